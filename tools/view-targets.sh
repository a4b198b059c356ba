#!/usr/bin/env bash
# The viewer's target modes measured on a fly-through of the demo model (BENCHMARKS.md,
# "Viewer targets"): `tessera view` under Xvfb plays a camera path with --target-ms or
# --target-triangles and writes a frame log; after SETTLE frames, the median frame time of
# every 30-frame window is compared with the target, and the triangle count of every frame
# with the budget.
#
#   tools/view-targets.sh [OUT_DIR] [BACKEND]      (default /tmp/view-targets, vulkan)
#
# Needs xvfb-run and python3; targets: TARGETS_MS (default "60 120"), TARGETS_TRIANGLES
# (default "100000 300000"); SETTLE (default 60) frames are left out.
set -euo pipefail
out=${1:-/tmp/view-targets}
backend=${2:-vulkan}
settle=${SETTLE:-60}
tessera=${TESSERA:-$(dirname "$0")/../target/release/tessera}
mkdir -p "$out"
[ -f "$out/demo.tsr" ] || "$tessera" demo -o "$out/demo.tsr" --no-frames --views 4 >/dev/null
# Eight keyframes around the unit sphere, in and out between 1.15 and 2.2 radii.
python3 - "$out/path.json" <<'PY'
import json, math, sys
keys = []
for i in range(9):
    a = 2 * math.pi * i / 8
    r = 1.15 if i % 2 else 2.2
    keys.append({"eye": [r * math.cos(a), 0.35 * r, r * math.sin(a)], "target": [0, 0, 0]})
json.dump({"keyframes": keys, "frames_between": 40, "pause_frames": 0}, open(sys.argv[1], "w"))
PY
echo "{\"play\":\"$out/path.json\"}" > "$out/script.jsonl"
run() { # name, target flags...
  local name=$1; shift
  timeout -k 10 1200 xvfb-run -a -s "-screen 0 1400x900x24 -noreset" "$tessera" view "$out/demo.tsr" \
    --backend "$backend" --script "$out/script.jsonl" --frame-log "$out/$name.jsonl" "$@" \
    >/dev/null 2>"$out/$name.err"
}
for ms in ${TARGETS_MS:-60 120}; do run "ms$ms" --target-ms "$ms"; done
for n in ${TARGETS_TRIANGLES:-100000 300000}; do run "tri$n" --target-triangles "$n"; done
python3 - "$out" "$settle" ${TARGETS_MS:-60 120} -- ${TARGETS_TRIANGLES:-100000 300000} <<'PY'
import json, statistics, sys
out, settle = sys.argv[1], int(sys.argv[2])
rest = sys.argv[3:]
split = rest.index("--")
ms_targets, tri_targets = rest[:split], rest[split + 1:]
def frames(name):
    return [json.loads(l) for l in open(f"{out}/{name}.jsonl")][settle:]
for t in ms_targets:
    f = frames(f"ms{t}")
    meds = [statistics.median(x["frame_ms"] for x in f[i:i + 30]) for i in range(0, len(f) - 29, 30)]
    worst = max(abs(m / float(t) - 1) for m in meds)
    tris = statistics.median(x["triangles"] for x in f)
    print(f"target {t} ms: {len(f)} frames after {settle}, {len(meds)} windows, window medians "
          f"{min(meds):.1f}-{max(meds):.1f} ms (worst {100 * worst:.1f} % off), "
          f"median triangles {tris:.0f}, tolerance {min(x['tolerance'] for x in f):.3f}-"
          f"{max(x['tolerance'] for x in f):.3f} px")
for t in tri_targets:
    f = frames(f"tri{t}")
    offs = sorted(abs(x["triangles"] / float(t) - 1) for x in f)
    within = sum(o <= 0.05 for o in offs)
    meds = [statistics.median(x["triangles"] for x in f[i:i + 30]) for i in range(0, len(f) - 29, 30)]
    worst = max(abs(m / float(t) - 1) for m in meds)
    print(f"budget {t} triangles: {len(f)} frames after {settle}: {within} within 5 % "
          f"({100 * within / len(f):.1f} %), worst frame {100 * offs[-1]:.1f} % off, "
          f"p50 {100 * offs[len(offs) // 2]:.2f} %; 30-frame window medians worst "
          f"{100 * worst:.1f} % off")
PY
