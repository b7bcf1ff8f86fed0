#!/usr/bin/env python3
"""Blend or stop at a corner (issue 17, `blend::StopCost`): zigzags of six
lines (turns of 10–150°, G64 P 0.001–0.2, F600–F6000, lines of 2 and 20 mm)
checked three ways per machine file: every corner blended (`--blended`, a
build from before the rule), every corner an exact stop (`G61`, the same
build), and with the rule (`--rule`, the build under test). Prints the
programs where the rule is slower than the better of the other two and the
total cycle time of all programs each way.

    python3 bench/motion/corners.py --blended OLD/cnc --rule target/release/cnc MACHINE.toml ...

`--rule-before BIN` also checks each program with another build of the rule
(the build before a change to it) and prints its total beside the rule's, and
the programs where the two differ.
"""
import argparse
import itertools
import math
import os
import re
import subprocess
import tempfile


def prog(turn_deg, p, f, length, n=6):
    """A zigzag of `n` lines of `length` mm turning by ±turn_deg, with
    `G64 P<p>` (`G61` for p = 0)."""
    x, y, h = 0.0, 0.0, 0.0
    lines = ["G17 G90 G94", "G64 P%g" % p if p > 0 else "G61", "G00 X0 Y0 Z0", "G01 Z-1 F600"]
    for i in range(n):
        x += length * math.cos(h)
        y += length * math.sin(h)
        lines.append("G01 X%.4f Y%.4f F%g" % (x, y, f))
        h += math.radians(turn_deg) * (1 if i % 2 == 0 else -1)
    lines.append("M30")
    return "\n".join(lines) + "\n"


def cycle(binary, text, machine, path):
    with open(path, "w") as fh:
        fh.write(text)
    out = subprocess.run([binary, "check", path, "--machine", machine], capture_output=True, text=True).stdout
    m = re.search(r"\(([\d.]+) s\)", out)
    if not m:
        raise SystemExit("%s check failed: %s" % (binary, out))
    return float(m.group(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--blended", required=True, help="cnc built before the rule")
    ap.add_argument("--rule", required=True, help="cnc under test")
    ap.add_argument("--rule-before", help="another build of the rule, to compare with")
    ap.add_argument("machines", nargs="+")
    a = ap.parse_args()
    path = os.path.join(tempfile.mkdtemp(), "zigzag.nc")
    for machine in a.machines:
        worse, n, tot = 0, 0, [0.0, 0.0, 0.0, 0.0]
        before_tot, differ = 0.0, []
        for turn, p, f, length in itertools.product([10, 30, 60, 90, 120, 150], [0.001, 0.01, 0.05, 0.2],
                                                    [600, 3000, 6000], [2, 20]):
            b = cycle(a.blended, prog(turn, p, f, length), machine, path)
            s = cycle(a.blended, prog(turn, 0, f, length), machine, path)
            r = cycle(a.rule, prog(turn, p, f, length), machine, path)
            best = min(b, s)
            if a.rule_before:
                rb = cycle(a.rule_before, prog(turn, p, f, length), machine, path)
                before_tot += rb
                if abs(rb - r) > 0.0005:
                    differ.append("turn %d° P %g F%d lines %g mm: before %.3f s, after %.3f s (%+.3f)"
                                  % (turn, p, f, length, rb, r, r - rb))
            n += 1
            for i, v in enumerate((b, s, r, best)):
                tot[i] += v
            if r > best + 0.0015:
                worse += 1
                print("%s: turn %d° P %g F%d lines %g mm: blended %.3f s, stopped %.3f s, rule %.3f s (+%.3f)"
                      % (os.path.basename(machine), turn, p, f, length, b, s, r, r - best))
        print("%s: %d programs, the rule slower than the better of the two in %d; totals: blended %.2f s, "
              "stopped %.2f s, rule %.2f s, the better per program %.2f s"
              % (os.path.basename(machine), n, worse, *tot))
        if a.rule_before:
            for d in differ:
                print("  %s: %s" % (os.path.basename(machine), d))
            print("%s: the rule before %.2f s, after %.2f s; %d programs differ"
                  % (os.path.basename(machine), before_tot, tot[2], len(differ)))


if __name__ == "__main__":
    main()
