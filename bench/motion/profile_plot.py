#!/usr/bin/env python3
"""Speed against time over one section of the `cam` program (bench/motion/jerk.sh):
ours at two jerk limits and LinuxCNC, from the 1 ms samples.

usage: profile_plot.py OUTDIR PNG [--jerks 50,1000] [--section slot]

OUTDIR is jerk.sh's output directory (ours_cam_jJ.csv, lcnc_cam.tsv).
Sections (by X range, cutting depth Z < -0.99): square 15..65, ellipse
85..175, slot 195..305, helix 315..345. Time starts at the section's first
sample at cutting depth. Needs matplotlib.
"""
import math
import os
import sys

SECTIONS = {"square": (15, 65), "ellipse": (85, 175), "slot": (195, 305), "helix": (315, 345)}


def read(path):
    rows = []
    with open(path) as f:
        head = f.readline().strip()
        sep = "\t" if "\t" in head else ","
        cols = head.split(sep)
        names = ("t_s", "x_mm", "y_mm", "z_mm") if sep == "\t" else ("t", "x_set", "y_set", "z_set")
        idx = [cols.index(c) for c in names]
        for ln in f:
            v = ln.rstrip("\n").split(sep)
            if len(v) >= len(cols):
                rows.append(tuple(float(v[i]) for i in idx))
    return rows


def section(rows, lo, hi):
    """Times from the section start and speeds (central differences)."""
    inside = [i for i in range(1, len(rows) - 1) if lo <= rows[i][1] <= hi and rows[i][3] < -0.99]
    if not inside:
        return [], []
    i0, i1 = inside[0], inside[-1]
    t0 = rows[i0][0]
    ts, vs = [], []
    for i in range(i0, i1 + 1):
        ts.append(rows[i][0] - t0)
        vs.append(math.dist(rows[i + 1][1:], rows[i - 1][1:]) / (rows[i + 1][0] - rows[i - 1][0]))
    return ts, vs


def main(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    out, png = argv[0], argv[1]
    jerks = ["50", "1000"]
    sec = "slot"
    if "--jerks" in argv:
        jerks = argv[argv.index("--jerks") + 1].split(",")
    if "--section" in argv:
        sec = argv[argv.index("--section") + 1]
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    lo, hi = SECTIONS[sec]
    fig, ax = plt.subplots(figsize=(11, 4.5), dpi=110)
    runs = [("LinuxCNC 2.9 (no jerk limit)", os.path.join(out, "lcnc_cam.tsv"), "k")]
    colours = ["tab:blue", "tab:red", "tab:green", "tab:orange"]
    for j, c in zip(jerks, colours):
        runs.append((f"ours, {j} m/s³", os.path.join(out, f"ours_cam_j{j}.csv"), c))
    for label, path, c in runs:
        if not os.path.exists(path):
            continue
        ts, vs = section(read(path), lo, hi)
        if ts:
            ax.plot(ts, vs, color=c, lw=1.0, label=f"{label}: {ts[-1]:.2f} s")
    ax.set_xlabel("time from the section's first sample at depth, s")
    ax.set_ylabel("path speed, mm/s")
    ax.set_title(f"cam program, {sec} section (F6000, G64 P0.01, 100 mm/s, 1000 mm/s² per axis)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(png)
    print(f"wrote {png}")


if __name__ == "__main__":
    main(sys.argv[1:])
