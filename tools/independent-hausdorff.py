#!/usr/bin/env python3
"""tessera's object-space cut distances checked by an independent tool (issue 13).

    tessera bench errors REPO --cuts N --write-cuts DIR --json > DIR/tessera.json
    python3 tools/independent-hausdorff.py DIR [--samples-per-triangle S]

For every cut written by `bench errors --write-cuts` (DIR/cut-K.ply against DIR/leaves.ply),
PyMeshLab's Hausdorff distance filter (MeshLab's Metro-style sampler: vertices, edges and
faces of the sampled mesh, exact nearest points on the target through a uniform grid) is run
both ways, and its two-sided maximum is compared with tessera's `sampled_distance` for the same
cut. Both are sampled lower bounds of the same Hausdorff distance, from independent samplers
and independent nearest-point code.

Prints one line per cut and a JSON summary on the last line; exits 1 when a cut differs by
more than --tolerance (default 5 %) relative to the larger of the two figures.

Needs `pip install pymeshlab` (tested with 2025.7.post1).
"""

import argparse
import json
import pathlib
import sys
import time

import pymeshlab


def directed(ms, sampled, target, samples):
    r = ms.get_hausdorff_distance(
        sampledmesh=sampled,
        targetmesh=target,
        savesample=False,
        samplevert=True,
        sampleedge=True,
        samplefauxedge=False,
        sampleface=True,
        samplenum=samples,
        # Search the whole model: a sample farther than maxdist would be dropped, not counted.
        maxdist=pymeshlab.PercentageValue(100.0),
    )
    return r["max"], r["n_samples"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", type=pathlib.Path)
    ap.add_argument("--samples-per-triangle", type=int, default=16)
    ap.add_argument("--tolerance", type=float, default=0.05)
    args = ap.parse_args()
    ours = json.loads((args.dir / "tessera.json").read_text())
    rows = []
    worst = 0.0
    for k, cut in enumerate(ours["cuts"]):
        path = args.dir / f"cut-{k}.ply"
        ms = pymeshlab.MeshSet()
        ms.load_new_mesh(str(args.dir / "leaves.ply"))
        ms.load_new_mesh(str(path))
        leaves_faces = ms.mesh(0).face_number()
        cut_faces = ms.mesh(1).face_number()
        start = time.time()
        to_leaves, n1 = directed(ms, 1, 0, args.samples_per_triangle * cut_faces)
        to_cut, n2 = directed(ms, 0, 1, args.samples_per_triangle * leaves_faces)
        seconds = time.time() - start
        theirs = max(to_leaves, to_cut)
        mine = cut["sampled_distance"]
        difference = abs(theirs - mine) / max(theirs, mine, 1e-300)
        worst = max(worst, difference)
        rows.append(
            {
                "cut": k,
                "epsilon": cut["epsilon"],
                "triangles": cut_faces,
                "tessera": mine,
                "tessera_samples": cut["samples"],
                "pymeshlab": theirs,
                "pymeshlab_cut_to_leaves": to_leaves,
                "pymeshlab_leaves_to_cut": to_cut,
                "pymeshlab_samples": n1 + n2,
                "relative_difference": difference,
                "seconds": seconds,
            }
        )
        print(
            f"cut {k}: ε {cut['epsilon']:.3e}, {cut_faces} triangles: tessera {mine:.4e} "
            f"({cut['samples']} samples), PyMeshLab {theirs:.4e} ({n1 + n2} samples; "
            f"cut→leaves {to_leaves:.4e}, leaves→cut {to_cut:.4e}): {100 * difference:.2f} %",
            flush=True,
        )
    print(json.dumps({"cuts": rows, "largest_relative_difference": worst,
                      "tolerance": args.tolerance}))
    return 0 if worst <= args.tolerance else 1


if __name__ == "__main__":
    sys.exit(main())
