#!/bin/bash
# Issue 11's memory figure under a GPU budget: the anonymous RSS of `tessera render` at
# --gpu-budget 32 on three views of a large repository, minus that of a small repository's
# roots-only frame, on Vulkan (lavapipe) and GL (llvmpipe), ROUNDS rounds alternating the
# binaries given (to compare two builds back to back).
#
#   tools/gpu-budget-rss.sh LARGE.tsr SMALL.tsr TESSERA [TESSERA...]
#   e.g. tessera gen mesh --triangles 20000000 -o g20m.ply && tessera build g20m.ply -o g20m.tsr
#        tessera build testdata/mesh/bunny00.off -o bunny.tsr
#        ROUNDS=3 tools/gpu-budget-rss.sh g20m.tsr bunny.tsr target/release/tessera
#
# One line per render: `rss_anon_peak_sampled_bytes` (RssAnon read after every frame: a lower
# bound of the peak) and its difference from the small repository's frame in MiB.
set -euo pipefail
large=$1 small=$2
shift 2
rounds=${ROUNDS:-3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
anon() { python3 -c "import json,sys; print(json.load(sys.stdin)['rss_anon_peak_sampled_bytes'])"; }
for round in $(seq "$rounds"); do
  for backend in vulkan gl; do
    for bin in "$@"; do
      base=$("$bin" render "$small" -o "$out/small.png" --tolerance 1e9 --json --backend $backend 2>/dev/null | anon)
      for view in 30,20,0.6:1 30,20,0.6:0.5 120,10,0.9:1; do
        orbit=${view%%:*} tau=${view##*:}
        "$bin" render "$large" -o "$out/large.png" --orbit "$orbit" --tolerance "$tau" \
          --gpu-budget 32 --json --backend $backend 2>/dev/null | python3 -c "
import json, sys
d = json.load(sys.stdin)
a = d['rss_anon_peak_sampled_bytes']
print('round $round $backend $bin orbit $orbit tau $tau triangles', d['triangles'],
      'resident', d['resident_bytes'], 'anon', a, 'small', $base,
      'over_small_MiB %.1f' % ((a - $base) / 2**20), flush=True)"
      done
    done
  done
done
