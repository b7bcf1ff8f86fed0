"""Faults over DDS (issue 10, robustness), against the real nodes and a
stock rclpy peer: bad programs through the service, a client that vanishes
mid-call, a burst of 1000 service calls while a job runs, the simulator
killed and restarted during a job, and the controller killed while it
records. In each: a clear error or state, no panic, no stall of the loop,
and the recording of the run up to that moment readable.

(Encoder messages that stop during a thread: test_thread.py,
test_thread_lost_encoder_stops_the_axes_under_control.)

    bash scripts/ros_peer/setup.sh && . .venv-ros/env.sh
    python3 -m pytest tests/ros/test_faults.py -q    (-s prints the measured numbers)
"""
import json
import os
import random
import re
import signal
import subprocess
import sys
import time

import pytest
import rclpy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from cnc_msgs.msg import ControllerStatus, SpindleEncoder
from cnc_msgs.srv import RunProgram
from ros_nodes import (ROOT, TARGET, build, cpu_ticks, deep_qos, domain, hearing_peer, host_stolen, read_mcap,
                       sim_stall_reports, SpinningPeer, start, start_node, start_sim, stop)

DOMAIN = domain(0)
NS, SIM = "/cnc", "/sim"
# the bundled mill's interpolation.setpoint_delay_ms (the simulator applies
# each setpoint this long after its stamp)
DELAY_MS = 3
IDLE, RUNNING, ERROR = ControllerStatus.STATE_IDLE, ControllerStatus.STATE_RUNNING, ControllerStatus.STATE_ERROR
HERE = os.path.dirname(os.path.abspath(__file__))
# the module's machine: the bundled mill with a 50 MiB program limit
LIMIT = 50 * 1024 * 1024
BUSY = "job %d is running; wait for its end or abort it (nothing was queued)"


class Rig:
    """The two nodes (the simulator can be killed and started again) and
    an rclpy peer recording what they publish, by stamp and arrival."""

    def __init__(self, tmp):
        self.tmp = tmp
        self.env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        with open(os.path.join(ROOT, "config", "mill.toml")) as f:
            toml = f.read()
        assert "max_program_bytes = 67108864" in toml
        assert "\nsetpoint_delay_ms = %.1f\n" % DELAY_MS in toml
        self.machine = os.path.join(tmp, "mill_50mib.toml")
        with open(self.machine, "w") as f:
            f.write(toml.replace("max_program_bytes = 67108864", "max_program_bytes = %d" % LIMIT))
        self.programs = os.path.join(tmp, "programs")
        self.recordings = os.path.join(tmp, "recordings")
        os.makedirs(self.programs)
        self.node_log = os.path.join(tmp, "cnc_node.log")
        self.log_start = 0
        self.sim_log = os.path.join(tmp, "sim_axes.log")
        self.sim_args = ["--machine", "mill"]
        # --loop-stats 1: the control loop's wake-up lateness every second
        self.node_args = ["--machine", self.machine, "--program-dir", self.programs,
                          "--record-dir", self.recordings, "--loop-stats", "1"]
        with open(self.sim_log, "ab") as s, open(self.node_log, "ab") as n:
            self.sim, self.node = start(self.env, self.sim_args, self.node_args, sim_stderr=s, node_stderr=n)

    def kill_sim(self):
        self.sim.send_signal(signal.SIGKILL)
        self.sim.wait(timeout=10)

    def restart_sim(self):
        with open(self.sim_log, "ab") as s:
            self.sim = start_sim(self.env, self.sim_args, s)

    def node_stderr(self):
        with open(self.node_log, "rb") as f:
            return f.read().decode(errors="replace")

    def assert_node_healthy(self):
        """Still running, no panic, the loop never fell behind or dropped
        samples during this test (`log_start`: the node's log before it, so
        a test that failed on a host stall does not fail every one after)."""
        assert self.node.poll() is None, "cnc_node exited with %s" % self.node.returncode
        log = self.node_stderr()[self.log_start:]
        assert "panicked" not in log, log[-3000:]
        assert "fell" not in log and "dropped" not in log, log[-3000:]

    def close(self):
        stop([self.sim, self.node])


class Peer(SpinningPeer):
    """Setpoints (stamp ns, arrival s, positions m), status, the simulator's
    joint states and encoder, spindle commands; calls the service."""

    def __init__(self, name, own_participant=False):
        super().__init__(name, own_participant)
        self.setpoints = []
        self.status = []  # (arrival s, message)
        self.joint_states = []  # (stamp ns, positions m)
        self.encoder = []  # (stamp ns, velocity rad/s)
        self.spindle = []  # rad/s
        deep = deep_qos()
        self.node.create_subscription(JointState, NS + "/joint_setpoints", self._sp, deep)
        self.node.create_subscription(JointState, SIM + "/joint_states", self._js, deep)
        self.node.create_subscription(SpindleEncoder, SIM + "/spindle_encoder", self._enc, deep)
        self.node.create_subscription(ControllerStatus, NS + "/status", self._st, 100)
        self.node.create_subscription(Float64, NS + "/spindle_command", self._spin, 10)
        self.run = self.node.create_client(RunProgram, NS + "/run_program")
        self.abort = self.node.create_client(Trigger, NS + "/abort")
        self.spin()

    def streams_arrive(self, timeout=30.0):
        """Waits for the service and for the first setpoint and joint state;
        what is missing (None: all there)."""
        if not self.run.wait_for_service(timeout_sec=timeout):
            return "no %s/run_program within %.0f s" % (NS, timeout)
        t0 = time.time()
        while time.time() - t0 < timeout and not (self.setpoints and self.joint_states):
            time.sleep(0.05)
        with self.lock:
            missing = [what for what, got in (("setpoints", self.setpoints), ("joint states", self.joint_states))
                       if not got]
        return ("no %s within %.0f s" % (" and no ".join(missing), timeout)) if missing else None

    def _sp(self, m):
        t = time.time()
        with self.lock:
            self.setpoints.append((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, t, list(m.position)))

    def _js(self, m):
        with self.lock:
            self.joint_states.append((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, list(m.position)))

    def _enc(self, m):
        with self.lock:
            self.encoder.append((m.stamp.sec * 10**9 + m.stamp.nanosec, m.velocity))

    def _st(self, m):
        t = time.time()
        with self.lock:
            self.status.append((t, m))

    def _spin(self, m):
        with self.lock:
            self.spindle.append(m.data)

    def run_program(self, text="", path="", dry_run=False, record=False, dialect=""):
        req = RunProgram.Request()
        req.program = text
        req.program_path = path
        req.dry_run = dry_run
        req.record = record
        req.dialect = dialect
        return self.call(self.run, req, timeout=60.0)

    def wait_sim_at(self, what, target, after_ns=0, timeout=30.0):
        """Waits until the simulator's newest joint state, stamped after
        `after_ns`, stands within 1 µm of `target` (m); returns its stamp."""
        seen = []

        def there():
            if self.joint_states and self.joint_states[-1][0] > after_ns and max(
                    abs(a - b) for a, b in zip(self.joint_states[-1][1], target)) < 1e-6:
                seen.append(self.joint_states[-1][0])
            return seen
        self.wait_for(what, there, timeout)
        return seen[0]

    def job_status(self, job_id):
        with self.lock:
            return [m for _, m in self.status if m.job_id == job_id]

    def final_status(self, job_id, timeout=30.0):
        """The job's status once it has run and left running/hold."""
        def ended():
            mine = [m for _, m in self.status if m.job_id == job_id]
            return any(m.state == RUNNING for m in mine) and mine[-1].state in (IDLE, ERROR)
        self.wait_for("the end of job %d" % job_id, ended, timeout)
        return self.job_status(job_id)[-1]

    def until(self, stamp_ns, timeout=20.0):
        """Waits until setpoints and joint states up to `stamp_ns` (ns,
        the nodes' clock) have arrived: a busy subscriber lags behind."""
        self.wait_for("setpoints and joint states up to the stamp", lambda: self.setpoints and self.joint_states
                      and self.setpoints[-1][0] >= stamp_ns and self.joint_states[-1][0] >= stamp_ns, timeout)

    def last_setpoint(self):
        with self.lock:
            return self.setpoints[-1][2]



@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    build()
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    r = Rig(str(tmp_path_factory.mktemp("faults")))
    rclpy.init()
    try:
        # A peer's subscriptions have now and then matched nothing for
        # 10 s or more on a loaded CI machine (DDS discovery, seen once as
        # every test of this module failing at setup): hearing_peer makes
        # it again as a participant of its own before giving up.
        try:
            r.peer = hearing_peer(lambda own: Peer("faults_peer_%d" % (time.time_ns() % 100000), own),
                                  Peer.streams_arrive)
        except AssertionError as e:
            raise AssertionError("%s; nodes running: %s, %s\n-- cnc_node log:\n%s\n-- sim_axes log:\n%s" % (
                e, r.node.poll() is None, r.sim.poll() is None, r.node_stderr()[-2000:],
                open(r.sim_log, "rb").read().decode(errors="replace")[-2000:])) from None
        yield r
        r.peer.close()
    finally:
        rclpy.shutdown()
        r.close()


@pytest.fixture(autouse=True)
def node_log_start(request):
    """Each test judges the node's health by its log since the test began
    (`Rig.assert_node_healthy`)."""
    if "rig" in request.fixturenames:
        r = request.getfixturevalue("rig")
        r.log_start = len(r.node_stderr())
    yield


def stamp_of(m):
    return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec


def stamps_on_grid(sps, dt_ns=1_000_000, tol_ns=20_000, rig=None):
    """Checks setpoint stamps (ns, in arrival order) lie on the loop's grid:
    each difference is a whole, positive number of periods (within the
    wall clock's measurement, 20 us). Returns the periods a subscriber
    missed (differences of more than one period). With `rig`, a failure
    also shows the node's log of the system clock's moves (the stamps
    follow the system clock, so a slew or step moves them off the grid)."""
    missed = 0
    for a, b in zip(sps, sps[1:]):
        d = b[0] - a[0]
        n = round(d / dt_ns)
        if not (n >= 1 and abs(d - n * dt_ns) <= tol_ns):
            moves = [l for l in rig.node_stderr().splitlines() if "system clock moved" in l] if rig else []
            raise AssertionError((a[0], b[0], d, moves))
        missed += n - 1
    return missed


def read_truncated_mcap(path):
    """Messages of a recording whose writer died: its records in file
    order until the file ends (mcap's StreamReader, no CRC checks; the
    chunk being written when the process died is incomplete and ends the
    reading). Returns ({topic: [decoded message]}, number of complete
    chunks, the exception that ended the reading)."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk
    from mcap_ros2.decoder import DecoderFactory

    factory = DecoderFactory()
    schemas, channels, decoders, out = {}, {}, {}, {}
    chunks, end = 0, None
    with open(path, "rb") as f:
        reader = StreamReader(f, emit_chunks=True, validate_crcs=False)
        try:
            for rec in reader.records:
                inner = [rec]
                if isinstance(rec, Chunk):
                    inner = breakup_chunk(rec, validate_crc=True)
                    chunks += 1
                for r in inner:
                    if isinstance(r, Schema):
                        schemas[r.id] = r
                    elif isinstance(r, Channel):
                        channels[r.id] = r
                    elif isinstance(r, Message):
                        ch = channels[r.channel_id]
                        if ch.id not in decoders:
                            decoders[ch.id] = factory.decoder_for(ch.message_encoding, schemas[ch.schema_id])
                        out.setdefault(ch.topic, []).append(decoders[ch.id](r.data))
        except (McapError, EOFError, ValueError, MemoryError) as e:
            end = e
    return out, chunks, end


# --- bad programs -------------------------------------------------------


def refused(peer, home, **kw):
    """Sends a bad program; it must be refused with an error naming line
    and column, and nothing may move. Returns the message."""
    before = len(peer.setpoints)
    r = peer.run_program(**kw)
    assert not r.accepted and r.job_id == 0, r
    assert re.match(r"^line \d+, column \d+: ", r.message), r.message
    time.sleep(0.1)
    with peer.lock:
        after = [p for _, _, p in peer.setpoints[before:]]
    assert after, "no setpoints while the program was checked"
    assert all(p == home for p in after), after[-1]
    return r.message


def test_bad_programs_are_refused_with_line_and_column_and_nothing_moves(rig):
    peer = rig.peer
    home = peer.last_setpoint()
    assert home == [0.0, 0.0, 0.0], home
    msgs = {}
    # binary garbage as text: every byte value but NUL (a ROS string ends
    # there), so non-ASCII characters and control characters (CR, VT, FF)
    rnd = random.Random(10)
    garbage = bytes(rnd.randrange(1, 256) for _ in range(4000)).decode("latin-1")
    msgs["garbage text"] = refused(peer, home, text=garbage)
    # the same as a file by program_path: NUL bytes and invalid UTF-8
    with open(os.path.join(rig.programs, "garbage.bin"), "wb") as f:
        f.write(bytes(rnd.randrange(0, 256) for _ in range(100_000)))
    msgs["garbage file"] = refused(peer, home, path="garbage.bin")
    # a valid first line, then a NUL byte and invalid UTF-8 in line 2
    with open(os.path.join(rig.programs, "nul.nc"), "wb") as f:
        f.write(b"N10 G00 X10\nN20 G00 Y\x00\xff\xfe10\n")
    msgs["NUL"] = refused(peer, home, path="nul.nc")
    # lines over limits.max_line_bytes (4096): one of 5000 bytes, and one of
    # 8 MB without any line end
    msgs["long line"] = refused(peer, home, text="N10 G00 X1\nG00 X1 " + "Y1 " * 1665 + "\n")
    msgs["8 MB line"] = refused(peer, home, text="G00 X1" + " " * 8_000_000)
    # NaN, infinity and huge numbers
    msgs["NaN"] = refused(peer, home, text="N10 G00 XNaN\n")
    msgs["inf"] = refused(peer, home, text="N10 G00 X-inf\n")
    msgs["1e309"] = refused(peer, home, text="N10 G00 X1e309\n")
    msgs["F1e300"] = refused(peer, home, text="N10 G01 X10 F1e300\n")
    msgs["30 digits"] = refused(peer, home, text="N10 G00 X" + "9" * 30 + "\n")
    msgs["huge arc"] = refused(peer, home, text="N10 G01 F100\nN20 G02 X0 Y0 I1000000000 J0\n")
    # loops nested 40 deep, each run twice (Q1): 2^40 passes of the
    # innermost block, refused before anything runs
    deep = ["N1 G00 X100 Y100", "N2 F60000 G91"]
    deep += ["N%d G01 X0.5" % (10 + i) for i in range(40)]
    deep += ["N%d X-0.5 G73 L%d Q1" % (100 + i, 10 + i) for i in reversed(range(40))]
    t0 = time.time()
    msgs["deep loops"] = refused(peer, home, text="\n".join(deep) + "\n")
    deep_s = time.time() - t0
    # HEIDENHAIN label calls (LBL / CALL LBL REP) are not in the dialect
    msgs["LBL"] = refused(peer, home, text="N10 LBL 1 *\nN20 G00 X10 *\nN30 LBL 0 *\nN40 CALL LBL 1 REP 5 *\n",
                          dialect="heidenhain")
    for k, m in msgs.items():
        print("%-12s %s" % (k, m.split("\n")[0][:160]))
    # many errors: the reply keeps the first ones and counts the rest (a
    # reply is kept in one DDS datagram), as many as `cnc check` finds
    g = msgs["garbage text"].split("\n")
    assert g[0] == "line 1, column 1: unexpected character '\\u{93}': expected an address letter and a number", g[0]
    assert all(re.match(r"^line \d+, column \d+: ", l) for l in g[:-1]), g
    more = re.match(r"^\.\.\. and (\d+) more errors$", g[-1])
    assert more and len(msgs["garbage text"].encode()) <= 1000, g[-1]
    with open(os.path.join(rig.tmp, "garbage.nc"), "w", encoding="utf-8") as f:
        f.write(garbage)
    p = subprocess.run([os.path.join(TARGET, "cnc"), "check", os.path.join(rig.tmp, "garbage.nc"),
                        "--machine", rig.machine], capture_output=True, text=True, errors="replace")
    assert p.returncode == 1 and "panicked" not in p.stderr, p.stderr[-2000:]
    total = int(re.search(r"(\d+) errors; the program is refused", p.stdout + p.stderr).group(1))
    print("garbage: %d errors, the reply lists %d (%d bytes)" % (total, len(g) - 1, len(msgs["garbage text"])))
    assert len(g) - 1 + int(more.group(1)) == total, (len(g), more.group(1), total)
    g = msgs["garbage file"].split("\n")
    assert re.match(r"^line 1, column 1: unexpected character '.+': expected an address letter and a number$",
                    g[0]), g[0]
    assert re.match(r"^\.\.\. and \d+ more errors$", g[-1]) and len(msgs["garbage file"].encode()) <= 1000, g
    assert msgs["NUL"] == "line 2, column 10: block N20: expected a number after address 'Y', found '\\0'"
    assert msgs["long line"] == "line 2, column 1: cannot read the program: line 2 is longer than 4096 bytes"
    assert msgs["8 MB line"] == "line 1, column 1: cannot read the program: line 1 is longer than 4096 bytes"
    assert msgs["NaN"] == "line 1, column 10: block N10: expected a number after address 'X', found 'N'"
    assert msgs["inf"] == "line 1, column 11: block N10: expected a number after address 'X', found 'i'"
    assert msgs["1e309"].startswith("line 1, column 11: block N10: unknown address 'E'"), msgs["1e309"]
    assert msgs["F1e300"].startswith("line 1, column 15: block N10: unknown address 'E'"), msgs["F1e300"]
    assert msgs["30 digits"] == ("line 1, column 9: block N10: number out of range after 'X': "
                                 "at most 1000000000 in magnitude")
    assert msgs["huge arc"] == (
        "line 2, column 9: block N20: travel limit: the arc reaches X 2000000000, outside the axis range 0..500\n"
        "line 2, column 12: block N20: travel limit: the arc reaches Y -1000000000, outside the axis range -200..500")
    assert msgs["deep loops"].startswith("line 82, column 12: block N100: with its loops the program would run "
                                         "1073741875 blocks or more, over the machine's limit of 1000000000 "
                                         "(limits.max_executed_blocks")
    assert msgs["LBL"].startswith("line 1, column 6: block N10: expected a number after address 'L', found 'B'")
    assert deep_s < 10.0, deep_s
    rig.assert_node_healthy()
    r = peer.run_program("G00 X1\n", dry_run=True)
    assert r.accepted, r.message


def test_program_size_limit_and_a_50mb_program_while_the_loop_runs(rig):
    """Over limits.max_program_bytes (50 MiB on this machine): refused, by
    text and by path (unread). A 50 MB program by path is checked (a dry
    run, ~1.1 million moves) while the loop publishes every sample on its
    grid."""
    peer = rig.peer
    home = peer.last_setpoint()
    over = LIMIT + 1000
    r = peer.run_program(text="G00 X1\n" + " " * (over - 7), dry_run=True)
    assert not r.accepted and r.message == (
        "the program is %d bytes, over the machine's limit of %d bytes (limits.max_program_bytes)" % (over, LIMIT))
    sparse = os.path.join(rig.programs, "sparse.nc")
    with open(sparse, "wb") as f:
        f.truncate(60_000_000)
    r = peer.run_program(path="sparse.nc", dry_run=True)
    assert not r.accepted and r.message == (
        "the program is 60000000 bytes, over the machine's limit of %d bytes (limits.max_program_bytes)" % LIMIT)
    # 50 MB of moves, back and forth
    big = os.path.join(rig.programs, "big50.nc")
    lines = ["N1 G90 G01 X10 Y10 Z5 F6000"]
    i, size = 0, 0
    while size < 50_000_000 - 100:
        i += 1
        s = "N%d X%.3f Y%.3f Z5\n" % (i + 1, 10 + (i % 400) * 0.25, 10 + (i % 3) * 0.125)
        lines.append(s)
        size += len(s)
    with open(big, "w") as f:
        f.write(lines[0] + "\n")
        f.writelines(lines[1:])
    del lines
    nbytes = os.path.getsize(big)
    assert 49_000_000 < nbytes <= 50_000_000, nbytes
    with peer.lock:
        n0 = len(peer.setpoints)
    late0 = late_wakeups(rig)
    t0 = time.time()
    r = peer.run_program(path="big50.nc", dry_run=True)
    took = time.time() - t0
    late, cycles = late_during(rig, late0)
    assert r.accepted, r.message[:500]
    with peer.lock:
        sps = peer.setpoints[n0:]
    missed = stamps_on_grid(sps, rig=rig)
    span = (sps[-1][0] - sps[0][0]) / 1e6
    gaps = max(b[1] - a[1] for a, b in zip(sps, sps[1:]))
    print("50 MB program (%d bytes, %d blocks): checked in %.1f s, estimate %.0f s; %d setpoints over %.0f ms "
          "(%d missed by the subscriber), largest arrival gap %.1f ms"
          % (nbytes, i + 1, took, r.estimated_duration, len(sps), span, missed, gaps * 1000))
    print("control loop: %d of %d wake-ups later than 1 ms during the check; %s"
          % (late, cycles, [l for l in rig.node_stderr().splitlines() if "loop lateness" in l][-1]))
    assert r.estimated_duration > 1000, r.estimated_duration
    assert span > 0.8 * took * 1000, (span, took)
    assert late <= 0.05 * cycles, (late, cycles)
    assert all(p == home for _, _, p in sps)
    rig.assert_node_healthy()


# --- a client that vanishes mid-call -------------------------------------


def test_a_client_killed_mid_call_does_not_stop_the_service(rig):
    """The client sends a program whose check takes a few seconds and is
    killed (SIGKILL) while the node checks it. A call sent meanwhile waits
    behind that check (which shows the node had the request when the
    client died) and is answered; the node does not panic."""
    peer = rig.peer
    slow = os.path.join(rig.tmp, "slow.nc")
    with open(slow, "w") as f:
        # 2 x 1000 x 500 moves: about 2.4 s of check in a debug build on
        # a quiet host (at 200 repeats it had become 0.9 s, too close to
        # the 0.8 s the call below must wait)
        f.write("N1 G00 X100 Y100\nN2 F60000 G91\nN10 G01 X0.5\nN20 X0.5\n"
                "N30 X-0.5 G73 L20 Q999\nN40 X-0.5 G73 L10 Q499\n")
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN)
    for k in range(2):
        p = subprocess.Popen([sys.executable, os.path.join(HERE, "vanishing_call.py"), NS, slow],
                             env=env, stdout=subprocess.PIPE, text=True)
        try:
            assert p.stdout.readline().strip() == "sent"
            t0 = time.time()
            req = RunProgram.Request()
            req.program = "G00 X10\n"
            req.dry_run = True
            fut = peer.run.call_async(req)
            time.sleep(0.3)
        finally:
            p.send_signal(signal.SIGKILL)
            p.wait(timeout=10)
        while not fut.done() and time.time() - t0 < 60:
            time.sleep(0.005)
        took = time.time() - t0
        r = fut.result()
        print("client %d killed mid-call; a call sent meanwhile answered after %.2f s" % (k + 1, took))
        assert r is not None and r.accepted and abs(r.estimated_duration - 0.22) < 0.1, r
        assert took > 0.8, took
    r = peer.run_program("G00 X10\n", dry_run=True)
    assert r.accepted, r.message
    rig.assert_node_healthy()


# --- 1000 calls while a job runs ------------------------------------------


def late_wakeups(rig):
    """(cycles, wake-ups later than 1 ms) of the control loop so far: its
    last --loop-stats line (cumulative, printed every second)."""
    t0 = time.time()
    while True:
        m = re.findall(r"loop lateness n=(\d+) .* over_1ms=(\d+)", rig.node_stderr())
        if m or time.time() - t0 > 5.0:
            break
        time.sleep(0.1)
    assert m, "no loop stats"
    return int(m[-1][0]), int(m[-1][1])


def late_during(rig, before):
    """Wake-ups later than 1 ms since `before` (a late_wakeups value), once
    the loop has printed its stats again (within 1.1 s)."""
    t0 = time.time()
    while late_wakeups(rig)[0] <= before[0] + 500 and time.time() - t0 < 3.0:
        time.sleep(0.1)
    time.sleep(1.1)
    now = late_wakeups(rig)
    return now[1] - before[1], now[0] - before[0]


def test_a_burst_of_1000_calls_while_a_job_runs(rig):
    """1000 run_program calls from another process while a job runs: each
    answered with the busy refusal; the job's every sample recorded on the
    grid, on the programmed line at the programmed speed during the burst;
    the loop's wake-ups as before."""
    peer = rig.peer
    held = []
    for attempt in range(3):
        # 490 mm at 1200 mm/min (24.5 s, longer than the burst takes on a
        # busy machine), recorded; aborted after the burst
        r = peer.run_program("N10 G00 X10 Y10 Z5\nN20 G01 X500 F1200\nN30 M30\n", record=True)
        assert r.accepted, r.message
        job = r.job_id
        peer.wait_for("line 2", lambda: any(m.job_id == job and m.source_line == 2 for _, m in peer.status))
        late0 = late_wakeups(rig)
        ticks, sim_since = cpu_ticks(), os.path.getsize(rig.sim_log)
        env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN)
        # 4 clients, 8 calls in flight each; every reply reaches every
        # client (DDS request/reply), so they keep 100 (rclpy's 10 lost some)
        p = subprocess.run([sys.executable, os.path.join(HERE, "burst_calls.py"), NS, "1000", "4", "8", "100"],
                           env=env, capture_output=True, text=True, timeout=180)
        assert p.returncode == 0, p.stderr
        res = json.loads(p.stdout.strip().splitlines()[-1])
        late, cycles = late_during(rig, late0)
        # (the stolen share over the burst itself, not the abort after it)
        stolen = host_stolen(ticks)
        print("burst: %d calls answered in %.2f s, %s" % (res["answered"], res["t1"] - res["t0"], res["messages"]))
        a = peer.call(peer.abort, Trigger.Request(), timeout=60.0)
        assert a.success, a.message
        st = peer.final_status(job, timeout=30)
        # the loop's own wake-ups (--loop-stats) over the burst and a
        # second either side: a stalled loop would be late at every one;
        # this VM's kernel (PREEMPT_NONE) holds up even a SCHED_FIFO thread
        # now and then while others work (measured: 0-1 in 4000 when the
        # machine is idle, 35 in 6000 while another test suite ran), so
        # up to 5 % pass. The loop kept time unless the host held the
        # whole VM up: the loop fell 200 ms and 969 ms behind, and 721 of
        # 5611 wake-ups came late, in CI runs on VMs with 5-14 % steal
        # time; such a run goes again, three at most, and when each was
        # held up so, the test skips (it measured the host). One off
        # without the host's hold-up fails.
        off = ("ended with %r" % st.last_error if "the control loop fell" in st.last_error
               else "%d of %d wake-ups later than 1 ms" % (late, cycles) if late > 0.05 * cycles else "")
        print("control loop: %d of %d wake-ups later than 1 ms over the burst" % (late, cycles))
        if not off:
            break
        evidence = ([stolen] if stolen else []) + sim_stall_reports(rig.sim_log, sim_since, wait=1.5)
        print("attempt %d: %s; the host: %s" % (attempt + 1, off, evidence))
        assert evidence, "%s, and neither the hypervisor nor the simulator held the nodes up" % off
        held.append("%s (%s)" % (off, evidence[0]))
        rig.log_start = len(rig.node_stderr())
    else:
        pytest.skip("three runs, each while the host held the nodes up: %s" % "; ".join(held))
    assert "aborted" in st.last_error, st.last_error
    assert res["sent"] == 1000 and res["answered"] == 1000, res
    assert res["messages"] == {BUSY % job: 1000}, res["messages"]
    assert res["accepted"] == 0
    # setpoints before and during the burst, as this subscriber got them:
    # stamps on the loop's grid, and how long it waited for the next one
    # (a busy Python subscriber misses some: the publisher keeps 10)
    with peer.lock:
        sps = list(peer.setpoints)
    t0, t1 = res["t0"], res["t1"]
    stats = {}
    for name, part in (("before", [s for s in sps if t0 - 0.8 <= s[1] < t0]),
                       ("during", [s for s in sps if t0 <= s[1] <= t1])):
        missed = stamps_on_grid(part, rig=rig)
        span = (part[-1][0] - part[0][0]) / 1e6
        gap = max(b[1] - a[1] for a, b in zip(part, part[1:]))
        stats[name] = (len(part), span, missed, gap * 1000)
        print("%s the burst: %d setpoints over %.0f ms on the grid, %d missed by the subscriber, "
              "largest arrival gap %.1f ms" % ((name,) + stats[name]))
    assert stats["during"][1] > 300, stats
    # (the arrival gap is this Python subscriber's as much as the node's:
    # it shares two cores with the four burst clients, and its thread got
    # no turn for 356 and 450 ms in full suite runs, while the node's loop
    # and its DDS threads, real-time, kept time; those are judged below, by
    # the loop's wake-ups and the recording. A node that stopped
    # publishing during the burst would leave a gap as long as the burst.)
    assert stats["during"][3] < 1000.0, stats
    # the job as the node recorded it: every cycle's sample on the grid
    # (none skipped or doubled), and during the burst X 0.02 mm further
    # each cycle (20 mm/s), exactly as planned
    peer.wait_for("the recording", lambda: "job %d recorded" % job in rig.node_stderr(), 10)
    rec = read_mcap(r.recording)["/cnc/joint_setpoints"]
    ns = [t for t, _ in rec]
    assert stamps_on_grid([(t,) for t in ns]) == 0
    assert len(ns) == round((ns[-1] - ns[0]) / 1e6) + 1, (len(ns), ns[0], ns[-1])
    xs = [(t, m.position[0]) for t, m in rec if int(t0 * 1e9) <= t <= int(t1 * 1e9)]
    steps = [round((b[1] - a[1]) * 1e3, 9) for a, b in zip(xs, xs[1:])]
    print("recording: %d samples on the grid; %d during the burst, X steps %s mm"
          % (len(ns), len(xs), sorted(set(steps))))
    assert len(xs) > 300 and set(steps) == {0.02}, sorted(set(steps))[:5]
    rig.assert_node_healthy()


# --- the simulator killed and started again during a job ----------------


def test_simulator_killed_mid_job_the_open_loop_job_goes_on_and_it_follows_again(rig):
    """The controller is the setpoint source: a job that does not need the
    encoder (G94 feed) runs on to its end while the simulator is dead,
    setpoints and status at their rate; the simulator started again ramps
    to the setpoints and follows them (and the spindle turns at the
    commanded speed again). Judged from the job's recording (every
    setpoint, and the joint states as the controller got them) and the
    peer."""
    peer = rig.peer
    prog = "N10 G00 X10 Y10 Z5\nN20 M03 S1000\nN30 G01 X160 F1500\nN40 M05\nN50 M30\n"  # N30: 6 s
    r = peer.run_program(prog, record=True)
    assert r.accepted, r.message
    job = r.job_id
    peer.wait_for("line 3", lambda: any(m.job_id == job and m.source_line == 3 for _, m in peer.status))
    time.sleep(0.5)
    t_kill = time.time()
    rig.kill_sim()
    rig.first_kill = t_kill
    time.sleep(1.0)
    t_restart = time.time()
    rig.restart_sim()
    st = peer.final_status(job, timeout=30)
    assert st.state == IDLE and st.last_error == "", (st.state, st.last_error)
    end_ns = stamp_of(st)
    kill_ns, restart_ns = int(t_kill * 1e9), int(t_restart * 1e9)
    peer.until(end_ns + 600_000_000)
    # the simulator settles on the end point (in 0.2 s on an idle machine;
    # judged by the position reached, not the time: a busy VM holds up the
    # restarted simulator, whose loop then skips steps)
    peer.wait_sim_at("the simulator at the end point", [0.160, 0.010, 0.005])
    with peer.lock:
        js, enc = list(peer.joint_states), list(peer.encoder)
    peer.wait_for("the recording", lambda: "job %d recorded" % job in rig.node_stderr(), 10)
    rec = read_mcap(r.recording)
    sps = [(t, list(m.position)) for t, m in rec["/cnc/joint_setpoints"]]
    rjs = [(t, list(m.position)) for t, m in rec["/sim/joint_states"]]
    status = [m for t, m in rec["/cnc/status"] if kill_ns <= t <= restart_ns]
    # every setpoint of the job, on the grid, ending on the end point
    ticks = round(r.estimated_duration * 1000)
    assert len(sps) == ticks + 1, (len(sps), ticks)
    assert stamps_on_grid(sps, rig=rig) == 0
    assert all(abs(a - b) < 1e-12 for a, b in zip(sps[-1][1], [0.160, 0.010, 0.005])), sps[-1][1]
    # while the simulator was dead: the setpoints went on (every cycle),
    # status at least 10 Hz (running), no joint states
    dead = [s for s in sps if kill_ns <= s[0] <= restart_ns]
    gap = max(b[0] - a[0] for a, b in zip(rjs, rjs[1:]))
    print("simulator dead %.2f s: %d setpoints, %d status messages; the joint states' largest gap %.2f s"
          % (t_restart - t_kill, len(dead), len(status), gap / 1e9))
    assert len(dead) >= 0.99 * (t_restart - t_kill) * 1000, len(dead)
    assert len(status) >= 9 and all(m.state == RUNNING and m.job_id == job for m in status), len(status)
    assert not [j for j in rjs if kill_ns + 50_000_000 < j[0] < restart_ns], "joint states from a dead simulator"
    assert gap >= (t_restart - t_kill) * 1e9 * 0.9, gap
    assert any(t < kill_ns for t, _ in rjs) and any(t > restart_ns for t, _ in rjs)
    # after the restart the simulator (at home) finds the setpoints (DDS
    # discovery), ramps to them at its limits overshooting a few mm, and
    # follows: its joint states against the setpoint of the same instant,
    # from half a second after its error was last 1 mm or more
    # (the simulator applies each setpoint at its stamp + the machine's
    # setpoint delay, interpolation.setpoint_delay_ms: a joint state
    # stamped t is compared with the setpoint stamped t - that delay)
    by_ms = {round(t / 1e6) + DELAY_MS: p for t, p in sps}
    errs = [(t, max(abs(a - b) for a, b in zip(p, by_ms[round(t / 1e6)])))
            for t, p in rjs if t > restart_ns and round(t / 1e6) in by_ms and t <= end_ns - 300_000_000]
    first_ns = min(t for t, _ in rjs if t > restart_ns)
    caught = max([t for t, e in errs if e >= 1e-3] or [first_ns])
    follow = sorted(e for t, e in errs if t > caught + 500_000_000)
    worst_end = max(abs(a - b) for a, b in zip(js[-1][1], [0.160, 0.010, 0.005]))
    spin = [v for t, v in enc if t > restart_ns]
    print("after the restart: first joint state %.2f s after the start, within 1 mm %.2f s after it; following "
          "error from 0.5 s later %.4f mm at most, median %.4f mm (%d states); at rest %.1e mm off the end; "
          "encoder %.1f rad/s at most (S1000: 104.7)"
          % ((first_ns - restart_ns) / 1e9, (caught - first_ns) / 1e9, follow[-1] * 1000,
             follow[len(follow) // 2] * 1000, len(follow), worst_end * 1000, max(spin) if spin else 0.0))
    assert (caught - first_ns) / 1e9 < 2.0 and len(follow) > 500, (caught - first_ns, len(follow))
    # (the servo model's own following error is 0.025 mm at 25 mm/s or
    # less; a setpoint that reaches the simulator late adds 0.025 mm a ms:
    # up to 0.9 mm measured on this VM while other tests ran, and a 99th
    # percentile of 0.58 mm on a VM whose 1 ms sleeps were up to 8 ms late)
    p99 = follow[int(0.99 * (len(follow) - 1))]
    assert follow[len(follow) // 2] < 0.05e-3 and p99 < 1.0e-3, (follow[len(follow) // 2], p99)
    # the spindle command reaches the new simulator (it is repeated)
    assert spin and abs(max(spin) - 104.72) < 5.0, "the restarted simulator's spindle: %s" % (spin[-3:],)
    rig.assert_node_healthy()


def test_simulator_killed_during_a_g95_move_ends_the_job_with_the_encoder_lost(rig):
    """A G95 move follows the measured spindle: the simulator killed, the
    readings stop, the axes stop under control and the job ends in error
    with the reason; the loop goes on; after the restart a job runs."""
    peer = rig.peer
    # N30: 0.05 mm/rev at S1000 is 50 mm/min (60 s for 50 mm)
    prog = "N10 G00 X10 Y10 Z5\nN20 M03 S1000\nN30 G95 G01 X60 F0.05\nN40 M30\n"
    for attempt in range(3):
        since = os.path.getsize(rig.sim_log)
        r = peer.run_program(prog)
        assert r.accepted, r.message
        job = r.job_id
        peer.wait_for("line 3", lambda: any(m.job_id == job and m.source_line == 3 for _, m in peer.status))
        time.sleep(0.5)
        # a busy VM may hold up the simulator, or the readings on their
        # way, for more than the encoder timeout (the simulator reports a
        # stall of its loop, and setpoints that reached it late, on stderr,
        # a line a second at most): the job then ends before the kill,
        # rightly; only then it runs again (README, thread tests)
        mine = peer.job_status(job)
        if mine[-1].state != ERROR:
            break
        assert "encoder signal lost" in mine[-1].last_error, mine[-1].last_error
        stalls = sim_stall_reports(rig.sim_log, since, wait=1.5)
        assert stalls, "%s, and the simulator reported no stall" % mine[-1].last_error
        print("attempt %d: %r after the simulator %s; again" % (attempt + 1, mine[-1].last_error, stalls[-1]))
    else:
        pytest.skip("three runs, each stopped while the host held the simulator up (the last: %r after %s)"
                    % (mine[-1].last_error, stalls[-1]))
    rig.kill_sim()
    t_kill = time.time()
    try:
        st = peer.final_status(job, timeout=10)
        t_err = time.time()
        err_ns = stamp_of(st)
        peer.wait_for("setpoints after the error", lambda: peer.setpoints[-1][0] >= err_ns + 600_000_000)
        with peer.lock:
            # (X decelerates under control in a few ms, then stands)
            sps = [s for s in peer.setpoints if s[0] > err_ns + 100_000_000]
            spin = list(peer.spindle)
    finally:
        rig.restart_sim()
        restart_ns = time.time_ns()
    print("G95 with the simulator killed: %r (%.0f ms after the kill)" % (st.last_error, (t_err - t_kill) * 1000))
    assert st.state == ERROR, (st.state, st.last_error)
    assert re.match(r"^line 3: spindle encoder signal lost: no reading for \d+ ms", st.last_error), st.last_error
    assert st.spindle_speed_command == 0.0 and spin[-1] == 0.0, (st.spindle_speed_command, spin[-3:])
    # the loop goes on: setpoints on the grid, standing where X stopped
    assert len(sps) > 100, len(sps)
    stamps_on_grid(sps, rig=rig)
    assert all(s[2] == sps[0][2] for s in sps) and 0.010 < sps[0][2][0] < 0.011, sps[0][2]
    # after the restart: the simulator (started at home) finds the
    # setpoints (DDS discovery) and goes where they stand; a job runs, and
    # it follows
    # (judged by the new simulator's own joint states: the last one from
    # before the kill may stand there too; and by the position reached,
    # not a fixed time: a busy VM holds up a simulator just started, in
    # discovery and in its loop, which then skips steps; measured on CI:
    # 0.26 mm short of the end 0.5 s after it)
    here = sps[0][2]
    t = peer.wait_sim_at("the restarted simulator at the setpoints", here, restart_ns)
    print("the restarted simulator stands at the setpoints %.2f s after its start" % ((t - restart_ns) / 1e9))
    r = peer.run_program("N10 G00 X20 Y20 Z10\n")
    assert r.accepted, r.message
    st = peer.final_status(r.job_id)
    assert st.state == IDLE and st.last_error == "", st.last_error
    t = peer.wait_sim_at("the simulator at the job's end point", [0.020, 0.020, 0.010], restart_ns)
    print("... and at the next job's end point %.2f s after the job's end" % ((t - stamp_of(st)) / 1e9))
    # a killed subscriber stays matched until its lease ends (50 s): the
    # setpoints go on to everyone past the 8192 samples rustdds would
    # otherwise hold for it (they stopped 8 s after the kill, for 40 s)
    # (measured during a job: at rest both nodes publish at 50 Hz only,
    # docs/ros_interface.md §3; a job publishes every cycle)
    first = getattr(rig, "first_kill", t_kill)
    time.sleep(max(0.0, first + 11.0 - time.time()))
    r = peer.run_program("N10 G01 X120 F1200\n")  # 5 s
    assert r.accepted, r.message
    time.sleep(max(0.0, first + 12.0 - time.time()))
    t0 = time.time()
    a, b = int(t0 * 1e9), int(t0 * 1e9) + 1_000_000_000
    peer.until(b)
    with peer.lock:
        n = len([s for s in peer.setpoints if a <= s[0] < b])
        js_n = len([j for j in peer.joint_states if a <= j[0] < b])
    peer.call(peer.abort, Trigger.Request())
    peer.final_status(r.job_id)
    print("%.1f s after the first kill: %d setpoints and %d joint states in 1 s" % (t0 - first, n, js_n))
    # (the defect stopped them altogether; this subscriber takes all but a
    # few on an idle machine, half with two CPU hogs running)
    assert n >= 200 and js_n >= 200, (n, js_n)
    rig.assert_node_healthy()


# --- the controller killed while it records -----------------------------


def test_controller_killed_mid_job_its_recording_reads_up_to_the_kill(rig, tmp_path):
    """A second controller (namespace /cnck, the module's simulator's
    topics recorded with its own) records a job and is killed (SIGKILL):
    the recording has no summary, but read as a stream it gives every
    message of its complete chunks: the job's first setpoints, each cycle
    on the grid, all but at most the chunk that was open (about 1 MiB)."""
    env = dict(rig.env)
    rec_dir = str(tmp_path / "rec")
    log = str(tmp_path / "cnck.log")
    with open(log, "wb") as f:
        node = start_node(env, ["--machine", "mill", "--namespace", "/cnck", "--record-dir", rec_dir,
                                "--record-all"], f)
    try:
        cli = rig.peer.node.create_client(RunProgram, "/cnck/run_program")
        assert cli.wait_for_service(timeout_sec=30.0)
        req = RunProgram.Request()
        req.program = "N10 G00 X10 Y10 Z5\nN20 M03 S1000\nN30 G01 X300 F1500\nN40 M30\n"  # 12 s
        fut = cli.call_async(req)
        t0 = time.time()
        while not fut.done() and time.time() - t0 < 30:
            time.sleep(0.01)
        r = fut.result()
        assert r.accepted and r.recording, r
        t_start = time.time()
        time.sleep(8.0)
        node.send_signal(signal.SIGKILL)
        t_kill = time.time()
        node.wait(timeout=10)
    finally:
        if node.poll() is None:
            node.kill()
    size = os.path.getsize(r.recording)
    msgs, chunks, end = read_truncated_mcap(r.recording)
    sp = msgs.get("/cnc/joint_setpoints", [])
    print("killed after %.2f s: %d bytes, %d complete chunks, %s; read until %r"
          % (t_kill - t_start, size, chunks, {k: len(v) for k, v in msgs.items()}, end))
    assert chunks >= 2, chunks
    # the job's first samples, one per cycle from the start
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in sp]
    assert all(b - a == 1_000_000 or abs(b - a - 1_000_000) < 20_000 for a, b in zip(stamps, stamps[1:]))
    assert [round(p, 9) for p in sp[0].position] == [0.0, 0.0, 0.0], sp[0].position
    # at most one chunk's worth lost: the setpoints of a complete chunk
    # (with the simulator's topics, ~2 s of the job) at 1 ms each
    per_chunk = len(sp) / chunks
    elapsed_ms = (t_kill - t_start) * 1000
    print("%d setpoints read (%.0f a chunk) of %.0f ms before the kill" % (len(sp), per_chunk, elapsed_ms))
    assert len(sp) >= elapsed_ms - 1.5 * per_chunk - 300, (len(sp), per_chunk, elapsed_ms)
    assert {"/sim/joint_states", "/cnc/status", "/tf"} <= set(msgs), set(msgs)
    with open(log, "rb") as f:
        assert b"panicked" not in f.read()
