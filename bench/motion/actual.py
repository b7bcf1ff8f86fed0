"""What the simulated machine does at realistic jerk, over DDS and offline
(issue 17): the CAM-like program of jerk.sh (`gen.py cam`, `G64 P0.01`,
X/Y/Z at 100 mm/s and 1000 mm/s²) run at each jerk limit

- offline, `cnc simulate --csv` (setpoints and the in-process axes), and
- over DDS: `sim_axes` and `cnc_node` as two processes on one domain
  (loopback), the job sent on `/cnc_act/run_program`, recorded by the node
  with every topic (`--record-all`): `/cnc_act/joint_setpoints` and the
  simulated axes' `/sim_act/joint_states`, each stamped on the shared clock.

For each series (setpoints and actual positions, offline and over DDS): the
cycle time, the largest and the 99th-percentile distance from the
programmed path (analyse.py's), the largest |v|, |a| and |j| per axis from
finite differences at the 1 ms sample period, and the end error. Over DDS
also: the samples against the span of their stamps (none missing), the
setpoints that reached the simulator after their instant and its stalls
(from its log), the following error (actual at t against the setpoint applied at t, i.e.
stamped t − setpoint_delay_ms), and the largest difference between the
actual positions over DDS and offline (aligned by the setpoint delay).

    . .venv-ros/env.sh
    python3 bench/motion/actual.py [--jerks 50 200] [--out DIR] [--bin DIR]
                                   [--accel-ff F] [--program cam|helix_pairs]
                                   [--method filters|path|auto] [--contour-error MM]

`--program helix_pairs` runs `gen.py helix_pairs` under `G61` instead:
helical arcs of R 0.5, 2 and 10 mm, each from rest to rest (the arcs'
own path filter, no XYZ filter).

Bounded: every wait has a timeout, and both processes are stopped on exit.
"""
import argparse
import json
import math
import os
import re
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "ros"))

import analyse  # noqa: E402

VEL, ACC = 100, 1000
NS_CNC, NS_SIM = "/cnc_act", "/sim_act"
started = []


def stop_all():
    for p in started:
        if p.poll() is None:
            p.terminate()
    for p in started:
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(timeout=5)
    started.clear()


def machine_file(jerk, out, accel_ff=0.0, method="filters", contour_error=None):
    """config/mill.toml at VEL, ACC and `jerk` m/s³ on every axis (as jerk.sh),
    with the simulated drives' acceleration feed-forward `accel_ff` (0: none),
    planned by `method` ([planner] method: filters, path or auto), with
    `[planner] contour_error_mm = contour_error` if given."""
    with open(os.path.join(ROOT, "config", "mill.toml")) as f:
        text = f.read()
    if method != "auto":
        text = re.sub(r"(?m)^(lookahead_blocks = .*)$", r'\1\nmethod = "%s"' % method, text)
    if contour_error is not None:
        text = re.sub(r"(?m)^(lookahead_blocks = .*)$", r"\1\ncontour_error_mm = %g" % contour_error, text)
    if accel_ff:
        text = re.sub(r"(?m)^(max_velocity_mm_s = .*)$", r"\1\nservo_accel_feed_forward = %g" % accel_ff, text)
    text = re.sub(r"(?m)^max_velocity_mm_s = .*", "max_velocity_mm_s = %d.0" % VEL, text)
    text = re.sub(r"(?m)^max_acceleration_mm_s2 = .*", "max_acceleration_mm_s2 = %d.0" % ACC, text)
    text = re.sub(r"(?m)^max_jerk_mm_s3 = .*", "max_jerk_mm_s3 = %.1f" % (float(jerk) * 1000), text)
    text = re.sub(r"(?m)^program_dir = .*", 'program_dir = "%s"' % out, text)
    path = os.path.join(out, "mill_j%s.toml" % jerk)
    with open(path, "w") as f:
        f.write(text)
    m = re.search(r"(?m)^setpoint_delay_ms = ([\d.]+)", text)
    return path, float(m.group(1)) if m else 0.0


def series_stats(segs, P, dt=0.001, moving=None, stamps=None):
    """Path distance and finite-difference limits of a 1 ms series of XYZ (mm);
    with `moving` (a flag per sample) also the largest distance over the
    flagged samples and over the others; with `stamps` (s) the differences
    only over samples 1 ms apart (a sample the recording lacks leaves a gap,
    not a jump)."""
    eps = 1e-9
    if stamps is None:
        step = [True] * len(P)
    else:  # step[i]: samples i and i + 1 are 1 ms apart
        step = [i + 1 < len(P) and abs(stamps[i + 1] - stamps[i] - dt) < 2e-4 for i in range(len(P))]
    moved = [i for i in range(1, len(P)) if any(abs(P[i][k] - P[i - 1][k]) > eps for k in range(3))]
    k0, k1 = moved[0] - 1, moved[-1]
    v, a, j = [0.0] * 3, [0.0] * 3, [0.0] * 3
    for i in range(len(P)):
        for k in range(3):
            if i + 1 < len(P) and step[i]:
                v[k] = max(v[k], abs(P[i + 1][k] - P[i][k]) / dt)
            if 1 <= i < len(P) - 1 and step[i - 1] and step[i]:
                a[k] = max(a[k], abs(P[i + 1][k] - 2 * P[i][k] + P[i - 1][k]) / dt ** 2)
            if 1 <= i < len(P) - 2 and step[i - 1] and step[i] and step[i + 1]:
                j[k] = max(j[k], abs(P[i + 2][k] - 3 * P[i + 1][k] + 3 * P[i][k] - P[i - 1][k]) / dt ** 3 / 1000)
    grid = analyse.Grid(segs)
    devs, dmax, dline = [], 0.0, 0
    split = [0.0, 0.0]
    for i in range(k0, k1 + 1):
        d, si = grid.nearest(P[i])
        devs.append(d)
        if moving is not None:
            split[0 if moving[i] else 1] = max(split[0 if moving[i] else 1], d)
        if d > dmax:
            dmax, dline = d, segs[si]["line"]
    devs.sort()
    return {"cycle_s": round((k1 - k0) * dt, 3), "max_dev_mm": dmax, "max_dev_line": dline,
            "p99_dev_mm": devs[int(0.99 * (len(devs) - 1))],
            "max_v_mm_s": v, "max_a_mm_s2": a, "max_j_m_s3": j,
            "end_error_mm": math.dist(P[-1], segs[-1]["b"]),
            "max_dev_moving_mm": split[0], "max_dev_at_rest_mm": split[1]}


def moving(S, dt=0.001, speed=10.0):
    """Per sample: does the setpoint move at `speed` mm/s or more (the
    samples around it), or is it at rest (a stop, a hold)."""
    v = [math.dist(S[max(i - 1, 0)], S[min(i + 1, len(S) - 1)]) / (2 * dt) for i in range(len(S))]
    return [x >= speed for x in v]


def offline(cnc, prog, machine, out, jerk):
    csv = os.path.join(out, "offline_j%s.csv" % jerk)
    subprocess.run([cnc, "simulate", prog, "--machine", machine, "--csv", csv], check=True,
                   stdout=subprocess.DEVNULL, timeout=600)
    S, A = [], []
    with open(csv) as f:
        cols = f.readline().strip().split(",")
        ix = [cols.index(c) for c in ("x_set", "y_set", "z_set", "x_act", "y_act", "z_act")]
        for ln in f:
            r = ln.split(",")
            S.append(tuple(float(r[i]) for i in ix[:3]))
            A.append(tuple(float(r[i]) for i in ix[3:]))
    return S, A


def over_dds(a, machine, out, jerk):
    """(setpoints [(stamp s, xyz mm)], states [(stamp s, xyz mm)], reply) of one run over DDS."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from cnc_msgs.msg import ControllerStatus
    from cnc_msgs.srv import RunProgram
    from ros_nodes import read_mcap

    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    rec = os.path.join(out, "rec_j%s" % jerk)
    logs = [open(os.path.join(out, "%s_j%s.log" % (n, jerk)), "wb") for n in ("sim", "cnc")]
    started.append(subprocess.Popen(
        [os.path.join(a.bin, "sim_axes"), "--machine", machine, "--namespace", NS_SIM,
         "--controller-namespace", NS_CNC], cwd=ROOT, env=env, stderr=logs[0]))
    started.append(subprocess.Popen(
        [os.path.join(a.bin, "cnc_node"), "--machine", machine, "--namespace", NS_CNC,
         "--sim-namespace", NS_SIM, "--program-dir", out, "--record-all", "--record-dir", rec],
        cwd=ROOT, env=env, stderr=logs[1]))
    node = rclpy.create_node("actual_probe_j%s" % jerk)
    status = []
    node.create_subscription(ControllerStatus, NS_CNC + "/status", status.append, 100)
    cli = node.create_client(RunProgram, NS_CNC + "/run_program")
    ex = SingleThreadedExecutor()
    ex.add_node(node)

    def spin_until(cond, secs):
        t_end = time.time() + secs
        while time.time() < t_end and not cond():
            ex.spin_once(timeout_sec=0.05)
        return cond()

    if not spin_until(cli.service_is_ready, 60):
        raise RuntimeError(NS_CNC + "/run_program not there within 60 s")
    spin_until(lambda: False, 2.0)  # the simulator's first states reach the node
    req = RunProgram.Request()
    req.program_path = a.program + ".nc"
    req.record = True
    fut = cli.call_async(req)
    if not spin_until(fut.done, 60):
        raise RuntimeError("no reply within 60 s")
    reply = fut.result()
    if not reply.accepted:
        raise RuntimeError("refused: " + reply.message)

    def ended():
        mine = [m for m in status if m.job_id == reply.job_id]
        return any(m.state == ControllerStatus.STATE_RUNNING for m in mine) and mine[-1].state in (
            ControllerStatus.STATE_IDLE, ControllerStatus.STATE_ERROR)
    if not spin_until(ended, reply.estimated_duration + 60):
        raise RuntimeError("the job did not end")
    end = [m for m in status if m.job_id == reply.job_id][-1]
    if end.last_error:
        raise RuntimeError("the job ended in error: " + end.last_error)
    path = reply.recording if os.path.isabs(reply.recording) else os.path.join(ROOT, reply.recording)
    log = os.path.join(out, "cnc_j%s.log" % jerk)
    spin_until(lambda: ("job %d recorded" % reply.job_id) in open(log, "rb").read().decode(errors="replace"), 30)
    node.destroy_node()
    stop_all()
    for f in logs:
        f.close()
    got = read_mcap(path)

    def xyz(name):
        # (the recording names the topics /cnc/... and /sim/... whatever the namespaces)
        msgs = [d for topic, v in got.items() if topic.endswith("/" + name) for _, d in v]
        return sorted((d.header.stamp.sec + d.header.stamp.nanosec * 1e-9, tuple(p * 1000.0 for p in d.position))
                      for d in msgs)
    return xyz("joint_setpoints"), xyz("joint_states"), reply, path


def window(series, t0, t1):
    return [s for s in series if t0 - 1e-6 <= s[0] <= t1 + 1e-6]


def grid_check(series):
    """(samples, span in 1 ms cycles, largest gap in ms) of stamped samples."""
    if not series:
        return 0, 0, float("nan")
    span = round((series[-1][0] - series[0][0]) * 1000) + 1
    gap = max((b[0] - a[0] for a, b in zip(series, series[1:])), default=0.0) * 1000
    return len(series), span, gap


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jerks", nargs="*", default=["50", "200"], help="m/s³")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "out", "actual"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release"))
    ap.add_argument("--accel-ff", type=float, default=0.0,
                    help="the simulated drives' acceleration feed-forward, 0..1 (servo_accel_feed_forward)")
    ap.add_argument("--method", choices=("filters", "path", "auto"), default="filters",
                    help="the machine's [planner] method")
    ap.add_argument("--contour-error", type=float, default=None,
                    help="the machine's [planner] contour_error_mm (the path planner's)")
    ap.add_argument("--program", choices=("cam", "helix_pairs"), default="cam",
                    help="gen.py's program: cam (G64 P0.01) or helix_pairs (G61)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    a.out = os.path.abspath(a.out)
    signal.signal(signal.SIGTERM, lambda s, f: (stop_all(), sys.exit(128 + s)))
    prog = os.path.join(a.out, a.program + ".nc")
    mode = {"cam": "G64 P0.01", "helix_pairs": "G61"}[a.program]
    subprocess.run([sys.executable, os.path.join(HERE, "gen.py"), a.program, "--dialect", "cnc836",
                    "--mode", mode, "-o", prog], check=True)
    segs = analyse.parse_program(prog)
    cnc = os.path.join(a.bin, "cnc")
    import rclpy
    rclpy.init()
    results = {}
    try:
        for jerk in a.jerks:
            machine, delay_ms = machine_file(jerk, a.out, a.accel_ff, a.method, a.contour_error)
            s_off, a_off = offline(cnc, prog, machine, a.out, jerk)
            sp, st, reply, rec = over_dds(a, machine, a.out, jerk)
            # the job's span on the shared clock: its first to its last setpoint, and the
            # states until the last setpoint is applied (delay) and the axes have settled
            t_first, t_last = sp[0][0], sp[-1][0]
            st_job = window(st, t_first, t_last + delay_ms / 1000 + 0.2)
            sp_pos = [p for _, p in sp]
            st_pos = [p for _, p in st_job]
            # following error: the actual at t against the setpoint the simulator applied
            # then, i.e. the setpoints interpolated at t - delay
            sp_t = [t for t, _ in sp]
            fe = 0.0
            for t, p in st_job:
                x = (t - delay_ms / 1000 - t_first) * 1000
                k = math.floor(x)
                if 0 <= k < len(sp) - 1 and abs(sp_t[k] - t_first - k / 1000) < 1e-4:
                    f = x - k
                    q = tuple(u + (w - u) * f for u, w in zip(sp[k][1], sp[k + 1][1]))
                    fe = max(fe, math.dist(p, q))
            # actual over DDS against offline: offline row k is the axes after the step that
            # applied setpoint k; over DDS the simulator steps on its own grid, a fraction of a
            # cycle after the node's, and applies the setpoints interpolated at (step - delay),
            # so the state stamped t is compared with the offline rows interpolated at
            # (t - t_first) / 1 ms - delay
            diff, diff_k, matched = 0.0, -1, 0
            for t, p in st_job:
                x = (t - t_first) * 1000 - delay_ms
                k = math.floor(x)
                if 0 <= k < len(a_off) - 1:
                    f = x - k
                    q = tuple(u + (w - u) * f for u, w in zip(a_off[k], a_off[k + 1]))
                    matched += 1
                    if math.dist(p, q) > diff:
                        diff, diff_k = math.dist(p, q), k
            with open(os.path.join(a.out, "sim_j%s.log" % jerk), "rb") as f:
                log = f.read()
            late = sum(int(n) for n in re.findall(rb"(\d+) setpoints? arrived after their instant", log))
            stalls = [int(n) for n in re.findall(rb"stalled: (\d+) steps", log)]
            r = {
                "jerk_m_s3": jerk, "estimate_s": reply.estimated_duration, "recording": rec,
                "offline_set": series_stats(segs, s_off), "offline_act": series_stats(segs, a_off, moving=moving(s_off)),
                "dds_set": series_stats(segs, sp_pos, stamps=[t for t, _ in sp]),
                "dds_act": series_stats(segs, st_pos, stamps=[t for t, _ in st_job]),
                "dds_set_grid": grid_check(sp), "dds_act_grid": grid_check(st_job),
                "following_error_mm": fe, "dds_vs_offline_act_mm": diff, "dds_vs_offline_at_s": diff_k / 1000,
                "matched": matched, "late_setpoints": late, "sim_stalls": stalls,
            }
            results[jerk] = r
            print("jerk %s m/s³ done" % jerk, file=sys.stderr)
    finally:
        stop_all()
        rclpy.shutdown()
    with open(os.path.join(a.out, "actual.json"), "w") as f:
        json.dump(results, f, indent=1)
    print("| jerk m/s³ | series | cycle s | max / p99 distance from the path µm (line) "
          "| max \\|a\\| X / Y / Z mm/s² | max \\|j\\| X / Y / Z m/s³ | at the last setpoint: end error µm |")
    print("|---:|---|---:|---|---|---|---:|")
    names = {"offline_set": "setpoints, offline", "offline_act": "actual, offline",
             "dds_set": "setpoints, DDS", "dds_act": "actual (joint_states), DDS"}
    for jerk, r in results.items():
        for key, label in names.items():
            s = r[key]
            print("| %s | %s | %.3f | %.2f / %.2f (%d) | %s | %s | %.3f |" % (
                jerk, label, s["cycle_s"], s["max_dev_mm"] * 1000, s["p99_dev_mm"] * 1000, s["max_dev_line"],
                " / ".join("%.0f" % x for x in s["max_a_mm_s2"]),
                " / ".join("%.0f" % x for x in s["max_j_m_s3"]), s["end_error_mm"] * 1000))
    print()
    print("| jerk m/s³ | offline actual: max distance while the setpoint moves at 10 mm/s or more µm (cutting) | below 10 mm/s µm (stops, starts) |")
    print("|---:|---:|---:|")
    for jerk, r in results.items():
        print("| %s | %.2f | %.2f |" % (jerk, r["offline_act"]["max_dev_moving_mm"] * 1000,
                                     r["offline_act"]["max_dev_at_rest_mm"] * 1000))
    print()
    print("| jerk m/s³ | setpoints over DDS (samples / span, largest gap ms) | joint_states (samples / span, "
          "largest gap ms) | setpoints late at the simulator | simulator stalls (steps run late at once) "
          "| following error max µm "
          "| DDS actual vs offline actual max µm (at s; samples compared) |")
    print("|---:|---|---|---:|---|---:|---:|")
    for jerk, r in results.items():
        print("| %s | %d / %d, %.2f | %d / %d, %.2f | %d | %s | %.1f | %.3f (%.3f s; %d) |" % (
            jerk, *r["dds_set_grid"], *r["dds_act_grid"], r["late_setpoints"],
            ", ".join(str(n) for n in r["sim_stalls"]) or "none", r["following_error_mm"] * 1000,
            r["dds_vs_offline_act_mm"] * 1000, r["dds_vs_offline_at_s"], r["matched"]))


if __name__ == "__main__":
    main()
