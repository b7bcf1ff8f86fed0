"""What the nodes show of themselves to ROS tools (issue 19), against the
real nodes and a stock rclpy peer:

- `/rosout` (rcl_interfaces/Log, rclcpp's QoS): the controller's job lines
  (accepted, finished) and a refused program's errors by line and
  column, the simulator's lines, each with the node's logger name, level,
  file, function, line and stamp;
- `/diagnostics` (diagnostic_msgs/DiagnosticArray, 1 Hz): the controller's
  loop lateness, encoder health and job, the simulator's loop, setpoints
  and spindle, with their values; an ERROR when the simulator is killed
  during a G95 move;
- `<ns>/robot_description` (transient local): the URDF, to a subscriber
  that joins late, with the setpoints' joint names and the machine file's
  limits (`cnc urdf` prints the same, for the lathe too);
- `/tf` and `/tf_static`: world -> tool equals the last setpoint after a
  move, at 50 Hz of setpoint stamps while the job runs.

    bash scripts/ros_peer/setup.sh && . .venv-ros/env.sh
    python3 -m pytest tests/ros/test_observability.py -q -s

(diagnostic_msgs comes from PyPI; tf2_msgs, which PyPI does not have, is
built from geometry2's message by setup.sh: scripts/ros_peer/tf2_msgs.)
"""
import math
import os
import re
import signal
import subprocess
import threading
import time
import tomllib
import xml.etree.ElementTree as ET

import pytest
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import Log
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from cnc_msgs.msg import ControllerStatus
from cnc_msgs.srv import RunProgram, SetDelay
from ros_nodes import ROOT, TARGET, build, deep_qos, domain, hearing_peer, SpinningPeer, start, start_sim, stop

DOMAIN = domain(7)
NS, SIM = "/cnc", "/sim"
NODE_LOGGER, SIM_LOGGER = "cnc.cnc_node", "sim.sim_axes"
IDLE, RUNNING, ERROR = ControllerStatus.STATE_IDLE, ControllerStatus.STATE_RUNNING, ControllerStatus.STATE_ERROR
OK, WARN, ERR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR
NODE_STATUSES = ("cnc_node: control loop", "cnc_node: spindle encoder", "cnc_node: job")
SIM_STATUSES = ("sim_axes: simulation loop", "sim_axes: setpoints", "sim_axes: spindle")

# rclcpp's /rosout QoS (rmw_qos_profile_rosout_default)
ROSOUT_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
# robot_state_publisher's robot_description, tf2's /tf_static
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def ns_of(stamp):
    return stamp.sec * 10**9 + stamp.nanosec


class Peer(SpinningPeer):
    """Logs, diagnostics, setpoints, status and frames as they arrive."""

    def __init__(self, name, own_participant=False):
        super().__init__(name, own_participant)
        # (the helpers below lock too, and wait_for calls them under it)
        self.lock = threading.RLock()
        self.logs = []  # (arrival s, Log)
        self.diags = []  # (arrival s, DiagnosticArray)
        self.setpoints = []  # (stamp ns, names, positions m)
        self.status = []  # (arrival s, ControllerStatus)
        self.tf = []  # (arrival s, TFMessage)
        self.tf_static = []
        self.node.create_subscription(Log, "/rosout", self._add(self.logs), ROSOUT_QOS)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._add(self.diags), 50)
        self.node.create_subscription(JointState, NS + "/joint_setpoints", self._sp, deep_qos())
        self.node.create_subscription(ControllerStatus, NS + "/status", self._add(self.status), 100)
        self.node.create_subscription(TFMessage, "/tf", self._add(self.tf), QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE))
        self.node.create_subscription(TFMessage, "/tf_static", self._add(self.tf_static), LATCHED)
        self.run = self.node.create_client(RunProgram, NS + "/run_program")
        self.delay = self.node.create_client(SetDelay, SIM + "/setpoint_delay")
        self.spin()

    def missing(self, timeout=30.0):
        """What has not come within `timeout` s, or None: the
        run_program service, a setpoint."""
        return self.unheard([self.run], lambda: self.setpoints, NS + "/joint_setpoints", timeout)

    def _add(self, into):
        def cb(m):
            t = time.time()
            with self.lock:
                into.append((t, m))
        return cb

    def _sp(self, m):
        with self.lock:
            self.setpoints.append((ns_of(m.header.stamp), list(m.name), list(m.position)))

    def run_program(self, text):
        req = RunProgram.Request()
        req.program = text
        return self.call(self.run, req, timeout=60.0)

    def final_status(self, job_id, timeout=60.0):
        def ended():
            mine = [m for _, m in self.status if m.job_id == job_id]
            return any(m.state == RUNNING for m in mine) and mine[-1].state in (IDLE, ERROR)
        self.wait_for("the end of job %d" % job_id, ended, timeout)
        with self.lock:
            return [m for _, m in self.status if m.job_id == job_id][-1]

    def log_lines(self, pred, what, timeout=30.0):
        """The /rosout messages for which `pred` holds, once there is one."""
        self.wait_for(what, lambda: any(pred(m) for _, m in self.logs), timeout)
        with self.lock:
            return [m for _, m in self.logs if pred(m)]

    def statuses(self, since=0.0):
        """{name: (arrival s, DiagnosticStatus)} of the newest status of each
        name that arrived after `since`."""
        out = {}
        with self.lock:
            for t, a in self.diags:
                if t >= since:
                    for s in a.status:
                        out[s.name] = (t, s)
        return out

    def frames(self):
        """{child: (parent, translation, rotation)} of the newest transform
        of each frame, static ones first."""
        out = {}
        with self.lock:
            for _, m in self.tf_static + self.tf:
                for t in m.transforms:
                    out[t.child_frame_id] = (t.header.frame_id, t.transform.translation, t.transform.rotation,
                                             ns_of(t.header.stamp))
        return out


def values(s):
    return {kv.key: kv.value for kv in s.values}


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def rotate(q, v):
    x, y, z, _ = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def lookup(frames, target, child):
    """The translation of `child` in `target` (m), composed along the tree."""
    p, at = (0.0, 0.0, 0.0), child
    while at != target:
        assert at in frames, "no transform to %s (frames: %s)" % (at, sorted(frames))
        parent, t, r, _ = frames[at]
        p = rotate((r.x, r.y, r.z, r.w), p)
        p = (p[0] + t.x, p[1] + t.y, p[2] + t.z)
        at = parent
    return p


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    build()
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    tmp = str(tmp_path_factory.mktemp("observability"))
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")

    class Rig:
        pass
    r = Rig()
    r.env, r.tmp = env, tmp
    r.node_log, r.sim_log = os.path.join(tmp, "cnc_node.log"), os.path.join(tmp, "sim_axes.log")
    with open(r.sim_log, "ab") as s, open(r.node_log, "ab") as n:
        r.sim, r.node = start(env, ["--machine", "mill"], ["--machine", "mill", "--record-dir",
                                                            os.path.join(tmp, "rec")], s, n)
    r.t_start = time.time()
    rclpy.init()
    try:
        # (a peer whose readers the nodes never matched is made again as a
        # participant of its own: ros_nodes.hearing_peer)
        r.peer = hearing_peer(lambda own: Peer("obs_peer_%d" % (time.time_ns() % 100000), own), Peer.missing)
        yield r
        r.peer.close()
    finally:
        rclpy.shutdown()
        stop([r.sim, r.node])


def node_log(r):
    with open(r.node_log, "rb") as f:
        return f.read().decode(errors="replace")


def test_rosout_carries_the_job_lines_with_the_node_name_and_level(rig):
    peer = rig.peer
    t0 = time.time()
    # (a second's dwell: the check worker's "accepted", logged when the loop
    # took the job, comes before the end even on a busy VM)
    r = peer.run_program("N10 G01 X5 Y4 Z-1 F3000\nN15 G04 X1\nN20 G00 X0 Y0 Z0\nN30 M30\n")
    assert r.accepted, r.message
    job = r.job_id
    st = peer.final_status(job)
    assert st.state == IDLE, st.last_error
    lines = {}
    for what, pat in (("accepted", r"^job %d accepted: a program of \d+ bytes, estimated [0-9.]+ s$" % job),
                      ("finished", r"^job %d finished in [0-9.]+ s$" % job)):
        (m,) = peer.log_lines(lambda m, p=pat: re.match(p, m.msg), "the /rosout line 'job %d %s'" % (job, what))
        lines[what] = m
        print("/rosout [%s] %s (%s, %s:%d)" % (m.level, m.msg, m.function, m.file, m.line))
        assert m.name == NODE_LOGGER, m.name
        assert m.level == Log.INFO, m.level
        assert m.file.startswith("cnc_node/src/") and m.file.endswith(".rs") and m.line > 0, (m.file, m.line)
        assert m.function.startswith("cnc_node"), m.function
        # stamped with the system clock when it was logged
        assert t0 - 1.0 <= ns_of(m.stamp) / 1e9 <= time.time() + 1.0, (m.stamp, t0)
    assert ns_of(lines["accepted"].stamp) < ns_of(lines["finished"].stamp)
    took = float(re.search(r"in ([0-9.]+) s", lines["finished"].msg).group(1))
    assert abs(took - r.estimated_duration) < 0.05, (took, r.estimated_duration)
    # the same lines on stderr, as before
    log = node_log(rig)
    assert "cnc_node: job %d accepted" % job in log and "cnc_node: job %d finished" % job in log, log[-2000:]
    # the simulator's lines too: a fault injection it logs (at WARN), with
    # its own logger name (setting the delay it has changes nothing)
    req = SetDelay.Request()
    req.delay_ms = 3.0
    assert peer.call(peer.delay, req).success
    (m,) = peer.log_lines(lambda m: m.name == SIM_LOGGER and "(fault injection)" in m.msg,
                          "the simulator's /rosout line")
    assert m.level == Log.WARN and m.msg == "setpoint delay 3 ms -> 3 ms (fault injection)", (m.level, m.msg)
    assert m.file == "sim_axes/src/bin/sim_axes.rs" and m.function.startswith("sim_axes"), (m.file, m.function)


def test_a_refused_program_is_an_error_line_with_line_and_column(rig):
    peer = rig.peer
    r = peer.run_program("N10 G01 X10 F100\nN20 G01 Y\n")
    assert not r.accepted and re.match(r"^line 2, column \d+: ", r.message), r.message
    (m,) = peer.log_lines(lambda m: m.msg.startswith("run_program refused"), "the refusal on /rosout")
    print("/rosout [%s] %s" % (m.level, m.msg))
    assert m.level == Log.ERROR and m.name == NODE_LOGGER, (m.level, m.name)
    assert m.msg == "run_program refused (a program of 27 bytes): " + r.message, m.msg
    assert re.search(r": line 2, column \d+: block N20: ", m.msg), m.msg


def test_diagnostics_name_the_loop_the_encoder_and_the_job_with_values(rig):
    peer = rig.peer
    # the spindle turning, so the encoder sees its index (M03 does not wait
    # for the spindle, and on a busy VM the simulator may hear the command
    # late: the index is awaited, not assumed)
    r = peer.run_program("N10 M03 S600\nN20 G04 X2\nN30 G01 X2 F600\nN40 M05\n")
    assert r.accepted, r.message
    job = r.job_id

    def index_seen():
        got = peer.statuses()
        return "cnc_node: spindle encoder" in got and values(got["cnc_node: spindle encoder"][1]).get(
            "index seen") == "true"
    peer.wait_for("the encoder's index on /diagnostics", index_seen, 60.0)
    st = peer.final_status(job)
    assert st.state == IDLE, st.last_error
    t_end = time.time()
    peer.wait_for("every status after the job", lambda: set(NODE_STATUSES + SIM_STATUSES) <= set(
        peer.statuses(t_end)))
    got = peer.statuses(t_end)
    for name in NODE_STATUSES + SIM_STATUSES:
        _, s = got[name]
        print("%-28s %s %-16s %s %s" % (name, s.level, s.hardware_id, s.message, values(s)))
        assert s.level in (OK, WARN, ERR), s.level
        assert s.message
    loop = got["cnc_node: control loop"][1]
    assert loop.hardware_id == "mill (/cnc)"
    v = values(loop)
    # lateness in µs as numbers; about 1000 cycles a second
    p50, p99, mx = float(v["lateness p50 (us)"]), float(v["lateness p99 (us)"]), float(v["lateness max (us)"])
    assert 0 < p50 <= p99 <= mx * 1.1 + 1, v
    assert 300 < int(v["cycles"]) / float(v["period (s)"]) < 1500, v
    assert float(v["rate (Hz)"]) == 1000.0
    for k in ("late cycles", "skipped cycles", "samples dropped"):
        assert int(v[k]) >= 0, v
    # the level follows the values
    if int(v["skipped cycles"]) or int(v["samples dropped"]):
        assert loop.level == ERR
    elif int(v["late cycles"]):
        assert loop.level == WARN
    enc = got["cnc_node: spindle encoder"][1]
    v = values(enc)
    assert float(v["timeout (ms)"]) == 25.0
    age = float(v["age of last reading (ms)"])
    assert 0 <= age < 10_000 and float(v["readings per s"]) > 100, v
    assert v["index seen"] == "true" and int(v["index pulses"]) > 0 and int(v["counts per rev"]) == 4096, v
    # the level follows the values: an error past the timeout, a warning
    # when readings stopped that long within the period (a host hold-up),
    # else OK (the test said 10 ms, the timeout of before 64afa4d, and
    # failed when a hold-up left the last reading 13.1 ms old: OK then)
    timeout, max_age = float(v["timeout (ms)"]), float(v["max age in period (ms)"])
    want = ERR if age > timeout else WARN if max_age > timeout else OK
    assert enc.level == want, (enc.level, age, max_age, timeout)
    v = values(got["cnc_node: job"][1])
    assert (v["state"], v["job id"], v["progress (%)"], v["last error"]) == ("IDLE", str(job), "100", ""), v
    assert got["cnc_node: job"][1].level == OK and got["cnc_node: job"][1].message == "job %d finished" % job
    v = values(got["sim_axes: simulation loop"][1])
    assert int(v["steps"]) > 500 and int(v["stalls"]) >= 0, v
    assert got["sim_axes: setpoints"][1].hardware_id == "mill (/sim)"
    assert float(values(got["sim_axes: setpoints"][1])["setpoint delay (ms)"]) == 3.0
    v = values(got["sim_axes: spindle"][1])
    assert v["encoder published"] == "true" and v["stalled"] == "false", v
    # about one array a second from each node
    with peer.lock:
        arrivals = [t for t, a in peer.diags if any(s.name == "cnc_node: job" for s in a.status)]
    recent = [t for t in arrivals if t > t_end - 5.0]
    assert len(recent) >= 3, arrivals[-10:]


def test_robot_description_reaches_a_late_subscriber_with_the_machine_files_joints(rig):
    peer = rig.peer
    # the node published it once, at its start, well before this subscriber
    time.sleep(max(0.0, rig.t_start + 5.0 - time.time()))
    got = []
    late = rclpy.create_node("late_%d" % (time.time_ns() % 100000))
    late.create_subscription(String, NS + "/robot_description", lambda m: got.append(m.data), LATCHED)
    t0 = time.time()
    while not got and time.time() - t0 < 30.0:
        rclpy.spin_once(late, timeout_sec=0.1)
    late.destroy_node()
    assert got, "no %s/robot_description within 30 s" % NS
    print("robot_description after %.2f s: %d bytes" % (time.time() - t0, len(got[0])))
    urdf = ET.fromstring(got[0])
    assert urdf.tag == "robot" and urdf.get("name") == "mill"
    with open(os.path.join(ROOT, "config", "mill.toml"), "rb") as f:
        machine = tomllib.load(f)
    joints = {j.get("name"): j for j in urdf.findall("joint")}
    prismatic = [n for n, j in joints.items() if j.get("type") == "prismatic"]
    with peer.lock:
        names = peer.setpoints[-1][1]
    assert sorted(prismatic) == sorted(names) == [a["name"] for a in machine["axis"]], (prismatic, names)
    for a in machine["axis"]:
        lim = joints[a["name"]].find("limit")
        assert float(lim.get("lower")) == pytest.approx(a["min_mm"] / 1000, abs=1e-12)
        assert float(lim.get("upper")) == pytest.approx(a["max_mm"] / 1000, abs=1e-12)
        assert float(lim.get("velocity")) == pytest.approx(a["max_velocity_mm_s"] / 1000, abs=1e-12)
        assert lim.get("effort") is not None
    sp = joints["spindle"]
    assert sp.get("type") == "continuous"
    assert float(sp.find("limit").get("velocity")) == pytest.approx(machine["spindle"]["max_rpm"] * 2 * math.pi / 60)
    links = {l.get("name") for l in urdf.findall("link")}
    assert {"world", "base_link", "tool"} <= links
    # `cnc urdf` prints the same text
    out = subprocess.run([os.path.join(TARGET, "cnc"), "urdf", "--machine", "mill"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout == got[0]


def test_cnc_urdf_of_the_lathe_has_its_machine_files_limits():
    out = subprocess.run([os.path.join(TARGET, "cnc"), "urdf", "--machine", "lathe"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    urdf = ET.fromstring(out.stdout)
    with open(os.path.join(ROOT, "config", "lathe.toml"), "rb") as f:
        machine = tomllib.load(f)
    joints = {j.get("name"): j for j in urdf.findall("joint") if j.get("type") == "prismatic"}
    assert sorted(joints) == ["x", "z"]
    for a in machine["axis"]:
        lim = joints[a["name"]].find("limit")
        assert (float(lim.get("lower")), float(lim.get("upper"))) == (a["min_mm"] / 1000, a["max_mm"] / 1000)
        assert float(lim.get("velocity")) == a["max_velocity_mm_s"] / 1000


def test_the_foxglove_layout_shows_the_machine_the_logs_and_the_diagnostics():
    """docs/foxglove/cnc_layout.json (Foxglove is not on this machine: its
    format, read here): every panel of the tree has its configuration; the
    3D panel loads the URDF from the node's robot_description and shows /tf;
    the log panel reads /rosout, the diagnostics panels /diagnostics and a
    status the node publishes."""
    import json
    with open(os.path.join(ROOT, "docs", "foxglove", "cnc_layout.json")) as f:
        layout = json.load(f)
    conf = layout["configById"]

    def leaves(node):
        if isinstance(node, str):
            return [node]
        return leaves(node["first"]) + leaves(node["second"])
    panels = leaves(layout["layout"])
    assert sorted(panels) == sorted(conf), (panels, sorted(conf))
    three = conf["3D!cnc"]
    urdf = [l for l in three["layers"].values() if l["layerId"] == "foxglove.Urdf"]
    assert len(urdf) == 1 and urdf[0]["sourceType"] == "topic" and urdf[0]["topic"] == NS + "/robot_description"
    assert three["topics"]["/tf"]["visible"] and three["followTf"] == "world"
    for f in ("world", "base_link", "x_slide", "y_slide", "z_slide", "tool"):
        assert three["transforms"]["frame:" + f]["visible"], f
    assert conf["RosOut!log"]["topicToRender"] == "/rosout"
    assert conf["DiagnosticSummary!diag"]["topicToRender"] == "/diagnostics"
    st = conf["DiagnosticStatusPanel!diag"]
    assert st["topicToRender"] == "/diagnostics"
    assert (st["selectedHardwareId"], st["selectedName"]) == ("mill (/cnc)", NODE_STATUSES[0])


def test_tf_puts_the_tool_at_the_last_setpoint_after_a_move(rig):
    peer = rig.peer
    target_mm = (12.345, -6.789, 3.21)
    r = peer.run_program("N10 G01 X%.3f Y%.3f Z%.3f F6000\nN20 M30\n" % target_mm)
    assert r.accepted, r.message
    st = peer.final_status(r.job_id)
    assert st.state == IDLE, st.last_error
    # the job's end: its first status after running (the last one may be a
    # later status at rest, and the transform sent at the change of state
    # then falls inside the window of the running ones below)
    with peer.lock:
        mine = [m for _, m in peer.status if m.job_id == r.job_id]
    ran = max(i for i, m in enumerate(mine) if m.state == RUNNING)
    end_ns = ns_of(mine[ran + 1].header.stamp)
    # a transform of the tool's slide stamped at or after the job's end
    peer.wait_for("/tf after the job's end", lambda: any(
        t.header.stamp.sec * 10**9 + t.header.stamp.nanosec >= end_ns
        for _, m in peer.tf for t in m.transforms if t.child_frame_id == "z_slide"))
    peer.wait_for("/tf_static", lambda: peer.tf_static)
    frames = peer.frames()
    tf_ns = frames["z_slide"][3]
    # the setpoints up to that transform (a busy subscriber of 1000 a
    # second lags behind): the machine stands at the last one
    peer.wait_for("the setpoints up to the transform", lambda: peer.setpoints[-1][0] >= tf_ns)
    with peer.lock:
        last = [sp for sp in peer.setpoints if sp[0] <= tf_ns][-1]
    tool = lookup(frames, "world", "tool")
    print("world -> tool %s, last setpoint %s" % (tool, last[2]))
    assert max(abs(a - b) for a, b in zip(tool, last[2])) < 1e-6, (tool, last)
    assert max(abs(a - b / 1000) for a, b in zip(tool, target_mm)) < 1e-6, tool
    # static: world -> base_link, z_slide -> tool
    static = {t.child_frame_id: t.header.frame_id for _, m in peer.tf_static for t in m.transforms}
    assert static == {"base_link": "world", "tool": "z_slide"}, static
    # while the job ran: one /tf every 20 ms of setpoint stamps (50 Hz)
    first = [ns_of(m.header.stamp) for _, m in peer.status if m.job_id == r.job_id and m.state == RUNNING]
    with peer.lock:
        during = sorted({ns_of(t.header.stamp) for _, m in peer.tf for t in m.transforms
                         if t.child_frame_id == "x_slide" and first[0] < ns_of(t.header.stamp) < end_ns})
    gaps = [b - a for a, b in zip(during, during[1:])]
    print("/tf while running: %d transforms in %.3f s, gaps %s ms" % (
        len(during), (end_ns - first[0]) / 1e9, sorted(set(g // 1_000_000 for g in gaps))))
    assert gaps and all(g >= 20_000_000 for g in gaps), gaps
    assert sorted(gaps)[len(gaps) // 2] <= 25_000_000, gaps
    # the spindle's frame turns about Z
    parent, t, q, _ = frames["spindle_link"]
    assert parent == "z_slide" and abs(q.x) < 1e-12 and abs(q.y) < 1e-12
    assert abs(q.z ** 2 + q.w ** 2 - 1) < 1e-9


def test_the_simulator_killed_during_a_g95_move_makes_the_encoder_and_the_job_errors(rig):
    """As in test_faults: the readings stop, the G95 job ends in ERROR;
    here /diagnostics says so (the encoder ERROR with its age, the job
    ERROR) and /rosout has the job's failure at ERROR."""
    peer = rig.peer
    prog = "N10 G00 X10 Y10 Z5\nN20 M03 S1000\nN30 G95 G01 X60 F0.05\nN40 M30\n"
    r = peer.run_program(prog)
    assert r.accepted, r.message
    job = r.job_id
    peer.wait_for("line 3", lambda: any(m.job_id == job and m.source_line == 3 for _, m in peer.status))
    time.sleep(0.5)
    with peer.lock:
        early = [m for _, m in peer.status if m.job_id == job][-1]
    if early.state == ERROR:
        # a busy VM delivered the readings late past the encoder timeout
        # before the kill: the job ended already, rightly, with the same
        # error; the diagnostics after the kill are the same
        print("the job ended before the kill: %r" % early.last_error)
    rig.sim.send_signal(signal.SIGKILL)
    rig.sim.wait(timeout=10)
    t_kill = time.time()
    try:
        st = peer.final_status(job, timeout=20)
        assert st.state == ERROR and "spindle encoder signal lost" in st.last_error, st.last_error

        def lost():
            got = peer.statuses(t_kill + 1.0)
            return all(n in got for n in NODE_STATUSES) and got["cnc_node: spindle encoder"][1].level == ERR \
                and got["cnc_node: job"][1].level == ERR
        peer.wait_for("the encoder and the job as errors on /diagnostics", lost, 30.0)
        got = peer.statuses(t_kill + 1.0)
        enc, jb = got["cnc_node: spindle encoder"][1], got["cnc_node: job"][1]
        print("encoder: %s %s\njob: %s %s" % (enc.level, enc.message, jb.level, jb.message))
        age = float(values(enc)["age of last reading (ms)"])
        assert age > 900, values(enc)
        assert re.match(r"^encoder signal lost: no reading for \d+ ms \(timeout 25 ms\)$", enc.message), enc.message
        assert values(jb)["state"] == "ERROR" and "spindle encoder signal lost" in values(jb)["last error"]
        assert jb.message == "job %d failed: %s" % (job, st.last_error)
        (m,) = peer.log_lines(lambda m: m.msg.startswith("job %d failed" % job), "the failure on /rosout")
        assert m.level == Log.ERROR and m.msg == "job %d failed: %s" % (job, st.last_error), (m.level, m.msg)
        # the simulator's own statuses stopped (none stamped after the kill)
        with peer.lock:
            after = [s.name for _, a in peer.diags if ns_of(a.header.stamp) > t_kill * 1e9
                     for s in a.status if s.name in SIM_STATUSES]
        assert not after, after
    finally:
        with open(rig.sim_log, "ab") as s:
            rig.sim = start_sim(rig.env, ["--machine", "mill"], s)
    # back: the encoder is OK or WARN again once readings come
    t_back = time.time()
    peer.wait_for("the encoder's status back from ERROR", lambda: "cnc_node: spindle encoder" in peer.statuses(
        t_back + 1.0) and values(peer.statuses(t_back + 1.0)["cnc_node: spindle encoder"][1])[
        "readings per s"] != "0", 60.0)
