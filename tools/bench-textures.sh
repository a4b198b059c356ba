#!/bin/bash
# Issue 47's texture figures (BENCHMARKS.md, "Textures as pages"): a 2 M-triangle mesh with a
# 4096² texture (64 MiB of texels) against the same geometry without attributes, built under
# --memory 256M (ROUNDS rounds alternating; the textured input with BC1 pages, the default, and
# with RGBA8 pages), then drawn at 1280x720 from the whole-model view and three close views on
# Vulkan (lavapipe) and GL (llvmpipe) with and without --gpu-budget 32, each budgeted frame
# compared with the unbudgeted one.
#
#   [NEXUS=DIR] tools/bench-textures.sh [TESSERA] [WORKDIR]
set -euo pipefail
T=${1:-target/release/tessera}
T=$(realpath "$T")
dir=${2:-$(mktemp -d)}
testdata=$(realpath "$(dirname "$0")/../testdata")
cd "$dir"
rounds=${ROUNDS:-3}
[ -f g2m_tex.ply ] || $T gen mesh --triangles 2000000 --uv --texture 4096 -o g2m_tex.ply --json > /dev/null
[ -f g2m_plain.ply ] || $T gen mesh --triangles 2000000 -o g2m_plain.ply --json > /dev/null
for r in $(seq "$rounds"); do
  for m in plain bc1 rgba8; do
    input=g2m_tex.ply opt=(--texture-encoding "$m")
    [ $m = plain ] && input=g2m_plain.ply opt=()
    /usr/bin/time -v "$T" build $input -o g2m_$m.tsr --memory 256M "${opt[@]}" --json \
      > build.json 2> time.txt
    echo "build round $r $m wall $(grep 'Elapsed' time.txt | awk '{print $NF}')" \
      "rss_kB $(grep 'Maximum resident' time.txt | awk '{print $NF}') bytes $(stat -c %s g2m_$m.tsr)" \
      "texture_pages $(python3 -c "import json; print(json.load(open('build.json'))['texture_pages'])")"
  done
done
# The peer: Nexus on the same textured PLY (its default JPEG q95 textures baked per node), then
# compressed, where NEXUS names the directory holding nxsbuild and nxsedit.
if [ -n "${NEXUS:-}" ]; then
  mkdir -p nxtmp
  TMPDIR=$PWD/nxtmp "$NEXUS/nxsbuild" g2m_tex.ply -o g2m_tex.nxs > /dev/null 2>&1
  "$NEXUS/nxsedit" g2m_tex.nxs -z -o g2m_tex.nxz > /dev/null 2>&1
  echo "nexus nxs $(stat -c %s g2m_tex.nxs) nxz $(stat -c %s g2m_tex.nxz); ours bc1 $(stat -c %s g2m_bc1.tsr)"
fi
[ -f bunny.tsr ] || "$T" build "$testdata/mesh/bunny00.off" -o bunny.tsr > /dev/null
for be in vulkan gl; do
  base=$("$T" render bunny.tsr -o b.png --size 1280x720 --tolerance 1e9 --backend $be --json |
    python3 -c "import json,sys; print(json.load(sys.stdin)['rss_anon_peak_sampled_bytes'])")
  for view in 30,20,2.5 30,20,0.6 120,10,0.9 200,-10,0.7; do
    for b in none 32; do
      opt=()
      [ $b != none ] && opt=(--gpu-budget $b)
      "$T" render g2m_bc1.tsr -o "v_${be}_${view}_$b.png" --size 1280x720 --orbit $view \
        --mode color --tolerance 1 --backend $be "${opt[@]}" --json > v.json
      python3 -c "
import json; d = json.load(open('v.json')); t = d['textures']
print('$be view $view budget $b triangles', d['triangles'], 'max_gpu_bytes', d['max_resident_bytes'],
      'budget', d['budget_bytes'], 'pending_units', d['pending_units'],
      'err_over_tau %.3f' % d['max_error_over_tau'],
      'over_base_MiB %.1f' % ((d['rss_anon_peak_sampled_bytes'] - $base) / 2**20),
      'pool', t['pool_format'], t['pool_layers'], t['pool_bytes'], 'wanted', t['pages_wanted'],
      'resident', t['resident_pages'], 'settled', t['settled'], 'refused', t['pages_refused'])"
    done
    echo "$be $view: $("$T" compare "v_${be}_${view}_none.png" "v_${be}_${view}_32.png")"
  done
  echo "$be bc1 vs rgba8 pages, unbudgeted, 200,-10,0.7:" \
    "$("$T" render g2m_rgba8.tsr -o "r_$be.png" --size 1280x720 --orbit 200,-10,0.7 --mode color \
       --tolerance 1 --backend $be > /dev/null && "$T" compare "r_$be.png" "v_${be}_200,-10,0.7_none.png")"
done
