#!/usr/bin/env bash
# A cold fly-through on a slow disk: `tessera bench stream` run on each repository in turn,
# rounds alternating, inside a cgroup whose reads from the repository's disk are throttled to
# --mbps MB/s (a network share or a USB hard disk; this machine's own disk returns the few MB a
# frame asks long before the frames that wait for them, so unthrottled the packed and the raw
# repository settle alike). Prints, per run, the cold and warm figures of `bench stream
# --json`: when the stream settled (frame, and seconds from the start with the reads), the
# time spent reading, and the median frame.
#
#   tools/stream-slow-disk.sh [--mbps 20] [--rounds 3] [--tessera BIN] REPO... [-- BENCH ARGS]
#
# e.g. tools/stream-slow-disk.sh --mbps 20 g20s.tsr g20s-raw.tsr -- --gpu-budget 32
# Needs root and the block-I/O throttle of cgroup v1 (blkio) or v2 (io). Linux only.
set -euo pipefail

MBPS=20
ROUNDS=3
TESSERA=${TESSERA:-target/release/tessera}
REPOS=()
while (($#)); do
    case $1 in
    --mbps) MBPS=$2; shift 2 ;;
    --rounds) ROUNDS=$2; shift 2 ;;
    --tessera) TESSERA=$2; shift 2 ;;
    --) shift; break ;;
    -*) echo "unknown option $1" >&2; exit 2 ;;
    *) REPOS+=("$1"); shift ;;
    esac
done
BENCH_ARGS=("$@")
((${#REPOS[@]})) || { echo "usage: $0 [--mbps N] [--rounds R] REPO... [-- BENCH ARGS]" >&2; exit 2; }
[[ $(id -u) == 0 ]] || { echo "$0: needs root (it makes a cgroup)" >&2; exit 2; }
[[ -x $TESSERA ]] || { echo "$0: no tessera binary at $TESSERA (--tessera BIN)" >&2; exit 2; }

# The whole disk under the repositories' file system (throttles apply to disks, not partitions).
dev=$(stat -c '%Hd:%Ld' "${REPOS[0]}")
if [[ -e /sys/dev/block/$dev/partition ]]; then
    dev=$(cat "$(readlink -f "/sys/dev/block/$dev")/../dev")
fi
for r in "${REPOS[@]}"; do
    [[ $(stat -c '%Hd:%Ld' "$r") == "$(stat -c '%Hd:%Ld' "${REPOS[0]}")" ]] \
        || { echo "$0: the repositories must be on one file system" >&2; exit 2; }
done
bps=$((MBPS * 1000 * 1000))

group=tessera-slow-disk-$$
if [[ -d /sys/fs/cgroup/blkio ]]; then
    cg=/sys/fs/cgroup/blkio/$group
    mkdir "$cg"
    echo "$dev $bps" >"$cg/blkio.throttle.read_bps_device"
elif grep -qw io /sys/fs/cgroup/cgroup.controllers 2>/dev/null; then
    grep -qw io /sys/fs/cgroup/cgroup.subtree_control || echo +io >/sys/fs/cgroup/cgroup.subtree_control
    cg=/sys/fs/cgroup/$group
    mkdir "$cg"
    echo "$dev rbps=$bps" >"$cg/io.max"
else
    echo "$0: no block-I/O throttle here (cgroup v1 blkio or v2 io)" >&2
    exit 2
fi
trap 'rmdir "$cg" 2>/dev/null || true' EXIT
echo "reads from disk $dev throttled to $MBPS MB/s ($cg)"

out=$(mktemp -d)
for ((round = 1; round <= ROUNDS; round++)); do
    for r in "${REPOS[@]}"; do
        json=$out/$round-$(basename "$r").json
        # The bench drops the file from the page cache itself before its cold run.
        bash -c 'echo $$ >"$1/cgroup.procs"; shift; exec "$@"' _ "$cg" \
            "$TESSERA" bench stream "$r" --json "${BENCH_ARGS[@]}" >"$json"
        python3 - "$json" "$round" "$r" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
for run in d["runs"]:
    s = run["summary"]
    settle = s["seconds_to_settle"]
    print(f"round {sys.argv[2]} {sys.argv[3]} ({s['patch_codec']}, {d['repository_bytes']} B) "
          f"{run['mode']}: page cache {100 * s['page_cache_share_before']:.0f} % before, "
          f"settled from frame {s['settled_from_frame']} at "
          f"{'never' if settle is None else f'{settle:.2f} s'}, {s['frames']} frames in "
          f"{s['seconds']:.2f} s, read {s['read_ms_total']:.1f} ms, "
          f"frame median {s['frame_ms_median']:.3f} ms")
EOF
    done
done
echo "JSON of every run: $out"
