#!/usr/bin/env python3
"""Runs a command and samples its anonymous resident memory (RssAnon in /proc/PID/status)
about every 2 ms until it exits; prints the number of samples and the largest (a sampled
maximum: a lower bound of the peak, but far denser than `render --json`'s
`rss_anon_peak_sampled_bytes`, which reads RssAnon once a frame). The kernel keeps a
high-water mark for the whole resident set only (VmHWM, file pages included), so the
anonymous part's peak can only be sampled.

    tools/rss-anon-peak.py tessera render g20m.tsr -o g.png --gpu-budget 32 --json
"""

import subprocess
import sys
import time


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
    samples, peak = 0, 0
    while child.poll() is None:
        try:
            with open(f"/proc/{child.pid}/status") as status:
                for line in status:
                    if line.startswith("RssAnon:"):
                        peak = max(peak, int(line.split()[1]) * 1024)
                        samples += 1
        except OSError:
            pass
        time.sleep(0.002)
    print(f"exit {child.returncode} samples {samples} rss_anon_peak_sampled_bytes {peak}")
    sys.exit(child.returncode)


if __name__ == "__main__":
    main()
