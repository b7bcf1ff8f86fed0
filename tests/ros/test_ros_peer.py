"""The controller and simulator nodes against a stock ROS 2 peer: rclpy
(ROS 2 Kilted wheels from PyPI, Fast DDS) with our msgs/ package built for
it. Run through scripts/test.sh (which sets up the peer), or:

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/ros
"""
import os
import subprocess
import sys
import time

import pytest
import rclpy
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

from cnc_msgs.msg import ControllerStatus
from cnc_msgs.srv import RunProgram, SetDelay
from ros_nodes import (ROOT, TARGET, build, cpu_ticks, deep_qos, domain, hearing_peer, host_holdups, read_mcap,
                       SpinningPeer, stamp_s, start, stop)

DOMAIN = domain(1)
NS = "/cnc"
SIM_LOG = None  # the simulator's stderr (the nodes fixture)



@pytest.fixture(scope="module")
def nodes(tmp_path_factory):
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    build()
    # (the simulator's stderr to a file the tests read: its stalls)
    global SIM_LOG
    SIM_LOG = str(tmp_path_factory.mktemp("sim") / "sim_axes.log")
    with open(SIM_LOG, "ab") as log:
        procs = start(env, ["--machine", "mill"],
                      ["--machine", "mill", "--record-dir", os.path.join("target", "test-recordings")],
                      sim_stderr=log)
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rclpy.init()
    yield procs
    rclpy.shutdown()
    stop(procs)


class Peer(SpinningPeer):
    """An rclpy node that records setpoints and status in a spinning thread."""

    def __init__(self, name, own_participant=False):
        super().__init__(name, own_participant)
        self.setpoints = []  # (stamp s, positions m)
        self.status = []
        self.node.create_subscription(JointState, NS + "/joint_setpoints", self._sp, deep_qos())
        self.node.create_subscription(ControllerStatus, NS + "/status", self._st, 100)
        self.run = self.node.create_client(RunProgram, NS + "/run_program")
        self.abort = self.node.create_client(Trigger, NS + "/abort")
        self.hold = self.node.create_client(SetBool, NS + "/feed_hold")
        self.spin()

    def missing(self, timeout=30.0):
        """What has not come within `timeout` s, or None: the service, a
        setpoint and a status."""
        if not self.run.wait_for_service(timeout_sec=timeout):
            return "no %s/run_program service" % NS
        t0 = time.time()
        while not (self.setpoints and self.status) and time.time() - t0 < timeout:
            time.sleep(0.01)
        if self.setpoints and self.status:
            return None
        return "%d setpoints, %d status in %.0f s (this peer knows %d publisher(s) of the setpoints)" % (
            len(self.setpoints), len(self.status), timeout, self.publishers(NS + "/joint_setpoints"))

    def _sp(self, m):
        with self.lock:
            self.setpoints.append((stamp_s(m.header.stamp), list(m.position), list(m.name)))

    def _st(self, m):
        with self.lock:
            self.status.append(m)

    def run_program(self, text, dry_run=False, path=""):
        req = RunProgram.Request()
        req.program = text
        req.program_path = path
        req.dry_run = dry_run
        return self.call(self.run, req)

    def wait_state(self, job_id, state, timeout=30.0):
        self.wait_for("job %d in state %d" % (job_id, state),
                      lambda: any(s.job_id == job_id and s.state == state for s in self.status), timeout)



@pytest.fixture
def peer(nodes):
    p = hearing_peer(lambda own: Peer("peer_%d" % (time.time_ns() % 100000), own), Peer.missing)
    yield p
    p.close()


def test_both_nodes_are_in_the_graph(nodes):
    """`ros2 node list` and `ros2 topic list -t`, as a fresh participant
    asks them (an rclpy peer that was running before our nodes started
    misses them now and then: see ros::keep_announcing)."""
    import json
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN)
    p = subprocess.run([sys.executable, os.path.join(ROOT, "tests", "ros", "node_list.py"), "/cnc", "/sim"],
                       env=env, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    seen = json.loads(p.stdout.strip().splitlines()[-1])
    names = {tuple(n) for n in seen["nodes"]}
    assert ("cnc_node", "/cnc") in names and ("sim_axes", "/sim") in names, names
    topics = seen["topics"]
    assert topics.get("/cnc/joint_setpoints") == ["sensor_msgs/msg/JointState"]
    assert topics.get("/cnc/status") == ["cnc_msgs/msg/ControllerStatus"]
    assert topics.get("/sim/spindle_encoder") == ["cnc_msgs/msg/SpindleEncoder"]


def test_known_program_end_positions_and_rate(peer):
    prog = "N10 G17 G90 G00 X10 Y20 Z5\nN20 G01 X30.0015 F1200\nN30 G02 X40.0015 Y30 I0 J10\nN40 M30\n"
    r = peer.run_program(prog)
    assert r.accepted, r.message
    assert r.job_id >= 1
    # estimate: the check's cycle time, a whole number of ms
    assert r.estimated_duration > 1.0
    assert abs(r.estimated_duration * 1000 - round(r.estimated_duration * 1000)) < 1e-6
    peer.wait_state(r.job_id, ControllerStatus.STATE_RUNNING)
    peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
    # every setpoint of the job taken: the node goes on publishing at rest,
    # so one stamped after the IDLE status comes after all of them, however
    # far this peer's thread is behind (CI's host once had it 0.9 mm short
    # of the end 0.3 s after IDLE)
    with peer.lock:
        idle = next(m for m in peer.status if m.job_id == r.job_id and m.state == ControllerStatus.STATE_IDLE)
    t_idle = stamp_s(idle.header.stamp)
    peer.wait_for("a setpoint stamped after the job's end",
                  lambda: peer.setpoints and peer.setpoints[-1][0] >= t_idle, 10.0)
    with peer.lock:
        sps = list(peer.setpoints)
        sts = list(peer.status)
    assert sps[-1][2] == ["x", "y", "z"]
    end = sps[-1][1]
    # the end point to 1 µm, in metres on the topic
    for got, want in zip(end, [40.0015e-3, 30e-3, 5e-3]):
        assert abs(got - want) < 1e-6, end
    # samples published every cycle: 1 kHz within 1 %, from the stamps (the
    # median period: a sample a busy Python subscriber did not take in time
    # is not the publisher's rate); and nearly all of them arrived
    periods = sorted(b[0] - a[0] for a, b in zip(sps, sps[1:]))
    rate = 1.0 / periods[len(periods) // 2]
    assert abs(rate - 1000.0) < 10.0, rate
    # (an idle machine: all but a few; 86 % with two CPU hogs running, the
    # writer keeping 10 for a reader that falls behind, as ROS 2's do)
    span = sps[-1][0] - sps[0][0]
    assert len(sps) >= 0.5 * span * 1000.0, (len(sps), span)
    # status went through the program's lines
    lines = {s.source_line for s in sts if s.job_id == r.job_id}
    assert {2, 3} <= lines, lines
    last = [s for s in sts if s.job_id == r.job_id][-1]
    assert last.state == ControllerStatus.STATE_IDLE and last.progress == 1.0


class LateJoiner(SpinningPeer):
    """A participant that subscribes (rclpy's default QoS: volatile) only
    after the machine came to rest."""

    def __init__(self, name):
        super().__init__(name)
        self.got = {"setpoints": [], "states": []}
        self.node.create_subscription(JointState, NS + "/joint_setpoints", lambda m: self._m("setpoints", m), 10)
        self.node.create_subscription(JointState, "/sim/joint_states", lambda m: self._m("states", m), 10)
        self.spin()

    def _m(self, k, m):
        with self.lock:
            self.got[k].append((stamp_s(m.header.stamp), list(m.position)))


def test_a_late_subscriber_hears_where_the_machine_stands_at_rest(peer):
    """At rest both nodes publish at 50 Hz only (docs/ros_interface.md
    §3.1); a subscriber that joins then hears where the machine stands
    within 20 ms of its matching, setpoints and joint states alike."""
    r = peer.run_program("G00 X12.5 Y7 Z3\n")
    assert r.accepted, r.message
    peer.wait_state(r.job_id, ControllerStatus.STATE_RUNNING)
    peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
    # the node lingers 1 s at every cycle, the simulator until its axes
    # stand still to the last bit
    time.sleep(4.0)
    late = LateJoiner("late_%d" % (time.time_ns() % 100000))
    try:
        late.wait_for("a setpoint and a joint state", lambda: late.got["setpoints"] and late.got["states"])
        t0 = time.time()
        time.sleep(2.0)
        with late.lock:
            sps, sts = list(late.got["setpoints"]), list(late.got["states"])
    finally:
        late.close()
    span = time.time() - t0
    print("late subscriber: %d setpoints, %d joint states in %.1f s after the first" % (len(sps), len(sts), span))
    want = [0.0125, 0.007, 0.003]
    assert all(all(abs(a - b) < 1e-9 for a, b in zip(p, want)) for _, p in sps), sps[-1]
    assert all(all(abs(a - b) < 1e-6 for a, b in zip(p, want)) for _, p in sts), sts[-1]
    # 50 Hz, on the 1 kHz grid: stamps 20 ms apart (the median: a busy
    # subscriber may miss one), about 50 a second of each
    for name, msgs in (("setpoints", sps), ("joint states", sts)):
        gaps = sorted(b[0] - a[0] for a, b in zip(msgs, msgs[1:]))
        assert gaps and abs(gaps[len(gaps) // 2] - 0.020) < 0.0005, (name, gaps[:3], gaps[-3:])
        assert 30 * span <= len(msgs) <= 60 * (span + 1.0), (name, len(msgs), span)


def test_bad_program_is_refused_with_its_line(peer):
    r = peer.run_program("N10 G00 X10\nN20 G01 X20\nN30 G01 X30 W5 F100\n")
    assert not r.accepted
    lines = r.message.split("\n")
    assert lines[0].startswith("line 2, column 5: block N20: missing feed"), r.message
    assert lines[1].startswith("line 3, column 13: block N30: unknown address 'W'"), r.message
    assert r.job_id == 0
    r = peer.run_program("")
    assert not r.accepted and r.message == "exactly one of program and program_path must be set"


def test_dry_run_moves_nothing(peer):
    r = peer.run_program("G00 X100 Y100\n", dry_run=True)
    assert r.accepted and r.job_id == 0
    assert 0.4 < r.estimated_duration < 1.0, r.estimated_duration


def test_program_path_stays_in_the_program_directory(peer):
    r = peer.run_program("", path="mill_pocket.nc", dry_run=True)
    assert r.accepted, r.message
    assert abs(r.estimated_duration - 19.783) < 0.5, r.estimated_duration
    r = peer.run_program("", path="../config/mill.toml", dry_run=True)
    assert not r.accepted and "may not contain '..'" in r.message
    r = peer.run_program("", path="/etc/passwd", dry_run=True)
    assert not r.accepted and "is absolute" in r.message


def test_busy_refusal_feed_hold_resume_and_abort(peer):
    # 200 mm at 1200 mm/min: 10 s
    r = peer.run_program("G00 X10 Y10 Z0\nG01 X210 F1200\n")
    assert r.accepted, r.message
    peer.wait_state(r.job_id, ControllerStatus.STATE_RUNNING)
    time.sleep(1.5)
    busy = peer.run_program("G00 X1\n")
    assert not busy.accepted and "is running" in busy.message, busy.message
    h = peer.call(peer.hold, SetBool.Request(data=True))
    assert h.success, h.message
    peer.wait_state(r.job_id, ControllerStatus.STATE_HOLD)
    time.sleep(0.5)  # decelerating takes ~20 ms at 1700 mm/s²
    with peer.lock:
        a = peer.setpoints[-1][1][0]
    time.sleep(0.5)
    with peer.lock:
        b = peer.setpoints[-1][1][0]
    assert a == b, (a, b)
    assert 0.02 < a < 0.2
    h = peer.call(peer.hold, SetBool.Request(data=False))
    assert h.success
    time.sleep(0.5)
    with peer.lock:
        c = peer.setpoints[-1][1][0]
    assert c > b + 0.005, (b, c)
    t = peer.call(peer.abort, Trigger.Request())
    assert t.success, t.message
    peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
    time.sleep(0.3)
    with peer.lock:
        d = peer.setpoints[-1][1][0]
        last = [s for s in peer.status if s.job_id == r.job_id][-1]
    assert c < d < 0.2, d
    assert "aborted" in last.last_error, last.last_error
    # and a new job is accepted from where the machine stopped
    r2 = peer.run_program("G01 X10 F3000\n", dry_run=True)
    assert r2.accepted
    assert r2.estimated_duration > (d * 1000 - 10) / 50.0 * 0.9


def _x_speed(peer, t0, t1, timeout=30.0):
    """Mean X setpoint speed (mm/s) over stamps t0..t1 (s), once setpoints
    stamped t1 or later have arrived (a busy subscriber lags behind)."""
    peer.wait_for("setpoints up to %.3f" % t1, lambda: peer.setpoints and peer.setpoints[-1][0] >= t1, timeout)
    with peer.lock:
        pts = [(t, p[0]) for t, p, _ in peer.setpoints if t0 <= t <= t1]
    # (from the first and the last: exact whatever a busy subscriber missed
    # in between; a third of them with two CPU hogs running)
    assert len(pts) > 20 and pts[-1][0] - pts[0][0] > 0.5 * (t1 - t0), (len(pts), t0, t1)
    return (pts[-1][1] - pts[0][1]) * 1000.0 / (pts[-1][0] - pts[0][0])


def _status_when(peer, job_id, cond, timeout=30.0):
    """The stamp (s) of the job's first status that meets `cond`."""
    def first():
        return next((s for s in peer.status if s.job_id == job_id and cond(s)), None)
    peer.wait_for("a status of job %d" % job_id, lambda: first() is not None, timeout)
    with peer.lock:
        return stamp_s(first().header.stamp)


def test_feed_override_topic_scales_the_running_job(peer):
    from std_msgs.msg import Float64
    pub = peer.node.create_publisher(Float64, NS + "/feed_override", 10)
    # 400 mm at F3000 = 50 mm/s (X allows 250); the speeds are measured by
    # the setpoints' stamps from the status that shows the override in
    # force (this peer's own timing is no measure on a busy machine)
    r = peer.run_program("G00 X10 Y10 Z0\nG01 X410 F3000\n")
    assert r.accepted, r.message
    try:
        t = _status_when(peer, r.job_id, lambda s: s.source_line == 2)
        v100 = _x_speed(peer, t + 0.3, t + 0.7)
        assert abs(v100 - 50.0) < 0.5, v100
        for pct in (50.0, 150.0):
            pub.publish(Float64(data=pct))
            t = _status_when(peer, r.job_id, lambda s: abs(s.feed_override - pct / 100.0) < 1e-9)
            v = _x_speed(peer, t + 0.1, t + 0.5)
            assert abs(v - 50.0 * pct / 100.0) < 0.5, (pct, v, v100)
        # out of range: refused, nothing changes
        pub.publish(Float64(data=500.0))
        t = time.time() + 0.2
        v = _x_speed(peer, t, t + 0.3)
        assert abs(v - 75.0) < 0.5, v
        with peer.lock:
            over = [s.feed_override for s in peer.status if s.job_id == r.job_id][-1]
        assert over == 1.5, over
    finally:
        # the override stays in force for later jobs (as on a control
        # panel): back to 100 % whatever failed above, or every later test
        # would run at another speed than its estimate
        pub.publish(Float64(data=100.0))
        peer.wait_for("the override back at 100 %",
                      lambda: [s.feed_override for s in peer.status][-1] == 1.0, 10.0)
        t = peer.call(peer.abort, Trigger.Request())
        assert t.success, t.message
        peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
        peer.node.destroy_publisher(pub)


def test_short_lived_clients_get_their_reply_every_time(nodes):
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN)
    ok = 0
    for i in range(20):
        p = subprocess.run([sys.executable, os.path.join(ROOT, "tests", "ros", "oneshot_call.py"), NS],
                           env=env, capture_output=True, text=True, timeout=60)
        assert p.returncode == 0, (i, p.stdout, p.stderr)
        assert "accepted=True" in p.stdout, p.stdout
        ok += 1
    assert ok == 20


def test_two_machines_share_a_domain_and_a_5mb_program_goes_by_path(peer, tmp_path):
    """A second controller+simulator pair under /cnc2 and /sim2 in the same
    domain: its job moves only its own axes; a 5 MB program by program_path
    is accepted."""
    prog = tmp_path / "big.ngc"
    subprocess.run([sys.executable, os.path.join(ROOT, "bench", "gen_program.py"), "--blocks", "115000",
                    "--out", str(prog)], check=True, capture_output=True)
    size = prog.stat().st_size
    assert size > 5_000_000, size
    # the peer's subscription to /cnc2 and its clients are made before the
    # second pair starts, so they are in its first exchange with the peer
    # (a reader made later on this peer, once matched, went unmatched for
    # over 30 s in about half of the full suite's runs with two CPU hogs
    # running: no setpoints from /cnc2 nor /cnc, while calls were answered)
    got2 = []

    def on_cnc2(m):
        with peer.lock:
            got2.append((stamp_s(m.header.stamp), list(m.position)))
    sub2 = peer.node.create_subscription(JointState, "/cnc2/joint_setpoints", on_cnc2, 10)
    run2 = peer.node.create_client(RunProgram, "/cnc2/run_program")
    abort2 = peer.node.create_client(Trigger, "/cnc2/abort")
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN)
    procs = start(env, ["--machine", "mill", "--namespace", "/sim2", "--controller-namespace", "/cnc2"],
                  ["--machine", "mill", "--namespace", "/cnc2", "--sim-namespace", "/sim2",
                   "--program-dir", str(tmp_path)])
    try:
        assert run2.wait_for_service(timeout_sec=30.0)
        want = {("cnc_node", "/cnc"), ("cnc_node", "/cnc2"), ("sim_axes", "/sim"), ("sim_axes", "/sim2")}
        t0 = time.time()
        while time.time() - t0 < 10:
            names = set(peer.node.get_node_names_and_namespaces())
            if want <= names:
                break
            time.sleep(0.1)
        assert want <= names, names
        req = RunProgram.Request()
        req.program_path = "big.ngc"
        t0 = time.time()
        r = peer.call(run2, req, timeout=30.0)
        answered = time.time() - t0
        assert r.accepted, r.message
        assert r.estimated_duration > 3600, r.estimated_duration
        # 100 setpoints of each pair (in 0.1 s on an idle machine; a
        # Python subscriber sharing two busy cores takes longer)
        def counts():
            with peer.lock:
                return ([p for t, p, _ in peer.setpoints if t > t_from], [p for t, p in got2 if t > t_from])
        t_from = time.time()
        while time.time() - t_from < 30 and min(map(len, counts())) < 101:
            time.sleep(0.01)
        cnc, cnc2 = counts()
        print("100 setpoints of each pair after %.2f s" % (time.time() - t_from))
        # /cnc2 moves, /cnc stands still
        assert len(cnc2) > 100 and len(cnc) > 100, (len(cnc2), len(cnc))
        assert cnc2[0] != cnc2[-1]
        assert all(p == cnc[0] for p in cnc)
        a = peer.call(abort2, Trigger.Request(), timeout=10.0)
        assert a.success, a.message
        print("5 MB program (%d bytes) accepted after %.2f s" % (size, answered))
    finally:
        peer.node.destroy_subscription(sub2)
        peer.node.destroy_client(run2)
        peer.node.destroy_client(abort2)
        stop(procs)


def test_a_job_recorded_by_the_node_decodes_with_an_independent_reader(peer):
    """RunProgram.record: the node records the job; mcap + mcap-ros2-support
    decode every message; one setpoint per cycle, ending on the end point."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    req = RunProgram.Request()
    req.program = "N10 G00 X12 Y34 Z5\nN20 G01 X40 F3000\nM30\n"
    req.record = True
    r = peer.call(peer.run, req)
    assert r.accepted, r.message
    assert r.recording.endswith("job_%d_program.mcap" % r.job_id), r.recording
    peer.wait_state(r.job_id, ControllerStatus.STATE_RUNNING)
    peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
    path = os.path.join(ROOT, r.recording)
    t0 = time.time()
    while time.time() - t0 < 10:  # closed by the node right after the job
        try:
            with open(path, "rb") as f:
                reader = make_reader(f, decoder_factories=[DecoderFactory()])
                counts, last, ticks = {}, None, None
                for _, ch, _, dec in reader.iter_decoded_messages():
                    counts[ch.topic] = counts.get(ch.topic, 0) + 1
                    if ch.topic == "/cnc/joint_setpoints":
                        last = list(dec.position)
                break
        except Exception:
            time.sleep(0.2)
    ticks = round(r.estimated_duration * 1000)
    assert counts["/cnc/joint_setpoints"] == ticks + 1, (counts, ticks)
    for topic in ["/cnc/status", "/cnc/spindle_command", "/sim/joint_states", "/sim/spindle_encoder",
                  "/tf", "/cnc/tool_pose", "/cnc/toolpath", "/cnc/program", "/cnc/machine_file"]:
        assert counts.get(topic, 0) >= 1, (topic, counts)
    for got, want in zip(last, [0.040, 0.034, 0.005]):
        assert abs(got - want) < 1e-9, last


def test_bag_replay_republishes_a_recording_and_bag_record_records_live_topics(nodes, tmp_path):
    """`cnc bag replay` of the golden mill_pocket recording reaches a stock
    subscriber; `cnc bag record` records the replayed topics, and the two
    recordings hold the same setpoints."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    env = dict(os.environ, ROS_DOMAIN_ID=domain(2))
    cnc = os.path.join(TARGET, "cnc")
    out = tmp_path / "live.mcap"
    # replay into namespace /cnc of another domain (no controller there)
    rec = subprocess.Popen([cnc, "bag", "record", "-o", str(out), "--duration", "17"], env=env, cwd=ROOT)
    time.sleep(2.0)
    rep = subprocess.run([cnc, "bag", "replay", os.path.join(ROOT, "bags", "mill_pocket.mcap"), "--rate", "2"],
                         env=env, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert rep.returncode == 0, rep.stderr
    assert "messages republished" in rep.stdout
    rec.wait(timeout=30)
    assert rec.returncode == 0
    with open(out, "rb") as f:
        counts, last = {}, None
        for _, ch, _, dec in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            counts[ch.topic] = counts.get(ch.topic, 0) + 1
            if ch.topic == "/cnc/joint_setpoints":
                last = list(dec.position)
    # 19,804 setpoints in the golden at 2 kHz (keep-last-10: a loaded
    # machine may drop some); the last one is the end point exactly
    assert counts["/cnc/joint_setpoints"] > 15000, counts
    assert counts["/sim/joint_states"] > 15000 and counts["/cnc/status"] > 150, counts
    for got, want in zip(last, [0.020, 0.010, 0.005]):
        assert abs(got - want) < 1e-12, last


def test_cnc836_helix_and_loops_through_the_service(peer):
    """The seed's helix program (G10/G09/G73/G98) is checked through the
    service as offline: the same estimate; a broken rule is refused with its line."""
    r = peer.run_program("", path="cnc836_helix.nc", dry_run=True)
    assert r.accepted, r.message
    # offline (from home) 274.057 s; the node checks from where the machine
    # stands, which changes only the first rapid (well under 2 s)
    assert abs(r.estimated_duration - 274.057) < 2.0, r.estimated_duration
    r = peer.run_program("N10 G00 X1\nN20 G73 L30 Q1\nN30 X2\n", dry_run=True)
    assert not r.accepted
    assert r.message == ("line 2, column 9: block N20: jump target N30 is not a block at or before this one "
                         "(G73 jumps back only)"), r.message


def test_heidenhain_polar_through_the_service(peer):
    """Polar lines and arcs about a pole, checked through the service; a
    broken direction rule is refused with its line and column."""
    req = RunProgram.Request()
    req.program_path = "heidenhain_polar.h"
    req.dialect = "heidenhain"
    req.dry_run = True
    r = peer.call(peer.run, req)
    assert r.accepted, r.message
    # offline (from home) 15.213 s; the first moves start where the machine stands
    assert abs(r.estimated_duration - 15.213) < 4.0, r.estimated_duration
    req = RunProgram.Request()
    req.program = "N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G91 G12 H+90 *\n"
    req.dialect = "heidenhain"
    req.dry_run = True
    r = peer.call(peer.run, req)
    assert not r.accepted
    assert r.message.startswith("line 3, column 12: block N3: incremental H90 turns counter-clockwise"), r.message


def finished_recording(path, timeout=15.0):
    """The topics of a recording once the node has closed it (a file still
    being written has no summary and does not read)."""
    t0 = time.time()
    while True:
        try:
            return read_mcap(path)
        except Exception:
            if time.time() - t0 > timeout:
                raise
            time.sleep(0.2)


def test_the_simulated_axes_over_dds_move_as_the_offline_simulation(peer, tmp_path):
    """What the machine does, not only what it is told: the simulated
    axes' /sim/joint_states over DDS, at the bundled mill's 200 m/s³,
    against `cnc simulate` of the same program (the same axis model in
    process). The simulator steps on its own clock, a fraction of a cycle
    after the controller's, and applies each setpoint `delay_ms` after its
    stamp, interpolated; so the state stamped t is the offline run's axes
    interpolated at (t - first setpoint) / 1 ms - delay_ms. Transport that
    takes nothing away leaves them within 0.07 µm (bench/motion/actual.py,
    release builds); a setpoint that arrives late on a busy host moves them
    by up to a·t²/2 around it (135 µm once, on a CI host that held the
    nodes up through a tenth of the job).

    The simulator's delay is 10 ms in this test (/sim/setpoint_delay; 3
    in the machine file): the setpoints lead nothing here (no thread),
    and 10 ms covers this VM's transport but for stalls of the host. A run
    that is off while the simulator reported such a stall (late
    setpoints, its loop held up) or the hypervisor took 1 % of the CPUs'
    time (`host_stolen`) is run again, three runs at most; a run that is
    off with neither fails at once; when all three were
    off so, the test skips with the reasons (it measured the host: a CI
    VM with 5-14 % steal time held up all three runs of one suite)."""
    delay_ms = 10.0
    setpoint_delay = peer.node.create_client(SetDelay, "/sim/setpoint_delay")
    assert setpoint_delay.wait_for_service(timeout_sec=30.0)
    r = peer.call(setpoint_delay, SetDelay.Request(delay_ms=delay_ms))
    assert r.success, r.message
    try:
        offs = []
        for attempt in range(3):
            since, ticks = os.path.getsize(SIM_LOG), cpu_ticks()
            off = dds_against_offline(peer, tmp_path, delay_ms)
            if not off:
                break
            held = host_holdups(SIM_LOG, since, ticks, wait=1.5)
            print("run %d: %s; the host: %s" % (attempt + 1, off, held))
            assert held, "%s, and neither the hypervisor nor the simulator held the nodes up" % off
            offs.append("%s (%s)" % (off, held[0]))
    finally:
        # (the machine file's delay back for the tests after; asserted
        # after the block, so it never hides the failure above)
        restored = peer.call(setpoint_delay, SetDelay.Request(delay_ms=3.0))
    assert restored.success, restored.message
    if off:
        pytest.skip("three runs, each off while the host held the nodes up: %s" % "; ".join(offs))


def dds_against_offline(peer, tmp_path, delay_ms):
    """One run of the comparison (the test above): what was off, or ""."""
    import math
    prog = ("G17 G90 G00 X10 Y10 Z5\nG01 Z-1 F600\nG01 X40 F3000\nG02 X50 Y20 I0 J10\n"
            "G01 Y40\nG03 X40 Y50 I-10 J0\nG00 Z5\nM30\n")
    # from rest at home, as `cnc simulate` starts (the tests before leave
    # the machine elsewhere): a job there, then half a second for the
    # axes to settle
    home = peer.run_program("G90 G00 X0 Y0 Z0\nM30\n")
    assert home.accepted, home.message
    # (already there when this test runs alone: the job may end at once)
    peer.wait_state(home.job_id, ControllerStatus.STATE_IDLE)
    time.sleep(0.5)
    req = RunProgram.Request()
    req.program = prog
    req.record = True
    r = peer.call(peer.run, req)
    assert r.accepted and r.recording, r
    peer.wait_state(r.job_id, ControllerStatus.STATE_RUNNING)
    peer.wait_state(r.job_id, ControllerStatus.STATE_IDLE)
    rec = finished_recording(r.recording if os.path.isabs(r.recording) else os.path.join(ROOT, r.recording))
    sps = sorted((stamp_s(d.header.stamp), [p * 1000 for p in d.position]) for _, d in rec["/cnc/joint_setpoints"])
    sts = sorted((stamp_s(d.header.stamp), [p * 1000 for p in d.position]) for _, d in rec["/sim/joint_states"])
    t0, t1 = sps[0][0], sps[-1][0]
    # every cycle of the job: the setpoints (the node's own) none missing
    assert abs((t1 - t0) * 1000 + 1 - len(sps)) < 0.5 and len(sps) > 2000, (len(sps), t1 - t0)
    job = [s for s in sts if t0 <= s[0] <= t1]
    # the offline run of the same program
    prog_file = tmp_path / "p.nc"
    prog_file.write_text(prog)
    csv = tmp_path / "p.csv"
    subprocess.run([os.path.join(TARGET, "cnc"), "simulate", str(prog_file), "--machine", "mill", "--csv", str(csv)],
                   check=True, capture_output=True, timeout=120)
    rows = [[float(x) for x in ln.split(",")] for ln in csv.read_text().splitlines()[1:]]
    assert len(rows) == len(sps), (len(rows), len(sps))
    # the same setpoints, to the bit the topic carries (m as f64)
    assert max(abs(a - b) for (_, s), row in zip(sps, rows) for a, b in zip(s, row[1:4])) < 1e-9
    # and the axes do move: the offline actual lags its setpoint by up to
    # tens of µm at 50 mm/s, so a comparison of the setpoints with
    # themselves would not pass the bounds below
    lag = max(math.dist(row[1:4], row[4:7]) for row in rows)
    assert lag > 0.010, lag
    # the node takes the joint states best effort (docs/ros_interface.md
    # §2): some may be lost on the way where the host held the nodes up
    # (1 and 12 of 3362 seen so, 45-168 on a CI VM with 5-14 % steal
    # time); those that came are compared, and a tenth lost is off
    missing = round((job[-1][0] - job[0][0]) * 1000 + 1 - len(job))
    if missing > 0.1 * (len(job) + missing):
        return "%d joint states of %d lost on the way" % (missing, len(job) + missing)
    act = [row[4:7] for row in rows]
    diffs = []
    for t, p in job:
        x = (t - t0) * 1000 - delay_ms
        k = math.floor(x)
        if 0 <= k < len(act) - 1:
            f = x - k
            diffs.append(math.dist(p, [u + (w - u) * f for u, w in zip(act[k], act[k + 1])]))
    diffs.sort()
    # (the joint states of the job's last DELAY_MS are for after its end)
    assert len(diffs) > len(job) - delay_ms - 5, (len(diffs), len(job))
    assert len(diffs) > 2000, len(diffs)
    p90 = diffs[int(0.9 * (len(diffs) - 1))]
    print("DDS actual against offline: %d samples (%d lost on the way), "
          "p50 %.4f p90 %.4f p99 %.4f p99.9 %.4f µm, max %.4f µm" % (
        (len(diffs), missing) + tuple(diffs[int(q * (len(diffs) - 1))] * 1000 for q in (0.5, 0.9, 0.99, 0.999, 1.0))))
    # (debug builds in this suite: p90 0.007-0.01 µm, p99 0.02-0.09 µm,
    # max 0.7-3.5 µm where setpoints came late; a simulator that applied
    # them on arrival, or a model that differed, would be tens of µm off
    # at most samples: the p90 bound. The max bound only catches what no
    # lateness explains: while a setpoint is late the simulator goes on at
    # the last speed, so one 5 ms late while the axis accelerates at 2000
    # mm/s² moves it by a·t²/2 = 25 µm for a moment.)
    if p90 >= 0.00005 or diffs[-1] >= 0.100:
        return "p90 %.4f µm, max %.4f µm" % (p90 * 1000, diffs[-1] * 1000)
    return ""
