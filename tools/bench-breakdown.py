#!/usr/bin/env python3
"""The breakdown of BENCHMARKS.md (issue 13, item 7): where our triangles go.

    python3 tools/bench-breakdown.py [--tessera BIN] [--work DIR] [--models dragon,...]
                                     [--write BENCHMARKS.md] [--reuse]

For each model: `tessera build SOURCE -o WORK/MODEL.tsr` (the defaults), then `tessera bench
breakdown REPO --source SOURCE --json` (8 views, 1920×1080, τ = 0.25 … 16 px, CPU cuts
measured two-sided over visible samples; no GPU). Prints, per model, each τ's cut under the
run-time sphere projection and under a box projection of each diamond's own patches, the
box's triangles against the sphere's at equal measured p99 and max error (each rule's Pareto
front, log-log interpolated, as `tools/bench-leaf-size.py` reads fronts), and per level the
share of gathered triangles kept, the share of kept triangles on the locked border, the
diamonds whose stored error saturation took from a child, and the counterfactuals (each
diamond simplified again with its border locked and free; stored against own error). With --write FILE the tables
replace the block between `<!-- bench-breakdown:begin -->` and `<!-- bench-breakdown:end -->`.
--reuse makes the tables from the JSON a previous run left in --work.
"""

import argparse
import datetime
import importlib.util
import json
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.dont_write_bytecode = True  # no __pycache__ in tools/
sys.path.insert(0, str(ROOT / "tools"))
from benchmarks_block import replace_block  # noqa: E402
MESH = ROOT / "testdata" / "mesh"
MODELS = {
    "dragon": MESH / "dragon_vrip.ply.gz",
    "armadillo": MESH / "armadillo.off",
    "lion-head": MESH / "lion-head.off",
}
LEVELS = {"p99": [0.25, 0.5, 1.0, 2.0, 4.0], "max": [0.5, 1.0, 2.0, 4.0, 8.0]}

_spec = importlib.util.spec_from_file_location("leaf", ROOT / "tools" / "bench-leaf-size.py")
leaf = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(leaf)


def run(cmd, **kw):
    print("+", " ".join(str(c) for c in cmd), file=sys.stderr, flush=True)
    return subprocess.run(cmd, check=True, **kw)


def tables(name, source, b):
    out = [
        f"**{name}** (`{source.relative_to(ROOT)}`)",
        "",
        "| τ px | sphere: triangles | max px | p99 px | box: triangles | max px | p99 px |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in b["projection"]:
        s, x = r["sphere"], r["box"]
        out.append(
            f"| {r['tolerance']:g} | {s['triangles']:,.0f} | {s['error_max_px']:.2f} | "
            f"{s['error_p99_px']:.3f} | {x['triangles']:,.0f} | {x['error_max_px']:.2f} | "
            f"{x['error_p99_px']:.3f} |"
        )
    rows = {rule: [r[rule] for r in b["projection"]] for rule in ("sphere", "box")}
    out.append("")
    for statistic, levels in LEVELS.items():
        cells = []
        for level in levels:
            ks, ts = leaf.at_error(rows["sphere"], level, statistic)
            kb, tb = leaf.at_error(rows["box"], level, statistic)
            bound = "" if ks == kb == "≈" else f" ({kb}/{ks} bounds)"
            cells.append(f"{level:g} px {tb / ts:.2f}×{bound}")
        out.append(f"Box ÷ sphere triangles at equal measured {statistic}: " + "; ".join(cells) + ".")
        out.append("")
    out += [
        "| level | diamonds | gathered | kept | kept ÷ gathered | kept on the border | saturated |",
        "|---|---|---|---|---|---|---|",
    ]
    for l in b["levels"]:
        out.append(
            f"| {l['level']} | {l['diamonds']:,} | {l['gathered']:,} | {l['kept']:,} | "
            f"{l['kept'] / max(l['gathered'], 1):.3f} | "
            f"{l['kept_on_border'] / max(l['kept'], 1):.3f} | {l['saturated']:,} |"
        )
    out.append("")
    f2 = lambda x: "—" if x is None else f"{x:.2f}"
    out += [
        "Each diamond simplified again from its gathered patches (meshoptimizer as the build "
        "calls it): with its border locked down to the triangles it kept, and free; the "
        "stored error against the locked arm's (the own error recomputed):",
        "",
        "| level | diamonds | kept, locked | kept free at the locked error | free ÷ locked | "
        "locked ÷ free error at equal count (median) | stored ÷ own error: median | p90 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for l in b.get("locks", []):
        out.append(
            f"| {l['level']} | {l['diamonds']:,} | {l['kept_locked']:,} | "
            f"{l['kept_free_at_equal_error']:,} | "
            f"{l['kept_free_at_equal_error'] / max(l['kept_locked'], 1):.3f} | "
            f"{f2(l['error_ratio_median'])} | {f2(l['raise_median'])} | {f2(l['raise_p90'])} |"
        )
    kept = sum(l["kept_locked"] for l in b.get("locks", []))
    free = sum(l["kept_free_at_equal_error"] for l in b.get("locks", []))
    if kept:
        out += ["", f"All levels: free ÷ locked triangles at equal error {free / kept:.3f}."]
    out.append("")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target" / "release" / "tessera"))
    ap.add_argument("--work", default="/tmp/tessera-bench-breakdown")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--write", help="the Markdown file whose marked block is replaced")
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    stamp = work / "run.json"
    if args.reuse:
        meta = json.loads(stamp.read_text())
    else:
        commit = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True,
        ).stdout.strip()
        meta = {
            "commit": commit,
            "load": os.getloadavg()[0],
            "started": datetime.datetime.now(datetime.timezone.utc).isoformat(),
        }
    lines = []
    for name in args.models.split(","):
        source = MODELS[name]
        saved = work / f"{name}.json"
        if not args.reuse:
            repo = work / f"{name}.tsr"
            run([args.tessera, "build", source, "-o", repo], stdout=subprocess.DEVNULL)
            result = run(
                [args.tessera, "bench", "breakdown", repo, "--source", source, "--json"],
                capture_output=True, text=True,
            )
            saved.write_text(result.stdout)
        lines += tables(name, source, json.loads(saved.read_text()))
    if not args.reuse:
        meta["finished"] = datetime.datetime.now(datetime.timezone.utc).isoformat()
        stamp.write_text(json.dumps(meta))
    started = datetime.datetime.fromisoformat(meta["started"])
    finished = datetime.datetime.fromisoformat(meta["finished"])
    header = [
        f"Made by `python3 tools/bench-breakdown.py --write BENCHMARKS.md` (tessera "
        f"{meta['commit']}), {started:%Y-%m-%d %H:%M}–{finished:%H:%M} UTC, load "
        f"{meta['load']:.1f} at the start; each model: `tessera build SOURCE -o REPO`, then "
        "`tessera bench breakdown REPO --source SOURCE --json` (8 views, 1920×1080, 20,000 "
        "samples a view and direction; CPU cuts with frustum and normal-cone culling; errors "
        "two-sided over visible samples, max a sampled lower bound). Deterministic: no times. "
        "No peer runs here: the cluster DAG's ratios quoted above are the leaf-size sweep's "
        "and the trade script's, each in its own run.",
        "",
    ]
    text = "\n".join(header + lines)
    print(text)
    if args.write:
        replace_block(args.write, "bench-breakdown", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
