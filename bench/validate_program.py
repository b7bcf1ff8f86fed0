#!/usr/bin/env python3
"""Independent sanity check of a program written by gen_program.py.

    python3 bench/validate_program.py FILE

Re-reads the text (no shared code with the generator) and checks: '\\n'
line endings, upper-case words only, no comments, F set before the first
feed move, every arc's |r_start - r_end| < 0.001 mm from the printed
numbers, and all positions, arc extremes included, inside X 0..500,
Y 0..500, Z -100..100. Prints a one-line summary; exit 1 on any failure.
"""

import math
import re
import sys

WORD = re.compile(r"([A-Z])(-?\d+(?:\.\d+)?)")
LIMITS = {"X": (0.0, 500.0), "Y": (0.0, 500.0), "Z": (-100.0, 100.0)}


def main() -> int:
    path = sys.argv[1]
    data = open(path, "rb").read()
    if b"\r" in data:
        print("FAIL: CR in file")
        return 1
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    feed = None
    counts = {"G00": 0, "G01": 0, "G02": 0, "G03": 0}
    worst = 0.0
    bad = 0
    lines = data.decode("ascii").split("\n")
    if lines[-1] == "":
        lines.pop()

    def fail(no, msg):
        nonlocal bad
        bad += 1
        if bad <= 10:
            print(f"FAIL line {no}: {msg}")

    def inside(no, x, y, z):
        for ax, v in (("X", x), ("Y", y), ("Z", z)):
            lo, hi = LIMITS[ax]
            if not lo <= v <= hi:
                fail(no, f"{ax}{v} outside {lo}..{hi}")

    for no, text in enumerate(lines, 1):
        words = WORD.findall(text)
        if " ".join(a + b for a, b in words) != text:
            fail(no, f"unexpected text {text!r}")
            continue
        w = {}
        g = None
        for a, b in words:
            if a == "G":
                if b in ("0", "00", "1", "01", "2", "02", "3", "03"):
                    g = "G0" + b[-1]
            else:
                w[a] = float(b)
        if "F" in w:
            feed = w["F"]
        if g is None:
            continue
        counts[g] += 1
        x = w.get("X", pos["X"])
        y = w.get("Y", pos["Y"])
        z = w.get("Z", pos["Z"])
        if g != "G00" and not feed:
            fail(no, "feed move before F")
        if g in ("G02", "G03"):
            if "I" not in w or "J" not in w:
                fail(no, "arc without I/J")
                continue
            cx, cy = pos["X"] + w["I"], pos["Y"] + w["J"]
            rs = math.hypot(pos["X"] - cx, pos["Y"] - cy)
            re_ = math.hypot(x - cx, y - cy)
            worst = max(worst, abs(rs - re_))
            if abs(rs - re_) >= 0.001:
                fail(no, f"radius mismatch {rs} vs {re_}")
            # extremes: conservative full-circle box
            inside(no, cx - rs, cy - rs, z)
            inside(no, cx + rs, cy + rs, z)
        inside(no, x, y, z)
        pos.update(X=x, Y=y, Z=z)
    if not lines or lines[-1].split()[-1] != "M30":
        fail(len(lines), "last block is not M30")
    motion = counts["G01"] + counts["G02"] + counts["G03"]
    print(
        f"{path}: {len(lines)} lines, {motion} feed blocks "
        f"(G01 {counts['G01']} G02 {counts['G02']} G03 {counts['G03']}), "
        f"worst |r_start-r_end| {worst:.6f} mm, {bad} problems"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
