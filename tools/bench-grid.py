#!/usr/bin/env python3
"""The position grid chosen from the error (issue 49), measured: for a model, the repository
built on the full lattice (`--lossless`), with the default grid (Nexus's rule on the smallest
first-level error e, 2^trunc(log2(0.05 e))) and with grids at most f x e for larger fractions
f; each one's bytes, step, quantisation error, and its tau = 1 lit frame against the lossless
build's full-resolution (tau = 1e-6) frame over model pixels (PSNR), beside the lossless
build's own tau = 1 frame, and the triangles each tau = 1 frame draws.

Usage: tools/bench-grid.py [--tessera BIN] [--model testdata/mesh/dragon_vrip.ply.gz]
       [--fractions 0.25,0.5,1,2] [--orbit 200,10,1.35] [--size 800x800]
Needs numpy and pillow.
"""

import argparse
import json
import math
import pathlib
import subprocess
import tempfile

import numpy as np
from PIL import Image

ROOT = pathlib.Path(__file__).resolve().parent.parent


def run(cmd):
    out = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))}: {out.stderr}")
    return out.stdout


def psnr_over_model(a, b):
    """PSNR (dB) of RGB image b against a over the pixels either shows the model on (the
    background is the top-left pixel's colour), as tools/bench-normals.py measures it."""
    a = np.asarray(Image.open(a).convert("RGB"), dtype=np.float64)
    b = np.asarray(Image.open(b).convert("RGB"), dtype=np.float64)
    background = a[0, 0]
    model = np.any(a != background, axis=2) | np.any(b != background, axis=2)
    mse = np.mean((a[model] - b[model]) ** 2)
    return float("inf") if mse == 0 else 10 * math.log10(255.0**2 / mse)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target/release/tessera"))
    ap.add_argument("--model", default=str(ROOT / "testdata/mesh/dragon_vrip.ply.gz"))
    ap.add_argument("--fractions", default="0.25,0.5,1,2")
    ap.add_argument("--orbit", default="200,10,1.35")
    ap.add_argument("--size", default="800x800")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)

        def build(name, flags):
            repo = tmp / f"{name}.tsr"
            b = json.loads(run([args.tessera, "build", args.model, "-o", repo, "--json"] + flags))
            return repo, b

        def render(repo, tau, name):
            png = tmp / f"{name}-{tau}.png"
            r = json.loads(run([args.tessera, "render", repo, "-o", png, "--tolerance", tau,
                                "--orbit", args.orbit, "--size", args.size, "--json"]))
            return png, r

        lossless, lb = build("lossless", ["--lossless"])
        default, db = build("default", [])
        grid = db.get("position_grid") or {}
        e = grid.get("first_level_error")
        reference, _ = render(lossless, "1e-6", "lossless")
        rows = [("lossless", lossless, lb, "--lossless"), ("default (Nexus's rule)", default, db, "")]
        for f in [float(x) for x in args.fractions.split(",") if x] if e else []:
            name = f"f{f:g}"
            repo, b = build(name, ["--position-step", f"{f * e:.6e}"])
            rows.append((f"at most {f:g} e", repo, b, f"--position-step {f * e:.6e}"))
        print(f"model {args.model}; first-level error e = {e}")
        print("| grid | flags | step (x, y, z) | quantisation error | repository bytes | "
              "tau = 1 triangles | PSNR tau = 1 vs lossless full resolution |")
        print("|---|---|---|---|---|---|---|")
        for name, repo, b, flags in rows:
            png, r = render(repo, "1", name.split()[0])
            step = ", ".join(f"{s:.3e}" for s in b["position_step"])
            triangles = r.get("triangles", r.get("drawn_triangles", "?"))
            print(f"| {name} | `{flags}` | {step} | {b['quantisation_error']:.3e} | "
                  f"{b['repository_bytes']:,} | {triangles} | "
                  f"{psnr_over_model(reference, png):.2f} dB |")


if __name__ == "__main__":
    main()
