"""Emulates a host that holds up its CPUs now and then, as a busy VM's
hypervisor does (steal time): one process per CPU, pinned to it, under
SCHED_FIFO 99 (above the nodes' loops), busy for 8-25 ms at random every
150-400 ms. Run it (as root) beside the ROS tests to rehearse them on such
a host; stop it with Ctrl-C or SIGTERM.

    python3 tests/ros/host_stalls.py [--cpus 0 1] [--min-ms 8] [--max-ms 25]

Unlike steal time it does not show in /proc/stat's steal column (the
tests' `host_stolen`); the simulator's own stall reports do show it.
"""
import argparse
import os
import random
import signal
import sys
import time


def hold(cpu, min_ms, max_ms, seed):
    os.sched_setaffinity(0, {cpu})
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(99))
    rnd = random.Random(seed)
    while True:
        time.sleep(rnd.uniform(0.15, 0.4))
        end = time.perf_counter() + rnd.uniform(min_ms, max_ms) / 1000.0
        while time.perf_counter() < end:
            pass


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cpus", type=int, nargs="+", default=sorted(os.sched_getaffinity(0)))
    ap.add_argument("--min-ms", type=float, default=8.0)
    ap.add_argument("--max-ms", type=float, default=25.0)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    if not 0 < a.min_ms <= a.max_ms <= 200:
        sys.exit("host_stalls: need 0 < --min-ms <= --max-ms <= 200")
    kids = []
    for i, cpu in enumerate(a.cpus):
        pid = os.fork()
        if pid == 0:
            try:
                hold(cpu, a.min_ms, a.max_ms, a.seed + i)
            except PermissionError as e:
                print("host_stalls: CPU %d: %s (SCHED_FIFO needs root)" % (cpu, e), file=sys.stderr)
                os._exit(2)
        kids.append(pid)
    print("host_stalls: holding CPUs %s for %g-%g ms every 150-400 ms" % (a.cpus, a.min_ms, a.max_ms), flush=True)

    def stop(*_):
        for k in kids:
            try:
                os.kill(k, signal.SIGKILL)
            except ProcessLookupError:
                pass
        sys.exit(0)

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    for _ in kids:
        os.wait()


if __name__ == "__main__":
    main()
