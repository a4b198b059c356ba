#!/usr/bin/env python3
"""Regenerates the trade-off tables of BENCHMARKS.md (issues 13 and 46): `tessera bench` per
model, in two arms.

    python3 tools/bench-trade.py [--tessera BIN] [--work DIR] [--models dragon,armadillo,...]
                                 [--error-views N] [--one-arm] [--write BENCHMARKS.md]

For each model: builds its repository when missing (`tessera build SOURCE -o WORK/NAME.tsr
[FLAGS]`), runs `tessera bench REPO --source SOURCE --json --plot DIR` (8 timed views,
1920×1080, 20,000 sparse samples a view and direction, 5 timed runs, and the dense error at
`--error-views` of `check --errors`'s eyes, 16 by default: the bench's defaults), then the
`--two-sided` arm (`--error-views 0`: the dense error never culls, so it is the first arm's;
only the frames differ: no cone or back-face culling for anyone), keeps the JSON in WORK, and
prints one Markdown table per model: for ours and each peer, at each τ, the dense max error
(every sample at the check's density, both ways, visible or not, against the input) with its
triangles (no culling, mean over the check's eyes), the frame's triangles, the sparse visible
max and p99, and the wall time of both arms (median of the runs, fastest–slowest); then the
verdict front to front on the dense max (ours ÷ each peer's triangles at 0.5 px … the peer's
coarsest, read off both Pareto fronts) and its worst ratio. With --write FILE the tables
replace the block between the lines `<!-- bench-trade:begin -->` and `<!-- bench-trade:end -->`
in FILE, with the commands, the date, the machine's load and the tessera commit that made them.

The error columns are deterministic (fixed cameras and seeds; the dense error has no random
sample at all); the times depend on the machine: compare times only within one run of this
script.
"""

import argparse
import datetime
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
DEM = ROOT / "testdata" / "dem"

# name: (source, build flags)
MODELS = {
    "dragon": (MESH / "dragon_vrip.ply.gz", []),
    "dragon-bounded": (MESH / "dragon_vrip.ply.gz", ["--bounded-errors"]),
    "armadillo": (MESH / "armadillo.off", []),
    "lion-head": (MESH / "lion-head.off", []),
    "bear": (MESH / "bear.off", []),
    "chinese-dragon": (MESH / "ChineseDragon-10kv.off", []),
    # A terrain: the height field meshed as `build` meshes it; the mesh peers run on that mesh
    # (the terrain baselines, ROAM and RUSTiC, are `bench terrain`'s).
    "jacksboro": (DEM / "jacksboro_fault_dem.npz", []),
    "jacksboro-bounded": (DEM / "jacksboro_fault_dem.npz", ["--bounded-errors"]),
}

SUBJECTS = [("ours", "ours"), ("cluster_dag", "cluster DAG"), ("discrete_lod", "discrete LODs")]


def run(cmd, **kw):
    print("+", " ".join(str(c) for c in cmd), file=sys.stderr, flush=True)
    return subprocess.run(cmd, check=True, **kw)


def wall(r):
    return f"{r['wall_ms']:.1f} ({r['wall_ms_min']:.1f}–{r['wall_ms_max']:.1f})"


def ratio_text(ratio):
    sign = {"exact": "", "at_most": "≤ ", "at_least": "≥ ", "open": "? "}[ratio["kind"]]
    return f"{sign}{ratio['value']:.2f}"


def verdict_lines(bench):
    """The front-to-front verdict on the dense max: per peer, ours ÷ its triangles per level."""
    out = []
    for c in bench["verdict_dense"]:
        label = dict(SUBJECTS).get(c["peer"], c["peer"])
        # Consecutive levels with the same reading (an open order below both fronts) as one.
        groups = []
        for lv in c["levels"]:
            text = ratio_text(lv["ratio"])
            if groups and groups[-1][2] == text and lv["ratio"]["kind"] == "open":
                groups[-1][1] = lv["error_px"]
            else:
                groups.append([lv["error_px"], lv["error_px"], text])
        levels = "; ".join(
            (f"{lo:.2f} px" if lo == hi else f"{lo:.2f}–{hi:.2f} px") + f": {text}"
            for lo, hi, text in groups
        )
        worst = c["worst"]
        worst_text = (
            f"worst {ratio_text(worst['ratio'])} at {worst['error_px']:.2f} px"
            if worst
            else "no level decided"
        )
        beaten = [
            f"{lv['error_px']:.2f}"
            for lv in c["levels"]
            if lv["ratio"]["kind"] in ("exact", "at_least") and lv["ratio"]["value"] > 1.0
        ]
        where = (
            f"; it draws fewer triangles than ours at {', '.join(beaten)} px" if beaten else ""
        )
        out.append(
            f"- ours ÷ {label}, front to front at equal dense max ({levels}): **{worst_text}**"
            f"{where}."
        )
    return out


def peer_settings(bench):
    """The peers' settings as the run states them: the DAG's clod_build settings (`--dag`) and
    the discrete LODs' levels (`--lod-fractions`); runs before 2026-12-07 state neither."""
    dag = bench.get("cluster_dag", {}).get("settings")
    dag_text = f"cluster DAG `{dag['text']}`" if dag else "cluster DAG 128-triangle clusters"
    levels = bench.get("discrete_lod_levels", [])
    return f"{dag_text}, {len(levels)} discrete levels"


def table(name, source, flags, bench, both=None):
    rows = {"ours": bench["rows"]}
    rows.update(bench["peers"])
    rows_both = None
    if both is not None:
        rows_both = {"ours": both["rows"]}
        rows_both.update(both["peers"])
    full = bench["peers"]["full_resolution"][0]
    full_both = f", two-sided {wall(both['peers']['full_resolution'][0])}" if both else ""
    dense = bench["dense"]
    out = [
        f"**{name}** (`{source.relative_to(ROOT)}`{', ' + ' '.join(flags) if flags else ''}; "
        f"{bench['model_triangles']:,} triangles; full resolution wall ms {wall(full)}{full_both}; "
        f"dense pass {dense['cuts_measured']} cuts in {bench['seconds']['dense']:.0f} s; "
        f"{peer_settings(bench)})",
        "",
        "| τ px | subject | dense max px (eye) | dense triangles | frame triangles | sparse max px | "
        "sparse p99 px | wall ms (runs) | two-sided wall ms (runs) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i, tau_row in enumerate(bench["rows"]):
        for key, label in SUBJECTS:
            r = rows[key][i]
            d = r["dense"]
            dmax = d["max_px"]
            if dmax is None:
                dense_text = "∞"
            else:
                dense_text = f"{dmax:.2f}"
                if dmax > r["tolerance"]:
                    dense_text = f"**{dense_text}**"
            two = wall(rows_both[key][i]) if rows_both else "–"
            out.append(
                f"| {tau_row['tolerance']:g} | {label} | {dense_text} ({d['worst_view']}) | "
                f"{round(d['triangles']):,} | {round(r['triangles']):,} | "
                f"{r['error_max_px']:.2f} | {r['error_p99_px']:.3f} | {wall(r)} | {two} |"
            )
    out.append("")
    out += verdict_lines(bench)
    out.append("")
    out.append(
        f"Plots: `docs/bench/trade/{name}/` (`triangles_vs_max_error.png`: the trade and the "
        "fronts at equal dense max error; triangles, error and frame time against τ)."
    )
    out.append("")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target" / "release" / "tessera"))
    ap.add_argument("--work", default="/tmp/tessera-bench-trade")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--error-views", type=int, default=16,
                    help="eyes of the dense error pass (check --errors's; default 16)")
    ap.add_argument("--one-arm", action="store_true",
                    help="skip the --two-sided arm (its times only)")
    ap.add_argument("--write", help="the Markdown file whose marked block is replaced")
    args = ap.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    commit = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    started = datetime.datetime.now(datetime.timezone.utc)
    load = os.getloadavg()[0]
    lines = []
    for name in args.models.split(","):
        source, flags = MODELS[name]
        repo = work / f"{name}.tsr"
        if not repo.exists():
            run([args.tessera, "build", source, "-o", repo, *flags], stdout=subprocess.DEVNULL)
        plots = ROOT / "docs" / "bench" / "trade" / name
        result = run(
            [args.tessera, "bench", repo, "--source", source, "--json", "--plot", plots,
             "--error-views", str(args.error_views)],
            capture_output=True, text=True, env=env,
        )
        (work / f"{name}.json").write_text(result.stdout)
        both = None
        if not args.one_arm:
            result_both = run(
                [args.tessera, "bench", repo, "--source", source, "--json", "--two-sided",
                 "--error-views", "0"],
                capture_output=True, text=True, env=env,
            )
            (work / f"{name}-two-sided.json").write_text(result_both.stdout)
            both = json.loads(result_both.stdout)
        lines += table(name, source, flags, json.loads(result.stdout), both)
    finished = datetime.datetime.now(datetime.timezone.utc)
    header = [
        f"Made by `python3 tools/bench-trade.py --write BENCHMARKS.md` (tessera {commit}), "
        f"{started:%Y-%m-%d %H:%M}–{finished:%H:%M} UTC, load {load:.1f} at the start; each model: "
        "`tessera build SOURCE -o REPO [FLAGS]`, then `tessera bench REPO --source SOURCE --json "
        f"--error-views {args.error_views}` (8 timed views, 1920×1080, 20,000 sparse samples a "
        "view and direction, 5 timed runs)"
        + ("" if args.one_arm else " and the same with `--two-sided --error-views 0` (its times)")
        + ". **Dense max**: every subject's cut at "
        f"{args.error_views} eyes of `check --errors` (one in eight inside the model's box) and "
        "each τ, its own rule at the run-time projection without culling, measured as `check "
        "--errors` measures ours: 15 samples a drawn triangle and 6 a leaf, both ways, seen or "
        "not, against the input (the leaves) less the quantisation, in pixels; the largest over "
        "the eyes (the eye in brackets; bold: above τ), a sampled lower bound; dense triangles: "
        "the cut without culling, mean over those eyes. Frame triangles and the sparse columns: "
        "the timed views' frames (culled), two-sided errors over visible samples only (20,000 "
        "a view and direction). Times: the median run (fastest–slowest); two-sided: every "
        "subject draws both faces, no cone culling. The verdict reads both subjects' Pareto "
        "fronts over τ in (dense max, dense triangles) at 0.5 px ×√2 … the peer's coarsest "
        "(log-log interpolation; ≤ / ≥ where a level lies outside a front, ? where both do).",
        "",
    ]
    text = "\n".join(header + lines)
    print(text)
    if args.write:
        replace_block(args.write, "bench-trade", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
