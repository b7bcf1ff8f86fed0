#!/usr/bin/env python3
"""Whole-process cost of commands side by side, alternated run by run
(A B C A B C ...) so that a machine whose speed drifts affects each alike:
wall time and CPU time (user + sys), median and range per
command, and the median of the per-round CPU ratios against the first.

usage: cost_ab.py [--runs N] NAME=COMMAND [NAME=COMMAND ...]

    python3 bench/cost_ab.py --runs 7 \\
        'before=/tmp/old/target/release/cnc check prog.ngc --machine mill' \\
        'after=target/release/cnc check prog.ngc --machine mill'

Each command runs through the shell with its output discarded; the first
line of its output from the first round is printed (a check's summary, a
simulation's cycle time) so that what was timed can be seen.
"""
import os
import resource
import statistics
import subprocess
import sys
import time


def run(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, shell=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if p.returncode != 0:
        sys.exit(f"exit {p.returncode}: {cmd}\n{p.stdout[-2000:]}")
    return wall, cpu, after.ru_maxrss, p.stdout


def main(argv):
    runs = 7
    if argv[:1] == ["--runs"]:
        runs, argv = int(argv[1]), argv[2:]
    if not argv or any("=" not in a for a in argv):
        sys.exit(__doc__)
    cmds = [tuple(a.split("=", 1)) for a in argv]
    res = {n: [] for n, _ in cmds}
    for r in range(runs):
        for n, c in cmds:
            wall, cpu, rss, out = run(c)
            res[n].append((wall, cpu))
            if r == 0:
                line = next((ln for ln in out.splitlines() if ln.strip()), "")
                print(f"{n}: {line.strip()[:200]}")
    print(f"\n{runs} rounds, alternated; CPU = user + sys of the whole process")
    print("| command | wall median (range) | CPU median (range) | CPU / first |")
    print("|---|---:|---:|---:|")
    first = cmds[0][0]
    for n, _ in cmds:
        w = [x[0] for x in res[n]]
        c = [x[1] for x in res[n]]
        ratio = statistics.median(x[1] / max(y[1], 1e-9) for x, y in zip(res[n], res[first]))
        print(
            f"| {n} | {statistics.median(w):.3f} s ({min(w):.3f}–{max(w):.3f}) "
            f"| {statistics.median(c):.3f} s ({min(c):.3f}–{max(c):.3f}) | {ratio:.2f} |"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
