#!/usr/bin/env python3
"""Peak disk use of a running process's files under a directory (issue 12's comparison with
Nexus, whose nxsbuild keeps unnamed temporaries that `du` cannot see): every 0.25 s until PID
exits, the blocks of the regular files PID holds open under DIR (named or unlinked) plus the
named files in DIR, each file counted once. Prints the sampled maximum in bytes (a lower
bound of the true peak).

    tools/fd-disk-peak.py PID DIR
"""
import os
import sys
import time

pid, d = int(sys.argv[1]), os.path.realpath(sys.argv[2])
peak = 0
while os.path.exists(f"/proc/{pid}"):
    seen = {}
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            p = f"/proc/{pid}/fd/{fd}"
            try:
                target = os.readlink(p)
                if not target.startswith(d):
                    continue
                st = os.stat(p)
                if os.path.isfile(p):
                    seen[(st.st_dev, st.st_ino)] = st.st_blocks * 512
            except OSError:
                pass
    except OSError:
        break
    for root, _, files in os.walk(d):
        for f in files:
            try:
                st = os.stat(os.path.join(root, f))
                seen[(st.st_dev, st.st_ino)] = st.st_blocks * 512
            except OSError:
                pass
    peak = max(peak, sum(seen.values()))
    time.sleep(0.25)
print(peak)
