"""The nodes as a ROS 2 user drives them, with the real `ros2` command line and
`ros2 launch` (ros2cli, launch and launch_ros from ../shared/vendor, installed by
scripts/ros_peer/setup.sh): `ros2 run cnc_controller cnc_node --ros-args ...`
with remaps and parameters, `ros2 node list`, `ros2 param list|get|set|describe`,
`ros2 service call`, `ros2 topic echo`, and `ros2 launch
launch_scripts/cnc_ros.launch.py` with a parameters file. The package is
installed for each run into a temporary prefix whose executables are the
binaries under test (CNC_TARGET_DIR). Where a motion is checked, an rclpy peer
(SingleThreadedExecutor) records the setpoints and joint states.

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/ros/test_ros2_cli.py
"""
import os
import re
import shutil
import signal
import subprocess
import time

import pytest

from ros_nodes import ROOT, TARGET, build, deep_qos, domain, read_mcap, SpinningPeer, stamp_s

DOMAIN = domain(6)
DISCOVERY_S = 30.0


def _missing_reason():
    venv = os.environ.get("VIRTUAL_ENV", os.path.join(ROOT, ".venv-ros"))
    note = os.path.join(venv, "ros2cli.missing")
    if os.path.exists(note):
        with open(note) as f:
            return f.read().strip()
    return ("the ros2 command line is not installed (scripts/ros_peer/setup.sh installs it "
            "from ../shared/vendor or from github.com/ros2)")


pytestmark = pytest.mark.skipif(shutil.which("ros2") is None, reason=_missing_reason())


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    """The environment: this module's domain, and the package cnc_controller
    installed with the binaries under test, first on AMENT_PREFIX_PATH."""
    build()
    prefix = tmp_path_factory.mktemp("ament_prefix")
    subprocess.run(["bash", os.path.join(ROOT, "scripts", "ros_peer", "install_package.sh"),
                    str(prefix), TARGET], check=True, capture_output=True)
    e = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
             AMENT_PREFIX_PATH=str(prefix) + os.pathsep + os.environ.get("AMENT_PREFIX_PATH", ""))
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    import rclpy
    rclpy.init()
    yield e
    rclpy.shutdown()


def ros2(env, *args, timeout=60):
    """`ros2 ARGS`: (exit code, stdout, stderr)."""
    r = subprocess.run(["ros2"] + list(args), cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=timeout)
    return r.returncode, r.stdout, r.stderr


def until(what, f, timeout=DISCOVERY_S):
    """Calls `f` until it returns something true (discovery is slow on a busy
    machine); that, or an assertion naming `what` with the last answer."""
    t0 = time.time()
    last = None
    while time.time() - t0 < timeout:
        last = f()
        if last and (not isinstance(last, tuple) or last[0]):
            return last
        time.sleep(0.5)
    raise AssertionError("timed out waiting for %s: %r" % (what, last))


class Started:
    """A command in a session of its own, its stderr in a file; stopped with
    its whole process group (`ros2 run` and `ros2 launch` start children)."""

    def __init__(self, env, args, log):
        self.log = log
        self.f = open(log, "w")
        self.p = subprocess.Popen(args, cwd=ROOT, env=env, stdout=self.f, stderr=subprocess.STDOUT,
                                  start_new_session=True)

    def text(self):
        self.f.flush()
        with open(self.log) as f:
            return f.read()

    def signal(self, sig):
        try:
            os.killpg(self.p.pid, sig)
        except ProcessLookupError:
            pass

    def stop(self):
        if self.p.poll() is None:
            self.signal(signal.SIGTERM)
            try:
                self.p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.signal(signal.SIGKILL)
                self.p.wait()
        self.signal(signal.SIGKILL)  # children left behind, if any
        self.f.close()


class Peer(SpinningPeer):
    """Records setpoints, joint states and status of one controller/simulator pair."""

    def __init__(self, name, ns, sim_ns, joint_states="joint_states"):
        super().__init__(name)
        from cnc_msgs.msg import ControllerStatus
        from cnc_msgs.srv import RunProgram
        from sensor_msgs.msg import JointState
        self.setpoints, self.joints, self.status = [], [], []
        # (a reader 1000 deep: with 100, a host that held this process up
        # for 200 ms at 500 Hz lost setpoints in it, and `on_grid` saw
        # gaps)
        self.node.create_subscription(JointState, ns + "/joint_setpoints",
                                      lambda m: self._add(self.setpoints, m), deep_qos())
        self.node.create_subscription(JointState, sim_ns + "/" + joint_states,
                                      lambda m: self._add(self.joints, m), deep_qos())
        self.node.create_subscription(ControllerStatus, ns + "/status", self._st, 100)
        self.run = self.node.create_client(RunProgram, ns + "/run_program")
        self.spin()

    def _add(self, into, m):
        with self.lock:
            into.append((stamp_s(m.header.stamp), list(m.position)))
            del into[:-5000]

    def _st(self, m):
        with self.lock:
            self.status.append(m)

    def last(self, which):
        with self.lock:
            return list(which[-1]) if which else None

    def wait_done(self, job_id, end_um, timeout=60.0):
        """Waits for the job's end in the status and for its last setpoint
        (the status may be handled before the setpoints published ahead of
        it); asserts that the setpoints end exactly at `end_um` (µm) and
        that their stamps are on the grid of `dt`."""
        self.wait_for("job %d to end" % job_id,
                      lambda: any(s.job_id == job_id and s.state == 0 and s.progress == 1.0
                                  for s in self.status[-20:]), timeout)
        try:
            self.wait_for("the setpoints at the end point",
                          lambda: bool(self.setpoints) and um(self.setpoints[-1][1]) == end_um, 10.0)
        finally:
            assert um(self.last(self.setpoints)[1]) == end_um

    def on_grid(self, dt, job_id=None):
        """Whether the stamps of the last setpoints are whole periods apart,
        most of them one period (the peer may miss one under load); with
        `job_id`, those from its first status as running to its end (the
        node publishes at its resting rate before a job and a second after
        it: a short job's last 100 setpoints may reach back into the rest,
        and a slow peer may look only after that second)."""
        with self.lock:
            mine = [(stamp_s(m.header.stamp), m) for m in self.status if m.job_id == job_id]
            start = min((t for t, m in mine if m.state == 1), default=None)
            end = min((t for t, m in mine if m.state == 0 and m.progress == 1.0), default=None)
            if job_id is None or start is None or end is None:
                stamps = [s for s, _ in self.setpoints[-100:]]
            else:
                stamps = [s for s, _ in self.setpoints if start <= s <= end][-100:]
        steps = [(b - a) / dt for a, b in zip(stamps, stamps[1:])]
        whole = all(k > 0.5 and abs(k - round(k)) < 1e-3 for k in steps)
        ok = whole and sum(round(k) == 1 for k in steps) > 0.9 * len(steps)
        # (what was off, for the assertion: the steps that are not one
        # whole period, with their place)
        off = [(i, round(k, 4)) for i, k in enumerate(steps) if not (abs(k - 1) < 1e-3)]
        return ok, "%d steps (job %s: statuses from %s to %s), not one period: %s" % (
            len(steps), job_id, start, end, off)


def um(pos_m):
    return [round(p * 1e6) for p in pos_m]


@pytest.fixture(scope="module")
def m2(env, tmp_path_factory):
    """Both nodes started with `ros2 run`, in /m2 and /m2sim, by their ROS
    arguments (an option given both ways, the ROS parameter wins), with the
    simulator's joint states renamed (`-r joint_states:=actual_joints`) and
    the controller told so by a remap of its own."""
    d = tmp_path_factory.mktemp("m2")
    rec = d / "recordings"
    sim = Started(env, ["ros2", "run", "cnc_controller", "sim_axes", "--ros-args",
                        "-r", "__ns:=/m2sim", "-r", "joint_states:=actual_joints",
                        "-p", "controller_namespace:=/m2",
                        "-p", "setpoint_delay_ms:=2.0", "-p", "rt_priority:=0",
                        "-p", "cpu_affinity:=0"], str(d / "sim.log"))
    node = Started(env, ["ros2", "run", "cnc_controller", "cnc_node", "--rate", "1000", "--ros-args",
                         "-r", "__ns:=/m2",
                         "-r", "/m2sim/joint_states:=/m2sim/actual_joints",
                         "-p", "sim_namespace:=/m2sim", "-p", "rate:=500",
                         "-p", "record_dir:=%s" % rec, "-p", "rt_priority:=0",
                         "-p", "cpu_affinity:=[0]"], str(d / "node.log"))
    yield {"sim": sim, "node": node, "rec": rec}
    node.stop()
    sim.stop()


def test_ros2_run_starts_both_nodes_under_their_ros_args(env, m2):
    rc, out, err = until("both nodes in ros2 node list", lambda: (
        lambda r: (("/m2/cnc_node" in r[1] and "/m2sim/sim_axes" in r[1]), r[1], r[2]))(
            ros2(env, "node", "list", "--no-daemon", "--spin-time", "3")))
    # the parameters, by `ros2 param`
    rc, out, err = ros2(env, "param", "list", "--no-daemon", "--spin-time", "5", "/m2/cnc_node")
    names = out.split()
    for n in ["machine", "sim_namespace", "rate", "program_dir", "record_dir", "record_all",
              "rt_priority", "cpu_affinity", "loop_stats", "max_feed_override", "use_sim_time"]:
        assert n in names, out + err
    rc, out, err = ros2(env, "param", "get", "--no-daemon", "--timeout", "30", "/m2/cnc_node", "rate")
    assert out.strip() == "Double value is: 500.0", out + err  # -p rate:=500 over --rate 1000
    # every value at once, as a parameters file
    rc, out, err = ros2(env, "param", "dump", "--no-daemon", "--timeout", "30", "/m2/cnc_node")
    for line in ["/m2/cnc_node:", "  ros__parameters:", "    machine: mill", "    rate: 500.0",
                 "    sim_namespace: /m2sim", "    rt_priority: 0", "    record_dir: %s" % m2["rec"],
                 "    program_dir: config/../examples", "    max_feed_override: 200.0"]:
        assert line in out.splitlines(), (line, out, err)
    rc, out, err = ros2(env, "param", "dump", "--no-daemon", "--timeout", "30", "/m2sim/sim_axes")
    for line in ["/m2sim/sim_axes:", "    setpoint_delay_ms: 2.0", "    controller_namespace: /m2",
                 "    rate: 1000.0", "    ripple: 0.0", "    seed: 1"]:
        assert line in out.splitlines(), (line, out, err)
    # the option given both ways was said so
    assert ("--rate and -p rate:=500 both set rate: the ROS parameter wins (500.0)"
            in m2["node"].text()), m2["node"].text()
    # both nodes pinned to CPU 0 (-p cpu_affinity:=[0] and :=0), every thread
    for node_name, ns in (("cnc_node", "/m2"), ("sim_axes", "/m2sim")):
        rc, out, err = ros2(env, "param", "get", "--no-daemon", "--timeout", "30",
                            "%s/%s" % (ns, node_name), "cpu_affinity")
        assert out.strip() == "Integer values are: [0]", out + err
        cpus = threads_cpus(node_name, "__ns:=%s" % ns)
        assert len(cpus) >= 5 and set(cpus.values()) == {"0"}, cpus


def threads_cpus(exe, arg):
    """{thread name: the CPUs it may run on} of the running process of
    executable `exe` with `arg` among its arguments."""
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                argv = f.read().decode(errors="replace").split("\0")
            if os.path.basename(argv[0]) != exe or arg not in argv:
                continue
            out = {}
            for tid in os.listdir("/proc/%s/task" % pid):
                with open("/proc/%s/task/%s/comm" % (pid, tid)) as f:
                    name = f.read().strip()
                with open("/proc/%s/task/%s/status" % (pid, tid)) as f:
                    allowed = [ln.split()[1] for ln in f if ln.startswith("Cpus_allowed_list:")]
                out[name] = allowed[0]
            return out
        except OSError:
            continue
    return {}


def test_ros2_param_set_takes_what_may_change_and_says_why_not(env, m2):
    def pset(node, name, value):
        rc, out, err = ros2(env, "param", "set", "--no-daemon", "--timeout", "30", node, name, value)
        return (out + err).strip()

    assert pset("/m2/cnc_node", "rate", "100.0") == (
        "Setting parameter failed: parameter 'rate' cannot be set because it is read-only: "
        "give it at start (--ros-args -p rate:=VALUE)")
    assert pset("/m2/cnc_node", "max_feed_override", "500.0") == (
        "Setting parameter failed: parameter 'max_feed_override': 500.0 is out of its range 1 to 200")
    # accepted (an integer for a double parameter is taken)
    assert pset("/m2/cnc_node", "max_feed_override", "150") == "Set parameter successful"
    rc, out, err = ros2(env, "param", "get", "--no-daemon", "--timeout", "30", "/m2/cnc_node",
                        "max_feed_override")
    assert out.strip() == "Double value is: 150.0", out + err
    assert "parameter max_feed_override: 200.0 -> 150.0" in m2["node"].text()
    # what is read-only says so
    rc, out, err = ros2(env, "param", "describe", "--no-daemon", "--timeout", "30", "/m2/cnc_node",
                        "rate", "record_dir")
    assert "Parameter name: rate" in out and "Read only: true" in out, out + err
    assert re.search(r"Parameter name: record_dir\n\s+Type: string\n\s+Description: directory of job", out), out


def test_parameter_sets_from_rclpy_are_checked_and_atomic(env, m2):
    """The other refusals, faster through rclpy's parameter client than one
    `ros2 param set` (a new DDS participant) each."""
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    peer = SpinningPeer("ros2_cli_params")
    node = AsyncParameterClient(peer.node, "/m2/cnc_node")
    sim = AsyncParameterClient(peer.node, "/m2sim/sim_axes")
    peer.spin()
    try:
        assert node.wait_for_services(DISCOVERY_S) and sim.wait_for_services(DISCOVERY_S)

        def result(fut):
            peer.wait_for("a reply", fut.done, 20.0)
            return fut.result()

        def set1(client, name, value):
            r = result(client.set_parameters([Parameter(name, value=value)])).results[0]
            return "ok" if r.successful else r.reason

        assert set1(node, "record_all", "maybe") == "parameter 'record_all' is a bool, not a string ('maybe')"
        assert set1(node, "no_such_thing", 1) == (
            "parameter 'no_such_thing' is not declared by this node (ros2 param list shows its parameters)")
        assert set1(node, "use_sim_time", True).startswith("use_sim_time: this node runs on the system clock")
        assert set1(node, "record_dir", "/dev/null") == "record_dir: /dev/null is not a directory"
        assert set1(sim, "setpoint_delay_ms", 250.0) == (
            "parameter 'setpoint_delay_ms': 250.0 is out of its range 0 to 100")
        assert set1(sim, "noise_rpm", 2.5) == "ok"
        # all or nothing
        r = result(node.set_parameters_atomically([Parameter("loop_stats", value=5.0),
                                                    Parameter("rate", value=100.0)])).result
        assert not r.successful and "read-only" in r.reason, r
        values = result(node.get_parameters(["loop_stats", "rate"])).values
        assert [values[0].double_value, values[1].double_value] == [0.0, 500.0]
        values = result(sim.get_parameters(["noise_rpm"])).values
        assert values[0].double_value == 2.5
    finally:
        peer.close()


def test_a_job_by_ros2_service_call_ends_where_the_program_says(env, m2):
    rec = m2["rec"]
    # recordings switched on while the node runs: the next job records
    rc, out, err = ros2(env, "param", "set", "--no-daemon", "--timeout", "30", "/m2/cnc_node",
                        "record_all", "true")
    assert out.strip() == "Set parameter successful", out + err
    peer = Peer("ros2_cli_peer", "/m2", "/m2sim", joint_states="actual_joints")
    try:
        peer.wait_for("setpoints and joint states",
                      lambda: bool(peer.setpoints) and bool(peer.joints), DISCOVERY_S)
        rc, out, err = ros2(env, "service", "call", "/m2/run_program", "cnc_msgs/srv/RunProgram",
                            "{program: 'G00 X12.345 Y-6.789 Z4.5\nM30\n'}", timeout=90)
        assert rc == 0 and "accepted=True" in out, out + err
        job = int(re.search(r"job_id=(\d+)", out).group(1))
        path = re.search(r"recording='([^']*)'", out).group(1)
        assert path.startswith(str(rec)), out
        # the setpoints end exactly on the program's end point, at 500 Hz
        peer.wait_done(job, [12345, -6789, 4500])
        ok, steps = peer.on_grid(0.002, job)
        assert ok, steps
        # the simulator in /m2sim follows /m2 (its controller_namespace)
        peer.wait_for("the axes to settle", lambda: bool(peer.joints) and all(
            abs(a - b) <= 2 for a, b in zip(um(peer.joints[-1][1]), [12345, -6789, 4500])), 10.0)
    finally:
        peer.close()
    # the status as ros2 topic echo shows it
    rc, out, err = ros2(env, "topic", "echo", "--once", "--no-daemon", "/m2/status",
                        "cnc_msgs/msg/ControllerStatus", timeout=60)
    assert re.search(r"^state: 0$", out, re.M) and re.search(r"^job_id: %d$" % job, out, re.M), out + err
    assert re.search(r"^progress: 1\.0$", out, re.M), out
    until("the recording", lambda: os.path.exists(path) and os.path.getsize(path) > 0, 10.0)
    # the controller heard the simulator under the renamed topic: its recording has them
    topics = until("a finished recording", lambda: _read(path), 10.0)
    assert len(topics.get("/sim/joint_states", [])) > 10, sorted(topics)


def _read(path):
    try:
        return read_mcap(path)
    except Exception:  # not finished yet
        return None


def test_bad_ros_args_stop_the_node_with_the_reason(env, tmp_path):
    bad_file = tmp_path / "bad.yaml"
    bad_file.write_text("/**:\n  ros__parameters:\n    rate: [1, a]\n")
    for args, want in [
        (["cnc_node", "--ros-args", "-p", "rate:=5"],
         "cnc_node: parameter 'rate': 5.0 is out of its range 10 to 20000 (from -p rate:=5)"),
        (["cnc_node", "--ros-args", "--params-file", str(bad_file)],
         "cnc_node: --params-file %s: '/**': parameter 'rate': a list must hold values of one type" % bad_file),
        (["sim_axes", "--ros-args", "-r", "__ns:=/1bad"],
         "sim_axes: remap '__ns:=/1bad': '1bad' must start with a letter or '_'"),
        (["sim_axes", "--ros-args", "--no-such-flag"], "sim_axes: unknown ROS argument '--no-such-flag'"),
        (["cnc_node", "--ros-args", "-p", "cpu_affinity:=[0, 1023]"],
         "cnc_node: --cpu-affinity: CPU 1023 is not one this process may run on (it may run on 0-"),
        (["sim_axes", "--ros-args", "-p", "cpu_affinity:=[-1]"],
         "sim_axes: parameter 'cpu_affinity': -1 is out of its range 0 to 1023 (from -p cpu_affinity:=[-1])"),
    ]:
        rc, out, err = ros2(env, "run", "cnc_controller", *args)
        assert rc != 0 and want in err, (args, rc, out, err)
    rc, out, err = ros2(env, "run", "cnc_controller", "cnc_node", "--help")
    assert rc == 0 and "--ros-args" in out and "--max-feed-override" in out, out + err
    # both launch files load (the old one starts the binaries with ExecuteProcess)
    for f in ["cnc.launch.py", "cnc_ros.launch.py"]:
        rc, out, err = ros2(env, "launch", "--print", os.path.join("launch_scripts", f))
        assert rc == 0 and "LaunchDescription" in out, (f, out, err)
    rc, out, err = ros2(env, "launch", "--print", "cnc_controller", "cnc_ros.launch.py")
    assert rc == 0 and "cnc_controller" in out, out + err


def test_ros2_launch_starts_both_with_a_params_file_and_runs_a_job(env, tmp_path):
    rec = tmp_path / "launch_recordings"
    params = tmp_path / "params.yaml"
    params.write_text(
        "/**/cnc_node:\n  ros__parameters:\n    rate: 250.0\n    record_all: true\n"
        "    record_dir: %s\n    rt_priority: 0\n"
        "/l3sim/sim_axes:\n  ros__parameters:\n    setpoint_delay_ms: 4.0\n    seed: 7\n"
        "    rt_priority: 0\n    cpu_affinity: [0]\n" % rec)
    # (the launch argument over the file's [0]: both nodes on the last CPU)
    last_cpu = max(os.sched_getaffinity(0))
    launch = Started(env, ["ros2", "launch", os.path.join("launch_scripts", "cnc_ros.launch.py"),
                           "namespace:=/l3", "sim_namespace:=/l3sim", "params_file:=%s" % params,
                           "cpu_affinity:=[%d]" % last_cpu],
                     str(tmp_path / "launch.log"))
    peer = None
    try:
        # the values from the file and the launch arguments, one `ros2 param dump` a node
        for node, want in [
            ("/l3/cnc_node", ["    rate: 250.0", "    record_dir: %s" % rec, "    record_all: true",
                              "    sim_namespace: /l3sim", "    rt_priority: 0"]),
            ("/l3sim/sim_axes", ["    setpoint_delay_ms: 4.0", "    seed: 7",
                                 "    controller_namespace: /l3", "    machine: mill"]),
        ]:
            rc, out, err = until("the parameters of %s" % node, lambda: (lambda r: (
                all(w in r[1].splitlines() for w in want), r[1], r[2]))(
                    ros2(env, "param", "dump", "--no-daemon", "--timeout", "30", node)), 45.0)
        for exe, ns in (("cnc_node", "/l3"), ("sim_axes", "/l3sim")):
            cpus = threads_cpus(exe, "__ns:=%s" % ns)
            assert len(cpus) >= 5 and set(cpus.values()) == {str(last_cpu)}, (exe, cpus)
        from cnc_msgs.srv import RunProgram
        peer = Peer("ros2_launch_peer", "/l3", "/l3sim")
        peer.wait_for("setpoints and joint states",
                      lambda: bool(peer.setpoints) and bool(peer.joints), DISCOVERY_S)
        assert peer.run.wait_for_service(timeout_sec=DISCOVERY_S)
        req = RunProgram.Request()
        req.program = "G00 X5 Y6 Z7\nM30\n"
        r = peer.call(peer.run, req)
        assert r.accepted and r.recording.startswith(str(rec)), r
        peer.wait_done(r.job_id, [5000, 6000, 7000])
        ok, steps = peer.on_grid(0.004, r.job_id)  # 250 Hz, from the parameters file
        assert ok, steps
        peer.wait_for("the axes to settle", lambda: bool(peer.joints) and all(
            abs(a - b) <= 2 for a, b in zip(um(peer.joints[-1][1]), [5000, 6000, 7000])), 10.0)
        until("the recording", lambda: os.path.exists(r.recording) and os.path.getsize(r.recording) > 0, 10.0)
        log = launch.text()
        assert "[cnc_node-2] cnc_node: mill (x y z), 250 Hz" in log, log
        assert "setpoints applied 4 ms after their stamps" in log, log
        # Ctrl-C ends the launch and both nodes cleanly (exit status 0), a
        # running job stopped under control and its recording closed
        if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
            req.program = "G01 X80 F600\nM30\n"
            r2 = peer.call(peer.run, req)
            assert r2.accepted, r2
            peer.wait_for("job 2 running", lambda: any(
                s.job_id == r2.job_id and s.state == 1 for s in list(peer.status)[-20:]), 10.0)
            launch.p.send_signal(signal.SIGINT)
            launch.p.wait(timeout=30)
            log = launch.text()
            for node in ["cnc_node", "sim_axes"]:
                assert re.search(r"\[%s-\d+\]: process has finished cleanly" % node, log), log
            assert "cnc_node: SIGINT/SIGTERM: stopping" in log, log
            assert "sim_axes: SIGINT/SIGTERM: shut down" in log, log
            assert os.path.getsize(r2.recording) > 0
            with open(r2.recording, "rb") as f:
                data = f.read()
            # a closed MCAP ends with its magic
            assert data[:8] == b"\x89MCAP0\r\n" and data[-8:] == b"\x89MCAP0\r\n", len(data)
    finally:
        if peer:
            peer.close()
        launch.stop()
