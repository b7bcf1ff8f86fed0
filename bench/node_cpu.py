"""CPU of one twin (cnc_node + sim_axes) at 1 kHz, idle and running a job,
as a new user measures it: utime + stime from /proc/PID/stat over a window,
in % of one core, per process and per thread (/proc/PID/task/TID/stat,
with each thread's wake-ups per second from .../status).
Several builds side by side in the same run, interleaved, several runs
each; medians.

    python3 bench/node_cpu.py --build before=/tmp/before/bin --build after=target/release [--runs 3]

Each run: both nodes started (lathe, their own namespaces), 4 s to settle,
an idle window, then bench/fleet/lathe_job.nc (G95, G33; 24 s) and a
window inside the job. With --node-args/--sim-args more options (e.g.
'--rt-priority 0'), with --no-sim the controller alone (idle only).
First it prints a host reference: the CPU time of the first build's
`cnc check` on bench/gen_program.py's 100,000 blocks, so shares taken on
hosts of different speed can be set side by side.
"""
import argparse
import os
import resource
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402

from cnc_msgs.msg import ControllerStatus  # noqa: E402
from cnc_msgs.srv import RunProgram  # noqa: E402


def cpu_s(path):
    with open(path) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wakeups(path):
    """Voluntary context switches of a thread (its wake-ups from a sleep or
    a wait), from /proc/PID/task/TID/status."""
    with open(path) as f:
        for line in f:
            if line.startswith("voluntary_ctxt_switches:"):
                return int(line.split()[1])
    return 0


def threads(pid):
    """{thread name: (cpu s, wake-ups)} (threads of one name summed)."""
    out = {}
    for tid in os.listdir("/proc/%d/task" % pid):
        try:
            with open("/proc/%d/task/%s/comm" % (pid, tid)) as f:
                name = f.read().strip()
            c, n = out.get(name, (0.0, 0))
            out[name] = (c + cpu_s("/proc/%d/task/%s/stat" % (pid, tid)),
                         n + wakeups("/proc/%d/task/%s/status" % (pid, tid)))
        except OSError:
            pass
    return out


def window(procs, secs, spin):
    """{proc name: (percent, {thread: (percent, wake-ups/s)})} over `secs`."""
    c0 = {k: (cpu_s("/proc/%d/stat" % p.pid), threads(p.pid)) for k, p in procs.items()}
    t0 = time.time()
    spin(secs)
    c1 = {k: (cpu_s("/proc/%d/stat" % p.pid), threads(p.pid)) for k, p in procs.items()}
    w = time.time() - t0
    if w > 1.5 * secs:
        # (the whole machine stalled: what was measured is not this window)
        return None

    def delta(k, t):
        (a, m), (b, n) = c0[k][1].get(t, (0.0, 0)), c1[k][1][t]
        return 100.0 * (b - a) / w, (n - m) / w
    return {k: (100.0 * (c1[k][0] - c0[k][0]) / w, {t: delta(k, t) for t in c1[k][1]}) for k in procs}


def one(a, label, bindir, run_no, node, extra=()):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    ns = "/cpu%s%d" % ("".join(c if c.isalnum() else "_" for c in label), run_no)
    procs = {}
    try:
        if not a.no_sim:
            procs["sim_axes"] = subprocess.Popen(
                [os.path.join(bindir, "sim_axes"), "--machine", "lathe", "--namespace", ns + "s",
                 "--controller-namespace", ns] + a.sim_args.split() + list(extra), cwd=ROOT, env=env, stderr=subprocess.DEVNULL)
        procs["cnc_node"] = subprocess.Popen(
            [os.path.join(bindir, "cnc_node"), "--machine", "lathe", "--namespace", ns, "--sim-namespace", ns + "s",
             "--program-dir", os.path.join(HERE, "fleet")] + a.node_args.split() + list(extra),
            cwd=ROOT, env=env, stderr=subprocess.DEVNULL)
        cli = node.create_client(RunProgram, ns + "/run_program")
        states = []
        sub = node.create_subscription(ControllerStatus, ns + "/status", lambda m: states.append(m.state), 10)
        ex = SingleThreadedExecutor()
        ex.add_node(node)

        def spin(secs):
            t_end = time.time() + secs
            while time.time() < t_end:
                ex.spin_once(timeout_sec=min(0.05, max(0.0, t_end - time.time())))
        t0 = time.time()
        while not cli.service_is_ready() and time.time() - t0 < 30:
            spin(0.1)
        spin(a.settle)
        res = {"idle": window(procs, a.window, spin)}
        if res["idle"] is None:
            print("run %d %s: the idle window took over 1.5 times its length (the machine stalled); left out"
                  % (run_no + 1, label), flush=True)
            del res["idle"]
        if not a.no_sim:
            req = RunProgram.Request()
            req.program_path = "lathe_job.nc"
            fut = cli.call_async(req)
            t0 = time.time()
            while not fut.done() and time.time() - t0 < 30:
                spin(0.01)
            assert fut.done() and fut.result().accepted, fut.result() if fut.done() else "no reply"
            spin(1.0)
            del states[:]
            res["running"] = window(procs, a.window, spin)
            # (a job that ended in the window, e.g. in ERROR on a busy
            # machine, did not run all of it: the run is left out)
            if res["running"] is None:
                print("run %d %s: the running window took over 1.5 times its length (the machine stalled); left out"
                      % (run_no + 1, label), flush=True)
                del res["running"]
            elif not states or set(states) != {ControllerStatus.STATE_RUNNING}:
                print("run %d %s: the job was not RUNNING throughout the window (states %s); left out"
                      % (run_no + 1, label, sorted(set(states))), flush=True)
                del res["running"]
        node.destroy_subscription(sub)
        node.destroy_client(cli)
        ex.remove_node(node)
        return res
    finally:
        for p in procs.values():
            p.terminate()
        for p in procs.values():
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def host_reference(bindir, blocks=100000, reps=3):
    """CPU seconds of `cnc check` on a fixed generated program (median of
    `reps`): how fast this host is, so CPU shares measured on different
    hosts can be set side by side (the same build's share of a core grows
    as the host gets slower). None without the build's `cnc`."""
    cnc = os.path.join(bindir, "cnc")
    if not os.access(cnc, os.X_OK):
        return None
    prog = os.path.join(ROOT, "bench", "out", "host_ref_%d.ngc" % blocks)
    if not os.path.exists(prog):
        os.makedirs(os.path.dirname(prog), exist_ok=True)
        subprocess.run([sys.executable, os.path.join(HERE, "gen_program.py"), "--blocks", str(blocks),
                        "--out", prog], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    cpu = []
    for _ in range(reps):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([cnc, "check", prog, "--machine", os.path.join(ROOT, "config", "mill.toml"),
                        "--dialect", "cnc836"], check=True, stdout=subprocess.DEVNULL)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
    return statistics.median(cpu)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", action="append", required=True, help="LABEL=BINDIR")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--settle", type=float, default=4.0)
    ap.add_argument("--node-args", default="")
    ap.add_argument("--sim-args", default="")
    ap.add_argument("--no-sim", action="store_true")
    ap.add_argument("--threads", action="store_true", help="per-thread breakdown")
    ap.add_argument("--pin", type=int, metavar="CPU",
                    help="run each build also with both nodes on this CPU (--cpu-affinity CPU)")
    a = ap.parse_args()
    builds = [b.split("=", 1) + [()] for b in a.build]
    if a.pin is not None:
        builds = [v for lab, d, _ in builds
                  for v in ([lab, d, ()], ["%s on CPU %d" % (lab, a.pin), d, ("--cpu-affinity", str(a.pin))])]
    rclpy.init()
    node = rclpy.create_node("cpu_probe")
    print("%d cores, load average before: %s" % (os.cpu_count(), open("/proc/loadavg").read().split()[:3]))
    ref = host_reference(builds[0][1])
    if ref is not None:
        print("host reference: `cnc check` (%s) of bench/gen_program.py's 100,000 blocks: %.3f s of CPU "
              "(median of 3)" % (builds[0][0], ref), flush=True)
    got = {lab: [] for lab, _, _ in builds}
    for r in range(a.runs):
        for lab, d, extra in builds:
            res = one(a, lab, d, r, node, extra)
            got[lab].append(res)
            print("run %d %s: %s" % (r + 1, lab, "; ".join(
                "%s %s %.1f %%" % (ph, k, v[0]) for ph, x in res.items() for k, v in x.items())), flush=True)
    print("load average after: %s" % open("/proc/loadavg").read().split()[:3])
    print("| build | state | cnc_node % of a core (median, runs) | sim_axes % of a core (median, runs) |")
    print("|---|---|---:|---:|")
    def phases(lab):
        return [ph for ph in ("idle", "running") if any(ph in x for x in got[lab])]
    for lab, _, _ in builds:
        for ph in phases(lab):
            cells = []
            for k in ("cnc_node", "sim_axes"):
                v = [x[ph][k][0] for x in got[lab] if ph in x and k in x[ph]]
                cells.append("%.1f (%s)" % (statistics.median(v), ", ".join("%.1f" % y for y in v)) if v else "—")
            print("| %s | %s | %s | %s |" % (lab, ph, cells[0], cells[1]))
    if a.threads:
        for lab, _, _ in builds:
            for ph in phases(lab):
                runs = [x for x in got[lab] if ph in x]
                for k in runs[0][ph]:
                    names = sorted({t for x in runs for t in x[ph][k][1]})
                    med = {t: [statistics.median([x[ph][k][1].get(t, (0.0, 0.0))[i] for x in runs]) for i in (0, 1)]
                           for t in names}
                    print("%s %s %s threads (%% of a core, wake-ups/s): %s" % (lab, ph, k, ", ".join(
                        "%s %.1f (%.0f/s)" % (t, v[0], v[1])
                        for t, v in sorted(med.items(), key=lambda kv: -kv[1][0]) if v[0] >= 0.05)))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
