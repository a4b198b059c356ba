#!/usr/bin/env python3
"""Regenerates the trade-off tables of BENCHMARKS.md (issue 13): one `tessera bench` per model.

    python3 tools/bench-trade.py [--tessera BIN] [--work DIR] [--models dragon,armadillo,...]
                                 [--write BENCHMARKS.md]

For each model: builds its repository when missing (`tessera build SOURCE -o WORK/NAME.tsr
[FLAGS]`), runs `tessera bench REPO --source SOURCE --json` (8 views, 1920×1080, 20,000
samples a view and direction, 5 timed runs: the bench's defaults), keeps the JSON in WORK, and
prints one Markdown table per model: for ours and each peer, at each τ, the triangles, the
two-sided visible max and p99 error and each direction's max, the PSNR over the model's pixels
and the wall time (median of the runs, fastest–slowest), then the verdict at equal measured
max. With --write FILE the tables replace the block between the lines
`<!-- bench-trade:begin -->` and `<!-- bench-trade:end -->` in FILE, with the commands, the
date, the machine's load and the tessera commit that made them.

The error columns are deterministic (fixed cameras and seeds); the times depend on the machine:
compare times only within one run of this script.
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


def table(name, source, flags, bench):
    rows = {"ours": bench["rows"]}
    rows.update(bench["peers"])
    full = bench["peers"]["full_resolution"][0]
    out = [
        f"**{name}** (`{source.relative_to(ROOT)}`{', ' + ' '.join(flags) if flags else ''}; "
        f"{bench['model_triangles']:,} triangles; full resolution "
        f"{full['wall_ms']:.1f} ms ({full['wall_ms_min']:.1f}–{full['wall_ms_max']:.1f}))",
        "",
        "| τ px | subject | triangles | max px | p99 px | max c→o | max o→c | samples | PSNR dB | wall ms (runs) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i, tau_row in enumerate(bench["rows"]):
        for key, label in SUBJECTS:
            r = rows[key][i]
            over = r["error_max_px"] > r["tolerance"]
            mx = f"**{r['error_max_px']:.2f}**" if over else f"{r['error_max_px']:.2f}"
            out.append(
                f"| {tau_row['tolerance']:g} | {label} | {round(r['triangles']):,} | {mx} | "
                f"{r['error_p99_px']:.3f} | {r['error_to_original']['max_px']:.2f} | "
                f"{r['error_to_cut']['max_px']:.2f} | {r['error_samples']:,} | {r['psnr']:.2f} | "
                f"{r['wall_ms']:.1f} ({r['wall_ms_min']:.1f}–{r['wall_ms_max']:.1f}) |"
            )
    out.append("")
    levels = []
    for c in bench["verdict_max"]:
        t = c["triangles"]
        dag = t["cluster_dag"]
        ratio = dag["value"] / t["ours"]["value"]
        kind = {"interpolated": "", "at_least": "≥ ", "at_most": "≤ "}.get(dag["kind"], "")
        levels.append(
            f"max {c['error_px']:.2f} px: DAG {kind}{ratio:.2f}× ours ({c['winner'] or 'undecided'})"
        )
    out.append("Verdict at equal measured max error: " + "; ".join(levels) + ".")
    out.append("")
    out.append(
        f"Plots: `docs/bench/trade/{name}/` (`triangles_vs_max_error.png`: the trade at equal "
        "max error; triangles, error and frame time against τ)."
    )
    out.append("")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tessera", default=str(ROOT / "target" / "release" / "tessera"))
    ap.add_argument("--work", default="/tmp/tessera-bench-trade")
    ap.add_argument("--models", default=",".join(MODELS))
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
            [args.tessera, "bench", repo, "--source", source, "--json", "--plot", plots],
            capture_output=True, text=True, env=env,
        )
        (work / f"{name}.json").write_text(result.stdout)
        lines += table(name, source, flags, json.loads(result.stdout))
    finished = datetime.datetime.now(datetime.timezone.utc)
    header = [
        f"Made by `python3 tools/bench-trade.py --write BENCHMARKS.md` (tessera {commit}), "
        f"{started:%Y-%m-%d %H:%M}–{finished:%H:%M} UTC, load {load:.1f} at the start; each model: "
        "`tessera build SOURCE -o REPO [FLAGS]`, then `tessera bench REPO --source SOURCE --json` "
        "(8 views, 1920×1080, 20,000 samples a view and direction, 5 timed runs). Errors: "
        "two-sided, visible samples only, pooled over views; max is the largest sample (a lower "
        "bound of the true distance), p99 is not a max (bold: max above τ). Times: the median "
        "run (fastest–slowest). Peers in the same runs; the verdict names who wins each level.",
        "",
    ]
    text = "\n".join(header + lines)
    print(text)
    if args.write:
        replace_block(args.write, "bench-trade", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
