"""Period jitter of /cnc/joint_setpoints as a stock ROS 2 subscriber sees it
(rclpy, default QoS), from the header stamps the control loop sets at each
wake-up, and the node's CPU use. Optionally sends 5 MB programs by
program_path (dry runs: checked, never moved) during the run and compares
the periods inside those check windows with the rest.

    python3 bench/loop_jitter.py --seconds 60 --node-pid PID [--big-program NAME --checks 10]
"""
import argparse
import os
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState

from cnc_msgs.srv import RunProgram


def cpu_seconds(pid):
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pct(sorted_vals, p):
    if not sorted_vals:
        return float("nan")
    i = min(len(sorted_vals) - 1, int(round(p / 100.0 * (len(sorted_vals) - 1))))
    return sorted_vals[i]


def stats(periods_us, nominal_us):
    dev = sorted(abs(p - nominal_us) for p in periods_us)
    return {
        "n": len(dev),
        "p50": pct(dev, 50), "p99": pct(dev, 99), "p99.9": pct(dev, 99.9), "max": dev[-1] if dev else float("nan"),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--node-pid", type=int, required=True)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--big-program", default="")
    ap.add_argument("--checks", type=int, default=10)
    ap.add_argument("--label", default="")
    ap.add_argument("--start-job", default="", help="program_path to run (for real) before measuring")
    a = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("jitter_probe")
    stamps = []
    node.create_subscription(JointState, "/cnc/joint_setpoints",
                             lambda m: stamps.append(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec), 10)
    cli = node.create_client(RunProgram, "/cnc/run_program")
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    stop = threading.Event()
    th = threading.Thread(target=lambda: [ex.spin_once(timeout_sec=0.05) for _ in iter(stop.is_set, True)], daemon=True)
    th.start()
    assert cli.wait_for_service(timeout_sec=30.0)
    if a.start_job:
        req = RunProgram.Request()
        req.program_path = a.start_job
        fut = cli.call_async(req)
        while not fut.done():
            time.sleep(0.001)
        assert fut.result().accepted, fut.result().message
    time.sleep(2.0)  # settle
    stamps.clear()
    c0, t0 = cpu_seconds(a.node_pid), time.time()
    windows = []  # (start ns, end ns) of checks, wall clock
    answers = []
    if a.big_program:
        gap = a.seconds / (a.checks + 1)
        for i in range(a.checks):
            time.sleep(max(0.0, t0 + (i + 1) * gap - time.time()))
            req = RunProgram.Request()
            req.program_path = a.big_program
            req.dry_run = True
            s = time.time_ns()
            fut = cli.call_async(req)
            while not fut.done():
                time.sleep(0.001)
            e = time.time_ns()
            r = fut.result()
            assert r.accepted, r.message
            windows.append((s, e))
            answers.append((e - s) / 1e9)
    time.sleep(max(0.0, t0 + a.seconds - time.time()))
    c1, t1 = cpu_seconds(a.node_pid), time.time()
    stop.set()
    th.join()
    st = list(stamps)
    nominal = 1e6 / a.rate
    raw = [(st[i + 1] - st[i]) / 1000.0 for i in range(len(st) - 1)]
    # a gap of two or more periods is a sample the subscriber did not get
    # (DDS keep-last-10 with a slow Python reader); the loop's own stalls
    # are in the node's lateness log
    keep = [i for i in range(len(raw)) if raw[i] < 1.5 * nominal]
    periods = [raw[i] for i in keep]
    st_p = [st[i] for i in keep]
    all_s = stats(periods, nominal)
    print("| %s | %d | %d | %.1f | %.1f | %.1f | %.1f | %.1f %% |" % (
        a.label or "loop", all_s["n"], len(raw) - len(keep), all_s["p50"], all_s["p99"], all_s["p99.9"], all_s["max"],
        100.0 * (c1 - c0) / (t1 - t0)))
    if windows:
        inside = [periods[i] for i in range(len(periods)) if any(w0 <= st_p[i] <= w1 for w0, w1 in windows)]
        outside = [periods[i] for i in range(len(periods)) if not any(w0 <= st_p[i] <= w1 for w0, w1 in windows)]
        si, so = stats(inside, nominal), stats(outside, nominal)
        print("| %s: during 5 MB checks | %d | | %.1f | %.1f | %.1f | %.1f | |" % (a.label, si["n"], si["p50"], si["p99"], si["p99.9"], si["max"]))
        print("| %s: outside checks | %d | | %.1f | %.1f | %.1f | %.1f | |" % (a.label, so["n"], so["p50"], so["p99"], so["p99.9"], so["max"]))
        print("check answers: %s s" % ", ".join("%.2f" % x for x in answers))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
