#!/usr/bin/env python3
"""Counts the events of a speed profile that a jerk limit makes slower:
stops, dips and acceleration phases, from a 1 kHz sample file.

usage: lcnc_events.py FILE   (LinuxCNC's TSV, e.g. jerk.sh's lcnc_cam.tsv, or
                             our CSV: read as analyse.py reads samples)

  stops   runs of samples under 0.5 mm/s between moving ones
  dips    local minima of the speed (over +-20 ms) above 0.5 mm/s and under
          0.95 of the lower of the highest speeds in the 0.3 s before and after
  phases  runs of one sign of the path acceleration over 300 mm/s^2

Python 3 stdlib only.
"""
import collections
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import analyse  # noqa: E402


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    _, _, pts = analyse.read_samples(sys.argv[1])
    dt = 0.001
    v = [0.0] + [math.dist(pts[i], pts[i - 1]) / dt for i in range(1, len(pts))]
    stops, moving = 0, False
    for x in v:
        if x > 0.5:
            moving = True
        elif moving:
            stops, moving = stops + 1, False
    w, dips, i = 20, [], 20
    while i < len(v) - w:
        if v[i] == min(v[i - w:i + w + 1]) and v[i] > 0.5:
            around = min(max(v[max(0, i - 300):i]), max(v[i:i + 300]))
            if v[i] < 0.95 * around:
                dips.append(1 - v[i] / around)
                i += w
                continue
        i += 1
    phases, sign = 0, 0
    for k in range(1, len(v) - 1):
        a = (v[k + 1] - v[k - 1]) / (2 * dt)
        s = 1 if a > 300 else (-1 if a < -300 else 0)
        if s and s != sign:
            phases, sign = phases + 1, s
    depth = collections.Counter(round(d, 1) for d in dips)
    print(f"samples {len(v)}, stops {stops}, dips {len(dips)}, acceleration phases {phases}")
    print("dips by depth (share of the speed lost): "
          + ", ".join(f"{k:.1f}: {n}" for k, n in sorted(depth.items())))


if __name__ == "__main__":
    main()
