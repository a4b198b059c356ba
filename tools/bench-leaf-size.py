#!/usr/bin/env python3
"""The leaf-size sweep of BENCHMARKS.md (issue 13, item 5): what the patch size costs and buys.

    python3 tools/bench-leaf-size.py [--tessera BIN] [--work DIR] [--model dragon]
                                     [--sizes 128,256,...] [--write BENCHMARKS.md]

Seed 001 says the patch size must be found by experiment. For each leaf size L the script
builds the model with `tessera build SOURCE -o WORK/MODEL-L.tsr --leaf-triangles L --json`,
runs `tessera bench REPO --source SOURCE --json` (the trade: 8 views, 1920×1080, two-sided
visible error, 5 timed runs, the cluster DAG and the other peers in the same run) and
`tessera bench stream REPO --json` (the default fly-in under the default 32 MiB budget at
τ = 1 px, CPU traversal), and prints one Markdown table: the repository, the triangles each
method needs at fixed measured max errors (read off each method's front as the bench's verdict
does: Pareto front, log-log interpolation, "≥"/"≤" outside the measured range), the frame
time at τ = 1 px, and the stream's peak resident bytes and loads. With --write FILE the table
replaces the block between `<!-- bench-leaf:begin -->` and `<!-- bench-leaf:end -->`.

Errors and triangle counts are deterministic; times depend on the machine (compare them only
within one run of this script).
"""

import argparse
import datetime
import json
import math
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.dont_write_bytecode = True  # no __pycache__ in tools/
sys.path.insert(0, str(ROOT / "tools"))
from benchmarks_block import replace_block  # noqa: E402
MESH = ROOT / "testdata" / "mesh"
SOURCES = {
    "dragon": MESH / "dragon_vrip.ply.gz",
    "armadillo": MESH / "armadillo.off",
    "lion-head": MESH / "lion-head.off",
    "bear": MESH / "bear.off",
}
SIZES = [128, 256, 512, 1024, 2048, 4096, 8192]
# Measured errors (px) at which every method's triangles are compared: the max (a sampled
# lower bound, set by single samples, so its fronts are jagged) and the p99 (steadier).
LEVELS = {"max": [0.5, 1.0, 2.0, 4.0, 8.0], "p99": [0.25, 0.5, 1.0, 2.0, 4.0]}


def run(cmd, **kw):
    print("+", " ".join(str(c) for c in cmd), file=sys.stderr, flush=True)
    return subprocess.run(cmd, check=True, **kw)


def front(rows, statistic):
    """(error, triangles) of the rows no other row beats on both, finest first; the error is
    the rows' measured `statistic` ("max" or "p99")."""
    points = sorted((r[f"error_{statistic}_px"], r["triangles"]) for r in rows)
    kept = []
    for error, triangles in points:
        if not kept or triangles < kept[-1][1]:
            kept.append((error, triangles))
    return kept


def at_error(rows, level, statistic="max"):
    """(kind, triangles) a method needs for a measured `statistic` error of `level` px."""
    points = front(rows, statistic)
    if level < points[0][0]:
        return "≥", points[0][1]
    if level >= points[-1][0]:
        return "≤", points[-1][1]
    for (e0, t0), (e1, t1) in zip(points, points[1:]):
        if e0 <= level < e1:
            if e0 <= 0:
                return "≈", t0 + (t1 - t0) * (level - e0) / (e1 - e0)
            f = (math.log(level) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return "≈", math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    raise AssertionError("unreachable")


def cell(kind, triangles):
    return f"{'' if kind == '≈' else kind}{round(triangles):,}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target" / "release" / "tessera"))
    ap.add_argument("--work", default="/tmp/tessera-bench-leaf")
    ap.add_argument("--model", default="dragon", choices=sorted(SOURCES))
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)))
    ap.add_argument("--write", help="the Markdown file whose marked block is replaced")
    ap.add_argument(
        "--reuse", action="store_true",
        help="make the tables from the JSON a previous run left in --work (no build, no bench)",
    )
    args = ap.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    source = SOURCES[args.model]
    commit = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    started = datetime.datetime.now(datetime.timezone.utc)
    load = os.getloadavg()[0]
    results = []
    for size in map(int, args.sizes.split(",")):
        repo = work / f"{args.model}-{size}.tsr"
        saved = work / f"{args.model}-{size}.json"
        if args.reuse:
            kept = json.loads(saved.read_text())
            results.append((size, kept["build"], kept["bench"], kept["stream"]))
            continue
        build = json.loads(
            run(
                [args.tessera, "build", source, "-o", repo, "--leaf-triangles", str(size), "--json"],
                capture_output=True, text=True,
            ).stdout
        )
        bench = json.loads(
            run(
                [args.tessera, "bench", repo, "--source", source, "--json"],
                capture_output=True, text=True, env=env,
            ).stdout
        )
        stream = json.loads(
            run(
                [args.tessera, "bench", "stream", repo, "--json"], capture_output=True, text=True
            ).stdout
        )
        saved.write_text(
            json.dumps({"build": build, "bench": bench, "stream": stream})
        )
        results.append((size, build, bench, stream))

    lines = [
        "| leaf size | simplices | repository MB | triangles a patch | root error | ours at τ = "
        "16 px | frame ms at τ = 1 px (ours, DAG) | stream: peak resident MB, loads |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for size, build, bench, stream in results:
        ours, dag = bench["rows"], bench["peers"]["cluster_dag"]
        one = next(i for i, r in enumerate(ours) if r["tolerance"] == 1.0)
        coarse = next(r for r in ours if r["tolerance"] == 16.0)
        warm = next(r for r in stream["runs"] if r["mode"] == "warm")["summary"]
        lines.append(
            f"| {size:,} | {build['tetrahedra']:,} | {build['repository_bytes'] / 1e6:.2f} | "
            f"{build['mean_triangles_per_patch']:.0f} | {build['root_error']:.2e} | "
            f"{round(coarse['triangles']):,} | {ours[one]['wall_ms']:.1f}, "
            f"{dag[one]['wall_ms']:.1f} | {warm['peak_resident_bytes'] / 1e6:.2f}, "
            f"{warm['loads']:,} |"
        )
    for statistic, levels in LEVELS.items():
        heads = " | ".join(f"{statistic} {e:g} px" for e in levels)
        lines += [
            "",
            f"Triangles at equal measured {statistic} error, ours / cluster DAG (ours ÷ DAG):",
            "",
            f"| leaf size | {heads} |",
            "|---|" + "---|" * len(levels),
        ]
        for size, _, bench, _ in results:
            ours, dag = bench["rows"], bench["peers"]["cluster_dag"]
            cells = []
            for level in levels:
                ko, to = at_error(ours, level, statistic)
                kd, td = at_error(dag, level, statistic)
                ratio = f" ({to / td:.2f}×)" if ko == kd == "≈" else ""
                cells.append(f"{cell(ko, to)} / {cell(kd, td)}{ratio}")
            lines.append(f"| {size:,} | " + " | ".join(cells) + " |")
    finished = datetime.datetime.now(datetime.timezone.utc)
    stamp = work / f"{args.model}-run.json"
    if args.reuse:
        kept = json.loads(stamp.read_text())
        commit, load = kept["commit"], kept["load"]
        started, finished = (datetime.datetime.fromisoformat(kept[k]) for k in ("started", "finished"))
    else:
        stamp.write_text(json.dumps({
            "commit": commit, "load": load,
            "started": started.isoformat(), "finished": finished.isoformat(),
        }))
    header = [
        f"Made by `python3 tools/bench-leaf-size.py --model {args.model} --write BENCHMARKS.md` "
        f"(tessera {commit}), {started:%Y-%m-%d %H:%M}–{finished:%H:%M} UTC, load {load:.1f} at "
        f"the start; `{source.relative_to(ROOT)}`. Per leaf size: `tessera build SOURCE -o REPO "
        "--leaf-triangles L`, `tessera bench REPO --source SOURCE --json` (8 views, 1920×1080, "
        "two-sided visible error, 5 timed runs: the median's frame time) and `tessera bench "
        "stream REPO --json` (default fly-in, 32 MiB, τ = 1 px). Triangles at a measured "
        "error: each method's Pareto front over τ = 0.25 … 16 px, log-log interpolated; ≥ / ≤: "
        "outside its measured range. The cluster DAG does not depend on the leaf size: its "
        "column repeats, re-measured in each run.",
        "",
    ]
    text = "\n".join(header + lines)
    print(text)
    if args.write:
        replace_block(args.write, "bench-leaf", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
