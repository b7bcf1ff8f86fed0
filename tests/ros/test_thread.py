"""G33 thread cutting over DDS: the controller node follows the simulator's
spindle encoder (/sim/spindle_encoder), a stock rclpy peer measures the
lead error and the groove's phase from the setpoints and the encoder
messages by their stamps, and the simulator's fault injection services
(/sim/encoder_enabled, /sim/spindle_stalled) make the faults.

    bash scripts/ros_peer/setup.sh && . .venv-ros/env.sh
    python -m pytest tests/ros -k thread -x -q

The measured numbers are printed (-s shows them).
"""
import bisect
import math
import os
import time

import pytest
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool

from cnc_msgs.msg import ControllerStatus, SpindleEncoder
from cnc_msgs.srv import RunProgram
from ros_nodes import ROOT, build, start, SpinningPeer, stop

DOMAIN = str(100 + os.getpid() % 100)
NS, SIM = "/cnc", "/sim"
ERROR = ControllerStatus.STATE_ERROR
IDLE = ControllerStatus.STATE_IDLE


@pytest.fixture(scope="module")
def machine(request):
    """Both nodes on a machine (`lathe` or `mill`, by indirect
    parametrization: one pair at a time, on the default namespaces)."""
    name = request.param
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    build()
    # the simulator's stderr (its stall reports) for Peer.attempts
    logs = os.path.join(ROOT, "target", "test-logs")
    os.makedirs(logs, exist_ok=True)
    sim_log = os.path.join(logs, "thread_sim_axes_%s.log" % name)
    # CNC_LOOP_STATS=S: the node logs its loop's lateness and the encoder
    # readings' age every S seconds
    stats = ["--loop-stats", os.environ["CNC_LOOP_STATS"]] if os.environ.get("CNC_LOOP_STATS") else []
    with open(sim_log, "wb") as f:
        procs = start(env, ["--machine", name], ["--machine", name] + stats, sim_stderr=f)
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rclpy.init()
    peer = None
    try:
        peer = Peer("thread_peer_%d" % (time.time_ns() % 100000))
        peer.sim_log = sim_log
        yield peer
    finally:
        if peer is not None:
            peer.close()
        rclpy.shutdown()
        stop(procs)


class Peer(SpinningPeer):
    """Records setpoints, encoder readings, spindle commands and status (by
    their stamps) in a spinning thread; calls the services."""

    def __init__(self, name):
        super().__init__(name)
        self.setpoints = []  # (stamp s, positions m)
        self.encoder = []  # (stamp s, count, counts_per_rev, count_at_index)
        self.spindle = []  # (stamp s of the setpoint before, rad/s)
        self.status = []
        self.last_end = None
        deep = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(JointState, NS + "/joint_setpoints", self._sp, deep)
        self.node.create_subscription(SpindleEncoder, SIM + "/spindle_encoder", self._enc, deep)
        self.node.create_subscription(Float64, NS + "/spindle_command", self._spin, 10)
        self.node.create_subscription(ControllerStatus, NS + "/status", self._st, 100)
        self.run = self.node.create_client(RunProgram, NS + "/run_program")
        self.encoder_enabled = self.node.create_client(SetBool, SIM + "/encoder_enabled")
        self.spindle_stalled = self.node.create_client(SetBool, SIM + "/spindle_stalled")
        self.spin()
        for c in (self.run, self.encoder_enabled, self.spindle_stalled):
            assert c.wait_for_service(timeout_sec=30.0), "no service %s" % c.srv_name
        # the encoder is flowing (the subscription is matched)
        t0 = time.time()
        while time.time() - t0 < 10 and not self.encoder:
            time.sleep(0.05)
        assert self.encoder, "no encoder messages"

    def _sp(self, m):
        with self.lock:
            self.setpoints.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, list(m.position)))

    def _enc(self, m):
        with self.lock:
            self.encoder.append((m.stamp.sec + m.stamp.nanosec * 1e-9, m.count, m.counts_per_rev,
                                 m.count_at_index))

    def _spin(self, m):
        with self.lock:
            t = self.setpoints[-1][0] if self.setpoints else 0.0
            self.spindle.append((t, m.data))

    def _st(self, m):
        with self.lock:
            self.status.append(m)

    def clear(self):
        self.last_end = None
        with self.lock:
            self.setpoints.clear()
            self.encoder.clear()
            self.spindle.clear()

    def run_program(self, text, dry_run=False):
        req = RunProgram.Request()
        req.program = text
        req.dialect = "cnc836"
        req.dry_run = dry_run
        return self.call(self.run, req)

    def set(self, client, on):
        r = self.call(client, SetBool.Request(data=on))
        assert r.success, r.message
        return r

    def final_status(self, job_id, timeout=60.0):
        """The job's status once it left running/hold (idle or error)."""
        t0 = time.time()
        while time.time() - t0 < timeout:
            with self.lock:
                mine = [s for s in self.status if s.job_id == job_id]
            if mine and mine[-1].state in (IDLE, ERROR) and any(
                    s.state == ControllerStatus.STATE_RUNNING for s in mine):
                self.last_end = mine[-1]
                return mine[-1]
            time.sleep(0.02)
        raise AssertionError("job %d did not end" % job_id)

    def run_to_end(self, text):
        r = self.run_program(text)
        assert r.accepted, r.message
        st = self.final_status(r.job_id, timeout=r.estimated_duration + 30.0)
        self.last_end = st
        time.sleep(0.3)  # the last setpoints and readings arrive
        with self.lock:
            return st, list(self.setpoints), list(self.encoder)

    def log_size(self):
        return os.path.getsize(self.sim_log)

    def sim_stalls(self, since):
        """The simulator's stall reports since `since` (a log size)."""
        with open(self.sim_log, "rb") as f:
            f.seek(since)
            return [l for l in f.read().decode(errors="replace").splitlines() if "stalled" in l]

    def attempts(self, what, n=3):
        """Runs of a job: the next one only when the last ended with the
        encoder lost while the simulator reported a stall. On a machine
        that holds up the simulator's real-time loop for 10 ms and more
        (a busy VM without a real-time kernel) the readings really were
        missing that long, and the controller is right to stop; any other
        loss of the encoder fails the test."""
        for i in range(n):
            since = self.log_size()
            yield i
            st = self.last_end
            if st is None or st.state != ERROR or "encoder signal lost" not in st.last_error:
                return
            stalls = self.sim_stalls(since)
            if not stalls:
                return
            print("%s: attempt %d ended with %r after the simulator %s; again"
                  % (what, i + 1, st.last_error, stalls[-1]))



def pairs_at(setpoints, encoder, axis, start, lo, hi, max_gap=0.004):
    """(stamp, position mm, revolutions from the index) of the setpoints of
    a pass in -`axis` from `start` whose `axis` is within lo..hi mm, with the encoder count interpolated at
    the setpoint's stamp between the two readings around it (the count's
    centre: count + 0.5). Setpoints without readings within `max_gap` on
    both sides are left out."""
    ts = [e[0] for e in encoder]
    out = []
    # the pass: from the thread's start (`start`, mm) to where the lead axis
    # is furthest along (not the moves before or the return)
    last = min(range(len(setpoints)), key=lambda i: setpoints[i][1][axis])
    first = max(i for i in range(last + 1) if setpoints[i][1][axis] * 1000.0 >= start - 1e-6)
    for t, pos in setpoints[first:last + 1]:
        p = pos[axis] * 1000.0
        if not (lo <= p <= hi):
            continue
        i = bisect.bisect_left(ts, t)
        if i == 0 or i >= len(ts):
            continue
        a, b = encoder[i - 1], encoder[i]
        if b[0] == t:
            a = b
        if t - a[0] > max_gap or b[0] - t > max_gap:
            continue
        f = 0.0 if b[0] == a[0] else (t - a[0]) / (b[0] - a[0])
        count = a[1] + f * (b[1] - a[1]) + 0.5
        # revolutions from the index (an index mark is at count_at_index)
        revs = (count - a[3]) / a[2]
        out.append((t, p, revs))
    return out


def lead_stats(pairs, start, sign, pitch, cpr):
    """Lead error spread in counts (after removing the pass's mean) and the
    groove's phase in degrees, in (-180, 180]: the mean of
    (lead travel)/pitch - revolutions, mod 1 revolution."""
    d = [sign * (start - p) / pitch - revs for _, p, revs in pairs]
    # about the circular mean (whole turns apart are the same groove)
    ref = math.atan2(sum(math.sin(2 * math.pi * x) for x in d),
                     sum(math.cos(2 * math.pi * x) for x in d)) / (2 * math.pi)
    d = [x - round(x - ref) for x in d]
    mean = sum(d) / len(d)
    err = [(x - mean) * cpr for x in d]
    phase = (mean % 1.0) * 360.0
    if phase > 180.0:
        phase -= 360.0
    return max(err) - min(err), phase, err


def wrap(deg):
    deg = deg % 360.0
    return deg - 360.0 if deg > 180.0 else deg


def example1(rpm, z_end=-40):
    return "N5 G00 X20 Z5\nN10 M03 S%d\nN20 G33 Z%d F1\nN30 G00 X30\nN40 Z5\nN50 M30\n" % (rpm, z_end)


@pytest.mark.parametrize("machine", ["lathe"], indirect=True)
def test_thread_example_1_lead_and_phase_at_s200_and_s800(machine):
    peer = machine
    res = {}
    for rpm in (200, 800):
        for _ in peer.attempts("S%d" % rpm):
            peer.clear()
            st, sps, enc = peer.run_to_end(example1(rpm))
        assert st.state == IDLE and st.last_error == "", (st.state, st.last_error)
        # lathe joints: x (radius), z; the end: X30 (radius 15), Z5
        end = sps[-1][1]
        assert abs(end[0] - 0.015) < 1e-9 and abs(end[1] - 0.005) < 1e-9, end
        cpr = enc[-1][2]
        pairs = pairs_at(sps, enc, 1, 5.0, -35.0, -2.0)
        # one setpoint a millisecond over the synchronized part (a slow
        # subscriber may miss a few)
        span = 33.0 / (rpm / 60.0)
        assert len(pairs) > 0.8 * span * 1000, (len(pairs), span)
        spread, phase, err = lead_stats(pairs, 5.0, 1.0, 1.0, cpr)
        worst = max(abs(e) for e in err)
        print("S%d: %d setpoints, lead error spread %.2f counts (max |e| %.2f), groove phase %.3f deg"
              % (rpm, len(pairs), spread, worst, phase))
        res[rpm] = (spread, phase)
    # measured (debug builds, a busy 2-core VM): spreads 0.8-1.8 counts,
    # phases 0.000 deg (setpoints and readings stamped with the instants
    # they stand for; 0.05 deg is 10 us at S800)
    for rpm, (spread, phase) in res.items():
        # (over DDS on this VM: 0.8-3.2 counts; offline the same executor
        # stays within one count of the true angle, tests in
        # cnc_node/tests/thread.rs. The rest here is the readings' delivery.)
        assert spread <= 4.0, (rpm, spread)
        # I0: the groove starts on the index
        assert abs(phase) <= 0.05, (rpm, phase)
    d = wrap(res[800][1] - res[200][1])
    print("groove phase S800 - S200: %.3f deg" % d)
    assert abs(d) <= 0.05, d


def wait_lead_past(peer, job_id, axis, limit, timeout=30.0):
    """Waits until the setpoint of `axis` is below `limit` (m); returns it,
    or None when the job ended first."""
    t0 = time.time()
    while time.time() - t0 < timeout:
        with peer.lock:
            p = peer.setpoints[-1][1][axis] if peer.setpoints else None
            ended = any(s.job_id == job_id and s.state in (IDLE, ERROR) for s in peer.status)
        if p is not None and p < limit:
            return p
        if ended:
            return None
        time.sleep(0.001)
    raise AssertionError("the job neither passed %g nor ended" % limit)


@pytest.mark.parametrize("machine", ["lathe"], indirect=True)
def test_thread_lost_encoder_stops_the_axes_under_control(machine):
    peer = machine
    prog = example1(800, z_end=-20)
    for _ in peer.attempts("lost encoder"):
        peer.clear()
        r = peer.run_program(prog)
        assert r.accepted, r.message
        # stop the encoder once Z passes -10
        z = wait_lead_past(peer, r.job_id, 1, -0.010)
        if z is None:
            peer.final_status(r.job_id)
            continue
        peer.last_end = None  # (this run is the test's)
        t_off = time.time()
        try:
            peer.set(peer.encoder_enabled, False)
            print("encoder stopped at Z %.3f mm (the call took %.0f ms)" % (z * 1000, (time.time() - t_off) * 1000))
            st = peer.final_status(r.job_id, timeout=10)
        finally:
            peer.set(peer.encoder_enabled, True)
        peer.last_end = None
    assert z is not None, "Z never passed -10: %s" % peer.last_end.last_error
    time.sleep(0.3)
    with peer.lock:
        sps = list(peer.setpoints)
        spin = list(peer.spindle)
    assert st.state == ERROR, (st.state, st.last_error)
    assert "line 3" in st.last_error and "encoder" in st.last_error, st.last_error
    print("status: %s" % st.last_error)
    assert st.spindle_speed_command == 0.0, st.spindle_speed_command
    assert spin and spin[-1][1] == 0.0, spin[-3:]
    # the setpoints of the job: consecutive ones (1 ms apart) never step
    # more than the lead speed allows, and Z comes to rest short of the end
    dt = 0.001
    v = 800 / 60.0 * 1.0  # mm/s on the thread
    zs = [(t, p[1] * 1000.0) for t, p in sps]
    steps = [(b[1] - a[1], round((b[0] - a[0]) / dt)) for a, b in zip(zs, zs[1:])]
    worst = max(abs(s) / n for s, n in steps if n >= 1)
    print("largest Z step %.4f mm per cycle (lead speed x dt = %.4f)" % (worst, v * dt))
    assert worst <= v * 1.06 * dt + 2500.0 * dt * dt, worst
    # Z at rest at the end, between where the encoder stopped and the end
    z_end = zs[-1][1]
    assert -20.0 < z_end < -10.0, z_end
    assert all(abs(p - z_end) < 1e-9 for _, p in zs[-50:]), zs[-50:]
    # deceleration: from the lead speed to rest, within the axis limit
    moving = [i for i, (s, n) in enumerate(steps) if n == 1 and abs(s) > 1e-9]
    last = moving[-1]
    tail = steps[max(0, last - 40):last + 2]
    acc = [abs(b[0] - a[0]) / dt / dt for a, b in zip(tail, tail[1:]) if a[1] == 1 and b[1] == 1]
    slowing = sum(1 for s, n in tail if 0 < abs(s) < v * dt * 0.99)
    print("stop: Z at rest at %.4f mm, %d cycles of deceleration, largest %.0f mm/s^2"
          % (z_end, slowing, max(acc)))
    assert max(acc) <= 2500.0, max(acc)
    assert slowing >= 3, tail
    # the node keeps running: a dry run answers
    r = peer.run_program("G00 X30 Z5\n", dry_run=True)
    assert r.accepted, r.message


@pytest.mark.parametrize("machine", ["lathe"], indirect=True)
def test_thread_stalled_spindle_is_an_error_and_the_thread_does_not_move(machine):
    peer = machine
    # back to the start of the thread first
    st, _, _ = peer.run_to_end("N5 G00 X20 Z5\n")
    assert st.state == IDLE, st.last_error
    for _ in peer.attempts("stalled spindle"):
        peer.clear()
        peer.set(peer.spindle_stalled, True)
        try:
            r = peer.run_program(example1(200, z_end=-15))
            assert r.accepted, r.message
            st = peer.final_status(r.job_id, timeout=20)
        finally:
            peer.set(peer.spindle_stalled, False)
    time.sleep(0.3)
    with peer.lock:
        sps = list(peer.setpoints)
    print("stalled spindle: %s" % st.last_error)
    assert st.state == ERROR, (st.state, st.last_error)
    assert st.last_error.startswith("line 3: G33 needs the spindle at S200 but it turns at 0 rpm"), st.last_error
    # Z never left the thread's start
    assert all(p[1] >= 0.005 - 1e-12 for _, p in sps), min(p[1] for _, p in sps)
    r = peer.run_program("G00 X30 Z5\n", dry_run=True)
    assert r.accepted, r.message


@pytest.mark.parametrize("machine", ["mill"], indirect=True)
def test_thread_example_2_in_y_starts_180_degrees_after_the_index(machine):
    peer = machine
    prog = "N5 G00 X50 Y10 Z10\nN10 M03 S600\nN20 G33 Y-30 F1.5 I180\nN30 G00 Z50\nN40 M30\n"
    for _ in peer.attempts("Example 2"):
        peer.clear()
        st, sps, enc = peer.run_to_end(prog)
    assert st.state == IDLE and st.last_error == "", (st.state, st.last_error)
    cpr = enc[-1][2]
    pairs = pairs_at(sps, enc, 1, 10.0, -25.0, 8.0)
    assert len(pairs) > 0.8 * 33.0 / 15.0 * 1000, len(pairs)
    spread, phase, _ = lead_stats(pairs, 10.0, 1.0, 1.5, cpr)
    print("Example 2: lead error spread %.2f counts, groove phase %.3f deg (want -180)" % (spread, phase))
    # measured: spreads 1.1-2.5 counts, phase 180.000 deg
    assert spread <= 4.0, spread  # (measured 1.0-3.2 counts over DDS)
    # (y_start - y)/1.5 - revs = -0.5 rev (mod 1): 180 degrees
    assert abs(wrap(phase - 180.0)) <= 0.05, phase
    end = sps[-1][1]
    assert all(abs(a - b) < 1e-9 for a, b in zip(end, [0.050, -0.030, 0.050])), end


@pytest.mark.parametrize("machine", ["lathe"], indirect=True)
def test_thread_examples_3_taper_and_4_runout(machine):
    peer = machine
    # Example 3: a taper thread, X (diameter 10 -> 12, radius 5 -> 6) moves
    # in proportion while Z leads with the pitch, 2 mm/rev
    for _ in peer.attempts("Example 3"):
        peer.clear()
        st, sps, enc = peer.run_to_end(
            "N5 G00 X10 Z5\nN10 M03 S800\nN20 G33 X12 Z-40 F2\nN30 G00 X30\nN40 Z5\nN50 M30\n")
    assert st.state == IDLE and st.last_error == "", (st.state, st.last_error)
    on = [(x * 1000.0, z * 1000.0) for _, (x, z) in sps if -39.0 <= z * 1000.0 <= 4.0 and x * 1000.0 < 6.5]
    assert len(on) > 1000, len(on)
    worst = max(abs(x - (5.0 + (5.0 - z) / 45.0)) for x, z in on)
    print("Example 3: X off the taper by at most %.2e mm" % worst)
    assert worst < 1e-6, worst
    cpr = enc[-1][2]
    pairs = pairs_at(sps, enc, 1, 5.0, -35.0, -2.0)
    spread, phase, _ = lead_stats(pairs, 5.0, 1.0, 2.0, cpr)
    print("Example 3: lead error spread %.2f counts, groove phase %.3f deg" % (spread, phase))
    assert spread <= 4.0 and abs(phase) <= 0.05, (spread, phase)
    # Example 4: runout J3 at 30 degrees on X (machine constant 8): X
    # (radius 10) leaves the thread over the last 3 mm and ends 3 tan 30
    # further out, then the empty block, then a block with every axis
    for _ in peer.attempts("Example 4"):
        peer.clear()
        st, sps, enc = peer.run_to_end(
            "N5 G00 X20 Z5\nN10 M03 S800\nN20 G33 Z-43 F1 J3\nN30\nN40 X30 Z5\nN50 M30\n")
    assert st.state == IDLE and st.last_error == "", (st.state, st.last_error)
    tan30 = math.tan(math.radians(30.0))
    at_end = [x * 1000.0 for _, (x, z) in sps if abs(z * 1000.0 + 43.0) < 1e-9]
    assert at_end, "Z reached -43"
    print("Example 4: X at Z-43: %.7f mm (10 + 3 tan 30 = %.7f)" % (at_end[0], 10.0 + 3.0 * tan30))
    assert abs(at_end[0] - (10.0 + 3.0 * tan30)) < 1e-9
    # before the runout X stays on the thread's radius (the pass: up to
    # Z-43, not the return)
    k = next(i for i, (_, (x, z)) in enumerate(sps) if abs(z * 1000.0 + 43.0) < 1e-9)
    assert all(abs(x * 1000.0 - 10.0) < 1e-9 for _, (x, z) in sps[:k] if -39.9 < z * 1000.0 < 4.9)
    end = sps[-1][1]
    assert abs(end[0] - 0.015) < 1e-9 and abs(end[1] - 0.005) < 1e-9, end
