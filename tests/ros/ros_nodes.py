"""Starting and stopping the controller (`cnc_node`) and simulator
(`sim_axes`) nodes for the ROS tests."""
import os
import subprocess
import threading
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TARGET = os.environ.get("CNC_TARGET_DIR", os.path.join(ROOT, "target", "debug"))


def domain(slot):
    """The DDS domain of the test module numbered `slot` (0-9): 1 +
    10 slot + pid mod 10, so no two modules of a run share one (a node
    that outlives its module is never heard by the next), and two runs on
    one host seldom do. All are 1-100: DDS takes its ports from the
    domain (7400 + 250 per domain), and above about 101 they fall in
    Linux's ephemeral range (32768-60999), where any socket the host
    opens may hold one before a participant binds it (ROS 2's advice for
    ROS_DOMAIN_ID on Linux; a module's peer once heard nothing of the
    controller for 90 s on domain 150-199)."""
    assert 0 <= slot <= 9
    return str(1 + 10 * slot + os.getpid() % 10)


def build():
    """Builds both nodes (unless CNC_SKIP_BUILD: scripts/test.sh built them)."""
    if not os.environ.get("CNC_SKIP_BUILD"):
        subprocess.run(["cargo", "build", "-q", "-p", "cnc_node", "-p", "sim_axes", "--bins"], cwd=ROOT, check=True)


def start(env, sim_args, node_args, sim_stderr=None, node_stderr=None):
    """The simulator and the controller with these arguments, in `env`."""
    return [start_sim(env, sim_args, sim_stderr), start_node(env, node_args, node_stderr)]


def start_sim(env, args, stderr=None):
    """The simulator alone (e.g. again after it was killed)."""
    return subprocess.Popen([os.path.join(TARGET, "sim_axes")] + args, cwd=ROOT, env=env, stderr=stderr)


def start_node(env, args, stderr=None):
    """The controller alone."""
    return subprocess.Popen([os.path.join(TARGET, "cnc_node")] + args, cwd=ROOT, env=env, stderr=stderr)


def session(domain, sim_args, node_args):
    """The body of a module fixture: both nodes on `domain` (loopback
    only) and rclpy initialised there; yields the nodes' environment, then
    shuts rclpy down and stops the nodes. `yield from` it."""
    import rclpy
    env = dict(os.environ, ROS_DOMAIN_ID=domain, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    build()
    procs = start(env, sim_args, node_args)
    os.environ["ROS_DOMAIN_ID"] = domain
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rclpy.init()
    try:
        yield env
    finally:
        rclpy.shutdown()
        stop(procs)


def sim_stall_reports(sim_log, offset, wait=0.0):
    """The simulator's reports, in its stderr `sim_log` from byte `offset`
    on, that the host held it up: a stall of its loop ("sim_axes:
    stalled: ...") or setpoints that reached it after their instant. It
    writes at most a line a second of each, so a caller that has just
    seen the effect may `wait` up to that many s for the line."""
    t0 = time.monotonic()
    while True:
        with open(sim_log, "rb") as f:
            f.seek(offset)
            lines = [ln for ln in f.read().decode(errors="replace").splitlines()
                     if "sim_axes: stalled:" in ln or "arrived after their instant" in ln]
        if lines or time.monotonic() - t0 >= wait:
            return lines
        time.sleep(0.1)


def cpu_ticks():
    """The host's CPU time so far, from /proc/stat's first line: (stolen,
    all) in clock ticks. Stolen time is what the hypervisor gave other
    guests while this VM's CPUs had work: every thread of the VM stands
    still then, a SCHED_FIFO loop too (zeros where the kernel does not
    count it)."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return 0, 0
    return (v[7] if len(v) > 7 else 0), sum(v)


def host_stolen(mark, threshold=0.01):
    """Evidence that the hypervisor held the whole VM up since `mark` (a
    `cpu_ticks()`): its stolen share of the CPUs' time when at least
    `threshold` (1 %: an idle VM of this kind shows 0.1 %), as a line for
    a test's report; None below it."""
    stolen, total = (a - b for a, b in zip(cpu_ticks(), mark))
    if total <= 0 or stolen < threshold * total:
        return None
    return "the hypervisor took %.1f %% of the CPUs' time (steal)" % (100.0 * stolen / total)


def host_holdups(sim_log, since, ticks, wait=0.0):
    """Evidence that the host held the nodes up since the simulator's
    stderr `sim_log` was `since` bytes long and the CPU ticks were `ticks`
    (a `cpu_ticks()`): the hypervisor's stolen time (`host_stolen`), then
    the simulator's stall reports (`sim_stall_reports`, `wait` as there)."""
    stolen = host_stolen(ticks)
    return ([stolen] if stolen else []) + sim_stall_reports(sim_log, since, wait=wait)


def deep_qos():
    """Reliable, the last 1000 samples: a 1 kHz topic's samples wait in
    the reader for a peer's thread that the machine's load holds back
    (with rclpy's default depth of 10 most of them are overwritten)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def stop(procs, timeout=5):
    """Terminates the processes, killing those that do not end in time."""
    for p in procs:
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            p.kill()


class HostWatch:
    """A thread of the test's own that sleeps 5 ms at a time and notes
    when it woke far later: the host held every process up (a VM's steal
    time, another tenant), the nodes' real-time loops too. Evidence for
    a test that runs a job again when the nodes rightly stopped it on a
    stall the simulator did not see (Python threads take turns every 5 ms,
    so only gaps over `threshold` count)."""

    def __init__(self, threshold=0.05):
        self.threshold = threshold
        self.gaps = []  # (monotonic s at wake-up, gap s)
        self.lock = threading.Lock()
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        last = time.monotonic()
        while True:
            time.sleep(0.005)
            now = time.monotonic()
            if now - last > self.threshold:
                with self.lock:
                    self.gaps.append((now, now - last))
            last = now

    def since(self, t):
        """The gaps seen since monotonic time `t` (s each)."""
        with self.lock:
            return [g for w, g in self.gaps if w >= t]


_HOST_WATCH = []


def host_watch():
    """The test process's one `HostWatch`, started on first use (every
    peer shares it: a thread of its own each, waking 200 times a second,
    would only add to the load it watches for)."""
    if not _HOST_WATCH:
        _HOST_WATCH.append(HostWatch())
    return _HOST_WATCH[0]


class SpinningPeer:
    """An rclpy node spun in a thread of its own, where its subscriptions'
    callbacks run. Subclasses make their subscriptions and clients after
    this `__init__`, then call `spin()`."""

    def __init__(self, name, own_participant=False):
        import rclpy
        # (rclpy's nodes share one DDS participant per context: a context
        # of its own is a participant of its own, discovered afresh)
        self.context = None
        if own_participant:
            self.context = rclpy.Context()
            rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.lock = threading.Lock()

    def spin(self):
        from rclpy.executors import SingleThreadedExecutor
        self.ex = SingleThreadedExecutor(context=self.context)
        self.ex.add_node(self.node)
        self.stop = False
        self.thread = threading.Thread(target=self._spin_thread, daemon=True)
        self.thread.start()

    def _spin_thread(self):
        while not self.stop:
            self.ex.spin_once(timeout_sec=0.05)

    def wait_for(self, what, cond, timeout=30.0):
        """Waits until `cond()` (called under the lock) is true; an
        assertion naming `what` if it is not within `timeout` s."""
        t0 = time.time()
        while time.time() - t0 < timeout:
            with self.lock:
                if cond():
                    return
            time.sleep(0.005)
        raise AssertionError("timed out waiting for %s" % what)

    def call(self, client, req, timeout=20.0):
        """The reply of `client` to `req` (an assertion if none comes)."""
        fut = client.call_async(req)
        t0 = time.time()
        while not fut.done() and time.time() - t0 < timeout:
            time.sleep(0.002)
        assert fut.done(), "no reply from %s within %.0f s" % (client.srv_name, timeout)
        return fut.result()

    def close(self):
        self.stop = True
        self.thread.join()
        self.node.destroy_node()
        if self.context is not None:
            self.context.try_shutdown()

    def unheard(self, clients, heard, topic, timeout=30.0):
        """For `hearing_peer`: what has not come within `timeout` s each,
        or None: the services of `clients`, then a sample of `topic`
        (`heard()` true)."""
        for c in clients:
            if not c.wait_for_service(timeout_sec=timeout):
                return "no service %s" % c.srv_name
        t0 = time.time()
        while not heard() and time.time() - t0 < timeout:
            time.sleep(0.01)
        if heard():
            return None
        return "no sample of %s in %.0f s (this peer knows %d publisher(s) of it)" % (
            topic, timeout, self.publishers(topic))

    def publishers(self, topic):
        """The publishers of `topic` this peer's participant knows."""
        return len(self.node.get_publishers_info_by_topic(topic))


def hearing_peer(make, missing, attempts=3):
    """A peer that hears the nodes: `make(own_participant)` makes one,
    `missing(peer)` says what has not come to it (None: all has). Now and
    then, on a loaded machine, the nodes' writers never match a peer's
    readers (rustdds against Fast DDS at start-up: the reader's
    announcement is lost, and it is not sent again); every attempt after
    the first is then a new DDS participant, which is announced afresh.
    An assertion naming what is missing if no attempt hears them."""
    for attempt in range(1, attempts + 1):
        p = make(attempt > 1)
        what = missing(p)
        if what is None:
            return p
        print("peer %d: %s" % (attempt, what))
        p.close()
    raise AssertionError(what)


def stamp_s(stamp):
    """A ROS stamp in seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def read_mcap(path):
    """{topic: [(log time ns, decoded message)]} of a finished recording,
    decoded by mcap + mcap-ros2-support, in log time order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = {}
    with open(path, "rb") as f:
        for _, ch, m, dec in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            out.setdefault(ch.topic, []).append((m.log_time, dec))
    return out


def job_recording(directory, job_id):
    """The node's recording of job `job_id` in its record directory, read
    (`read_mcap`): the one file named job_<id>_*."""
    name = [f for f in os.listdir(directory) if f.startswith("job_%d_" % job_id)]
    assert len(name) == 1, name
    return read_mcap(os.path.join(directory, name[0]))


def cnc(env, *args, timeout=60):
    """The `cnc` command line with `args`: (exit code, stdout, stderr)."""
    r = subprocess.run([os.path.join(TARGET, "cnc")] + list(args), cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


class StatusPeer(SpinningPeer):
    """An rclpy peer that keeps the controller's status messages (`ns`)."""

    def __init__(self, name, own_participant=False, ns="/cnc"):
        from cnc_msgs.msg import ControllerStatus
        super().__init__(name, own_participant)
        self.ns = ns
        self.status = []
        self.node.create_subscription(ControllerStatus, ns + "/status", self._st, 10)
        self.spin()

    def _st(self, m):
        with self.lock:
            self.status.append(m)

    def missing(self, timeout=30.0):
        """For `hearing_peer`: None once a status came, else what did not."""
        return self.unheard([], lambda: bool(self.latest()), self.ns + "/status", timeout)

    def latest(self):
        with self.lock:
            return self.status[-1] if self.status else None

    def wait_state(self, state, timeout=60.0):
        # (conditions run under the lock: they read the list directly)
        self.wait_for("state %d" % state, lambda: bool(self.status) and self.status[-1].state == state, timeout)
        return self.latest()


def status_peer(prefix):
    """The body of a peer fixture: a `StatusPeer` that has heard the
    controller (made again as a participant of its own if the node never
    matched its reader: `hearing_peer`), closed after. `yield from` it."""
    p = hearing_peer(lambda own: StatusPeer("%s_%d" % (prefix, time.time_ns() % 100000), own), StatusPeer.missing)
    try:
        yield p
    finally:
        p.close()
