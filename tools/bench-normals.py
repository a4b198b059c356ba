#!/usr/bin/env python3
"""Computed vertex normals on a scan without normals (issue 47, item 2), measured:

1. the leaves' stored normals against trimesh's angle-weighted vertex normals of the same
   input (`trimesh.Trimesh(process=False).vertex_normals`), vertex by vertex, crease vertices
   (two incident faces more than --crease degrees apart) counted apart;
2. the tau = 1 lit frame against the full-resolution (tau = 1e-6) lit frame over model pixels
   (PSNR), with the computed normals, and the same pair built with `--no-computed-normals`
   (today's face-normal shading) beside it.

Usage: tools/bench-normals.py [--tessera BIN] [--model testdata/mesh/bunny00.off]
       [--orbit 200,10,1.35] [--size 800x800] [--write BENCHMARKS.md]
Needs numpy, scipy, trimesh and pillow (pip install numpy scipy trimesh pillow).
"""

import argparse
import datetime
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
import trimesh
from PIL import Image
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


def psnr_over_model(a, b):
    """PSNR (dB) of RGB image b against a over the pixels either shows the model on (the
    background is the top-left pixel's colour)."""
    a = np.asarray(Image.open(a).convert("RGB"), dtype=np.float64)
    b = np.asarray(Image.open(b).convert("RGB"), dtype=np.float64)
    background = a[0, 0]
    model = np.any(a != background, axis=2) | np.any(b != background, axis=2)
    mse = np.mean((a[model] - b[model]) ** 2)
    share = model.mean()
    return (float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)), share


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target/release/tessera"))
    ap.add_argument("--model", default=str(ROOT / "testdata/mesh/bunny00.off"))
    ap.add_argument("--orbit", default="200,10,1.35")
    ap.add_argument("--size", default="800x800")
    ap.add_argument("--crease", type=float, default=60.0)
    ap.add_argument("--write", help="rewrite the bench-normals block of this file")
    args = ap.parse_args()
    commit = run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"]).strip()
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        smooth, faces = tmp / "smooth.tsr", tmp / "faces.tsr"
        run([args.tessera, "build", args.model, "-o", smooth])
        run([args.tessera, "build", args.model, "-o", faces, "--no-computed-normals"])
        frames = {}
        for name, repo in (("smooth", smooth), ("faces", faces)):
            for tau in ("1", "1e-6"):
                png = tmp / f"{name}-{tau}.png"
                cmd = [args.tessera, "render", repo, "-o", png, "--tolerance", tau,
                       "--orbit", args.orbit, "--size", args.size]
                if name == "smooth" and tau == "1e-6":
                    cmd += ["--export", tmp / "leaves.ply"]
                run(cmd)
                frames[name, tau] = png
        positions, stored = read_cut_ply(tmp / "leaves.ply")
        psnr_smooth, share = psnr_over_model(frames["smooth", "1e-6"], frames["smooth", "1"])
        psnr_faces, _ = psnr_over_model(frames["faces", "1e-6"], frames["faces", "1"])

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
    # Crease vertices: two incident faces more than --crease degrees apart.
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
    lines = [
        f"Made by `python3 tools/bench-normals.py --model {shown} --orbit {args.orbit} "
        f"--size {args.size}` (tessera {commit}), {started}; trimesh {trimesh.__version__}.",
        "",
        "| measure | value |",
        "|---|---|",
        f"| vertices compared (leaves, every input vertex) | {len(degrees):,} |",
        f"| crease vertices (two faces > {args.crease:g}° apart), apart | {int(crease.sum()):,} |",
        f"| non-crease within 1° of trimesh's angle-weighted normal | {within:.3f} % |",
        f"| non-crease angle: median / p99 / max | {np.median(smooth_deg):.4f}° / "
        f"{np.percentile(smooth_deg, 99):.4f}° / {smooth_deg.max():.4f}° |",
        f"| all vertices: max angle | {degrees.max():.4f}° |",
        f"| τ = 1 lit against τ = 1e-6 lit, computed normals (PSNR over model pixels) | "
        f"{psnr_smooth:.2f} dB |",
        f"| the same with face normals (`--no-computed-normals`) | {psnr_faces:.2f} dB |",
        f"| model pixels in the frame | {share * 100:.1f} % |",
    ]
    text = "\n".join(lines)
    print(f"{model}:\n{text}")
    if args.write:
        replace_block(args.write, "bench-normals", text)


if __name__ == "__main__":
    main()
