#!/usr/bin/env python3
"""Computed vertex normals on a scan without normals (issue 47, item 2), measured:

1. the leaves' stored normals (`render --tolerance 1e-6 --export leaves.ply`, every input
   vertex once) against trimesh's angle-weighted vertex normals of the same input
   (`trimesh.Trimesh(process=False).vertex_normals`), vertex by vertex. A *crease vertex* is
   one with an incident face whose normal is more than --crease / 2 degrees from trimesh's
   vertex normal (two incident faces up to --crease degrees apart); the others are the
   non-crease vertices the target (99 % within 1 degree) counts;
2. per view (--orbit, repeated), the tau = 1 lit frame against the full-resolution
   (tau = 1e-6) lit frame, PSNR over model pixels by `tessera compare` (pixels not the
   background in one frame or the other), with the computed normals; beside it the same pair
   with `--flat` (face normals, the same build), the pair built with `--no-computed-normals`
   (face normals, the shading before), and two diagnoses: the pair drawn with
   `render --supersample 4` (the same cuts, 16 samples a pixel, so the reference's aliasing of
   sub-pixel detail is left out), and the pair built with `--bounded-errors` (a finer cut
   whose errors are bounds).

Usage: tools/bench-normals.py [--tessera BIN] [--model testdata/mesh/bunny00.off]
       [--orbit 200,10,1.2 ...] [--size 800x800] [--normals-only] [--require]
       [--write BENCHMARKS.md]
--normals-only: measure 1 alone (one small frame for the export); --require: exit 1 when a
target is missed (99 % within 1 degree; 38 dB for the computed normals' frame).
Needs numpy, scipy and trimesh (pip install numpy scipy trimesh).
"""

import argparse
import datetime
import pathlib
import subprocess
import sys
import tempfile

import json

import numpy as np
import trimesh
from scipy.spatial import cKDTree

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
from benchmarks_block import replace_block  # noqa: E402


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{' '.join(map(str, cmd))}: exit {out.returncode}\n{out.stderr}")
    return out.stdout


def read_cut_ply(path):
    """The positions and normals of a cut `render --export` wrote (binary little-endian PLY:
    double x, y, z, then float nx, ny, nz when the repository has normals)."""
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    count = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    props = [l.split()[-1] for l in header if l.startswith("property ") and "list" not in l]
    if props[:6] != ["x", "y", "z", "nx", "ny", "nz"]:
        sys.exit(f"{path}: expected x y z nx ny nz first, found {props}")
    dtype = np.dtype([("p", "<f8", 3), ("n", "<f4", 3)] + [
        (f"_{i}", "<u1" if p in ("red", "green", "blue", "alpha") else "<f4")
        for i, p in enumerate(props[6:])
    ])
    vertices = np.frombuffer(data, dtype=dtype, count=count, offset=end)
    return vertices["p"].astype(np.float64), vertices["n"].astype(np.float64)


def compare(tessera, reference, frame):
    """`tessera compare --json` of `frame` against `reference`: PSNR over model pixels."""
    return json.loads(run([tessera, "compare", reference, frame, "--json"]))


def frame_pair(args, tmp, repo, orbit, name, extra=(), supersample=1):
    """The tau = 1 frame of `repo` against its tau = 1e-6 frame (`tessera compare --json`),
    both drawn with `render --supersample` (1: one sample a pixel)."""
    pngs = {}
    for tau in ("1e-6", "1"):
        pngs[tau] = tmp / f"{name}-{orbit}-{tau}.png"
        run([args.tessera, "render", repo, "-o", pngs[tau], "--orbit", orbit, "--size", args.size,
             "--tolerance", tau, "--supersample", str(supersample)] + list(extra))
    return compare(args.tessera, pngs["1e-6"], pngs["1"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target/release/tessera"))
    ap.add_argument("--model", default=str(ROOT / "testdata/mesh/bunny00.off"))
    ap.add_argument("--orbit", action="append",
                    help="AZ,EL,DIST; repeat for more views (default 200,10,1.2)")
    ap.add_argument("--size", default="800x800")
    ap.add_argument("--crease", type=float, default=60.0)
    ap.add_argument("--normals-only", action="store_true")
    ap.add_argument("--require", action="store_true")
    ap.add_argument("--write", help="rewrite the bench-normals block of this file")
    args = ap.parse_args()
    args.orbit = args.orbit or ["200,10,1.2"]
    git = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                         capture_output=True, text=True)
    commit = git.stdout.strip() if git.returncode == 0 else "of no git checkout"
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        smooth, faces, bounded = tmp / "smooth.tsr", tmp / "faces.tsr", tmp / "bounded.tsr"
        run([args.tessera, "build", args.model, "-o", smooth])
        leaves = tmp / "leaves.ply"
        run([args.tessera, "render", smooth, "-o", tmp / "export.png", "--tolerance", "1e-6",
             "--size", "64x64", "--export", leaves])
        positions, stored = read_cut_ply(leaves)
        if not args.normals_only:
            run([args.tessera, "build", args.model, "-o", faces, "--no-computed-normals"])
            run([args.tessera, "build", args.model, "-o", bounded, "--bounded-errors"])
            for orbit in args.orbit:
                rows.append((orbit, {
                    "smooth": frame_pair(args, tmp, smooth, orbit, "smooth"),
                    "flat": frame_pair(args, tmp, smooth, orbit, "flat", ["--flat"]),
                    "faces": frame_pair(args, tmp, faces, orbit, "faces"),
                    "supersampled": frame_pair(args, tmp, smooth, orbit, "ss", supersample=4),
                    "bounded": frame_pair(args, tmp, bounded, orbit, "bounded"),
                }))

    # trimesh on the same input, its vertices as the file has them.
    mesh = trimesh.load(args.model, process=False, force="mesh")
    reference = np.asarray(mesh.vertex_normals, dtype=np.float64)
    # Each exported vertex is an input vertex on tessera's position lattice: the nearest.
    distance, nearest = cKDTree(mesh.vertices).query(positions)
    diagonal = np.linalg.norm(mesh.bounds[1] - mesh.bounds[0])
    if distance.max() > 1e-5 * diagonal:
        sys.exit(f"an exported vertex is {distance.max()} from every input vertex")
    ref = reference[nearest]
    cos = np.einsum("ij,ij->i", stored / np.linalg.norm(stored, axis=1)[:, None], ref)
    degrees = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    # Crease vertices: an incident face more than --crease / 2 degrees from the vertex normal.
    face_normals = mesh.face_normals
    spread = np.zeros(len(mesh.vertices))
    for corner in range(3):
        v = mesh.faces[:, corner]
        angle = np.degrees(np.arccos(np.clip(
            np.einsum("ij,ij->i", face_normals, reference[v]), -1.0, 1.0)))
        np.maximum.at(spread, v, angle)
    crease = (2 * spread[nearest]) > args.crease
    smooth_deg = degrees[~crease]
    within = np.mean(smooth_deg <= 1.0) * 100

    model = pathlib.Path(args.model).name
    shown = pathlib.Path(args.model).resolve()
    shown = shown.relative_to(ROOT) if shown.is_relative_to(ROOT) else shown
    flags = " --normals-only" if args.normals_only else "".join(
        f" --orbit {o}" for o in args.orbit) + f" --size {args.size}"
    lines = [
        f"Made by `python3 tools/bench-normals.py --model {shown}{flags}` "
        f"(tessera {commit}), {started}; trimesh {trimesh.__version__}.",
        "",
        "| measure | value |",
        "|---|---|",
        f"| vertices compared (leaves, every input vertex) | {len(degrees):,} |",
        f"| crease vertices (an incident face > {args.crease / 2:g}° from the vertex normal), "
        f"apart | {int(crease.sum()):,} |",
        f"| non-crease within 1° of trimesh's angle-weighted normal | {within:.3f} % |",
        f"| non-crease angle: median / p99 / max | {np.median(smooth_deg):.4f}° / "
        f"{np.percentile(smooth_deg, 99):.4f}° / {smooth_deg.max():.4f}° |",
        f"| all vertices: max angle | {degrees.max():.4f}° |",
    ]
    if rows:
        w, h = (int(v) for v in args.size.lower().split("x"))
        lines += [
            "",
            f"τ = 1 lit frame against τ = 1e-6 lit frame, {args.size}, PSNR over model pixels "
            "(`tessera compare`):",
            "",
            "| `--orbit` | model pixels | computed normals | `--flat` | "
            "`--no-computed-normals` | computed, 4×4 supersampled | `--bounded-errors` |",
            "|---|---|---|---|---|---|---|",
        ]
        for orbit, f in rows:
            share = f["smooth"]["model_pixels"] / (w * h) * 100
            lines.append(
                f"| {orbit} | {share:.1f} % | **{f['smooth']['psnr_db']:.2f} dB** | "
                f"{f['flat']['psnr_db']:.2f} dB | {f['faces']['psnr_db']:.2f} dB | "
                f"{f['supersampled']['psnr_db']:.2f} dB | {f['bounded']['psnr_db']:.2f} dB |")
    text = "\n".join(lines)
    print(f"{model}:\n{text}")
    if args.write:
        replace_block(args.write, "bench-normals", text)
    missed = []
    if within < 99.0:
        missed.append(f"{within:.3f} % of the non-crease normals within 1° (target 99 %)")
    for orbit, f in rows:
        if f["smooth"]["psnr_db"] < 38.0:
            missed.append(f"{f['smooth']['psnr_db']:.2f} dB at --orbit {orbit} (target 38 dB)")
    if missed:
        print("missed: " + "; ".join(missed), file=sys.stderr)
        if args.require:
            sys.exit(1)


if __name__ == "__main__":
    main()
