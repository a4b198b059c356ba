#!/usr/bin/env python3
"""`tessera simplify` (seed 004's octree clustering) against peers at equal triangle counts,
in one run: PyMeshLab's quadric edge collapse (in core, Garland-Heckbert) and PyMeshLab's
vertex clustering on a uniform grid (Rossignac-Borrel; the grid clustering the seed compares
itself with, OoCS, places vertices by quadrics, this one by averaging). Every output is
measured by the same sampler: PyMeshLab's Hausdorff filter, one-sided from the output to the
input (Metro-style samples on vertices, edges and faces), in model units and as a fraction
of the input box's diagonal; time and peak RSS from `/usr/bin/time -v` around each run.

Usage: tools/simplify-peers.py [--tessera target/release/tessera] [--memory 64M]
                               [--mesh PATH]... [--targets 10000,100000] [--out DIR]
Needs `pip install pymeshlab`. Prints a Markdown table and a JSON line per row.
"""

import argparse
import gzip
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PEER = r"""
import sys, time, pymeshlab
kind, src, dst, target = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
ms = pymeshlab.MeshSet()
ms.load_new_mesh(src)
start = time.time()
if kind == "qec":
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=target, preservetopology=False,
                                                 qualitythr=0.3, optimalplacement=True)
else:
    # A cell size giving the target count: bisection on the cell (percent of the diagonal).
    lo, hi = 0.01, 20.0
    for _ in range(30):
        mid = (lo * hi) ** 0.5
        ms.set_current_mesh(0)
        ms.generate_copy_of_current_mesh()
        ms.meshing_decimation_clustering(threshold=pymeshlab.PercentageValue(mid))
        faces = ms.current_mesh().face_number()
        ms.delete_current_mesh()
        if abs(faces - target) <= 0.02 * target:
            break
        if faces > target:
            lo = mid
        else:
            hi = mid
    ms.set_current_mesh(0)
    ms.meshing_decimation_clustering(threshold=pymeshlab.PercentageValue(mid))
seconds = time.time() - start
ms.save_current_mesh(dst, binary=True, save_vertex_color=False, save_vertex_normal=False)
print(seconds)
"""

MEASURE = r"""
import sys, json, pymeshlab
ms = pymeshlab.MeshSet()
ms.load_new_mesh(sys.argv[1])  # the input: mesh 0
ms.load_new_mesh(sys.argv[2])  # the output: mesh 1
r = ms.get_hausdorff_distance(sampledmesh=1, targetmesh=0, samplevert=True, sampleedge=True,
                              sampleface=True, samplenum=int(sys.argv[3]))
print(json.dumps({"max": r["max"], "mean": r["mean"], "rms": r["RMS"],
                  "diagonal": ms.mesh(0).bounding_box().diagonal(),
                  "faces": ms.mesh(1).face_number()}))
"""


def timed(cmd):
    """Runs cmd under /usr/bin/time -v: (stdout, wall seconds, peak RSS bytes)."""
    out = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr}")
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", out.stderr).group(1))
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", out.stderr)
    parts = [float(p) for p in wall.group(1).split(":")]
    seconds = sum(p * 60 ** i for i, p in enumerate(reversed(parts)))
    return out.stdout, seconds, rss * 1024


def plain(path, work):
    """A path PyMeshLab reads: gzip undone, OFF/PLY as they are."""
    if path.endswith(".gz"):
        dst = os.path.join(work, os.path.basename(path)[:-3])
        with gzip.open(path, "rb") as f, open(dst, "wb") as g:
            shutil.copyfileobj(f, g)
        return dst
    return path


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tessera", default=os.path.join(ROOT, "target/release/tessera"))
    ap.add_argument("--memory", default="64M")
    ap.add_argument("--mesh", action="append")
    ap.add_argument("--targets", default="10000,100000")
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    meshes = args.mesh or [os.path.join(ROOT, "testdata/mesh/dragon_vrip.ply.gz")]
    work = args.out or tempfile.mkdtemp(prefix="simplify-peers-")
    os.makedirs(work, exist_ok=True)
    rows = []
    for mesh in meshes:
        src = plain(mesh, work)
        name = os.path.basename(mesh).split(".")[0]
        for target in [int(t) for t in args.targets.split(",")]:
            runs = []
            dst = os.path.join(work, f"{name}.{target}.tessera.ply")
            stdout, seconds, rss = timed([args.tessera, "simplify", mesh, "-o", dst,
                                          "--target-triangles", str(target),
                                          "--memory", args.memory, "--json"])
            own = json.loads(stdout)
            runs.append(("tessera simplify (seed 004)", dst, seconds, rss, own["error"]))
            for kind, label in [("qec", "PyMeshLab quadric edge collapse"),
                                ("grid", "PyMeshLab uniform-grid clustering")]:
                dst = os.path.join(work, f"{name}.{target}.{kind}.ply")
                _, seconds, rss = timed([sys.executable, "-c", PEER, kind, src, dst, str(target)])
                runs.append((label, dst, seconds, rss, None))
            for label, dst, seconds, rss, own_error in runs:
                m = json.loads(subprocess.run(
                    [sys.executable, "-c", MEASURE, src, dst, str(args.samples)],
                    capture_output=True, text=True, check=True).stdout)
                row = {"mesh": name, "target": target, "method": label,
                       "triangles": m["faces"], "seconds": seconds, "peak_rss_bytes": rss,
                       "max": m["max"], "mean": m["mean"], "rms": m["rms"],
                       "max_relative": m["max"] / m["diagonal"],
                       "mean_relative": m["mean"] / m["diagonal"],
                       "own_error": own_error}
                rows.append(row)
                print(json.dumps(row), flush=True)
    print()
    print("| mesh | target | method | triangles | max (% diag) | mean (% diag) | RMS | "
          "seconds | peak RSS MiB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['mesh']} | {r['target']:,} | {r['method']} | {r['triangles']:,} | "
              f"{100 * r['max_relative']:.3f} | {100 * r['mean_relative']:.4f} | "
              f"{r['rms']:.3e} | {r['seconds']:.2f} | {r['peak_rss_bytes'] / 2**20:.1f} |")


if __name__ == "__main__":
    main()
