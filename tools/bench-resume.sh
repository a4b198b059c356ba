#!/usr/bin/env bash
# Resuming a killed build (issue 12): a full `tessera build IN -o full.tsr --memory MEM`, then
# for each fraction F of its time a build killed with SIGKILL after F x that time and resumed
# with `--resume`, reporting the stage the checkpoint had reached, the resume's time as a
# fraction of the full build's, and whether the bytes are the full build's (cmp).
#
#   tools/bench-resume.sh IN.ply [MEM (256M)] [WORK_DIR (a new temporary one)] [FRACTIONS]
set -euo pipefail
in=$1
mem=${2:-256M}
dir=${3:-$(mktemp -d)}
fractions=${4:-"0.25 0.50 0.75"}
tessera=${TESSERA:-$(dirname "$0")/../target/release/tessera}
mkdir -p "$dir"
now() { date +%s.%N; }
rm -f "$dir/full.tsr" "$dir/out.tsr"
t0=$(now)
"$tessera" build "$in" -o "$dir/full.tsr" --memory "$mem" --json > "$dir/full.json"
full=$(echo "$(now) - $t0" | bc)
echo "full build: $full s ($(python3 -c "import json,sys; d=json.load(open('$dir/full.json')); print(', '.join(f\"{s['stage']} {s['seconds']:.2f}\" for s in d['stages']))"))"
for f in $fractions; do
    rm -f "$dir/out.tsr"
    "$tessera" build "$in" -o "$dir/out.tsr" --memory "$mem" > /dev/null 2>&1 &
    pid=$!
    sleep "$(echo "$f * $full" | bc)"
    kill -9 "$pid"
    wait "$pid" 2> /dev/null || true
    left=$([ -e "$dir/out.tsr" ] && echo "yes" || echo "nothing")
    stage=$(python3 -c "import json; s=json.load(open('$dir/.out.tsr.tessera-build/manifest.json'))['stages']; print(s[-1]['name'] if s else 'none')")
    t0=$(now)
    "$tessera" build "$in" -o "$dir/out.tsr" --memory "$mem" --resume > /dev/null 2>&1
    resume=$(echo "$(now) - $t0" | bc)
    same=$(cmp -s "$dir/full.tsr" "$dir/out.tsr" && echo "same bytes" || echo "DIFFERENT BYTES")
    printf 'kill -9 at %.0f%% (%.1f s): at the output: %s; checkpoint: %s; resume %.2f s = %.0f%% of the full build; %s\n' \
        "$(echo "$f * 100" | bc)" "$(echo "$f * $full" | bc)" "$left" "$stage" "$resume" \
        "$(echo "$resume * 100 / $full" | bc -l)" "$same"
done
