//! What both nodes need to join a ROS 2 graph: a context on the right
//! domain (loopback only when `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, as
//! ROS 2 does), QoS profiles that match rclpy's defaults, a spinner thread,
//! and the fixed-rate cycle grid of control loops.

use ros2_client::{
    qos::{Durability, History, WhenFull},
    Context, Node, NodeName, NodeOptions, QosProfile,
};
use std::net::{IpAddr, Ipv4Addr};
use std::time::{Duration, Instant};

/// The domain from `ROS_DOMAIN_ID` (0 if unset or invalid).
pub fn domain_from_env() -> u16 {
    std::env::var("ROS_DOMAIN_ID")
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .filter(|&d: &u16| d <= 232)
        .unwrap_or(0)
}

/// True when ROS 2's discovery range says localhost only.
pub fn localhost_only_from_env() -> bool {
    std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE")
        .map(|v| v.eq_ignore_ascii_case("LOCALHOST"))
        .unwrap_or(false)
        || std::env::var("ROS_LOCALHOST_ONLY")
            .map(|v| v == "1")
            .unwrap_or(false)
}

/// A ROS 2 context on `domain`.
pub fn context(domain: u16, localhost_only: bool) -> Result<Context, String> {
    let mut b = rustdds::DomainParticipantBuilder::new(domain);
    if localhost_only {
        b = b.with_only_networks([IpAddr::from(Ipv4Addr::LOCALHOST)]);
    }
    let dp = b
        .build()
        .map_err(|e| format!("DDS participant on domain {domain}: {e:?}"))?;
    Context::from_domain_participant(dp).map_err(|e| format!("ROS context: {e:?}"))
}

/// A node `namespace/name`, with its spinner running on its own thread
/// (graph and discovery information for `ros2 node list`). Its logs go to
/// `/rosout` through [`crate::rosout`] (rclcpp's QoS), not through
/// ros2-client's own rosout writer (keep last 1).
pub fn node(ctx: &Context, namespace: &str, name: &str) -> Result<Node, String> {
    let nn = NodeName::new(namespace, name)
        .map_err(|e| format!("node name {namespace}/{name}: {e:?}"))?;
    let mut node = ctx
        .new_node(nn, NodeOptions::new().enable_rosout(false))
        .map_err(|e| format!("node {namespace}/{name}: {e:?}"))?;
    let spinner = node.spinner().map_err(|e| format!("spinner: {e:?}"))?;
    std::thread::Builder::new()
        .name("ros-spinner".into())
        .spawn(move || {
            let _ = smol::block_on(spinner.spin());
        })
        .map_err(|e| e.to_string())?;
    Ok(node)
}

/// rclpy's default: reliable, keep last 10, volatile. Writes never block
/// for long (a full queue fails at once rather than stall the caller).
pub fn qos_default() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// For services: reliable, volatile, as rclpy's services, but keep last
/// [`SERVICE_DEPTH`] rather than 10 (history is no part of QoS matching).
pub fn qos_services() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast {
            depth: SERVICE_DEPTH,
        })
}

/// Requests and replies a service keeps. The request and reply topics
/// have no keys, so each is one instance: a server's request history and
/// its reply history are shared by all its clients, and with 10, a few
/// clients with calls in flight at once can lose some (a reply also
/// reaches every client; tests/ros/test_faults.py, the burst of 1000
/// calls).
pub const SERVICE_DEPTH: usize = 256;

/// The cycles of a fixed-rate loop on the grid `origin + n·dt` of the
/// monotonic clock. Cycle n is *meant for* its grid instant: a loop that
/// woke late runs the cycles it missed ([`Grid::due`]) rather than shifting
/// every later one, so its n-th cycle always stands for the same instant
/// and its stamps ([`WallClock::stamp`]) are exactly n·dt apart. Instants are
/// computed from n (no accumulated rounding, also when dt is not a whole
/// number of nanoseconds).
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    origin: Instant,
    dt: f64,
    next: u64,
    spin: Duration,
    last_wake: Option<Instant>,
}

impl Grid {
    /// Cycle 0 at `origin`, one every `dt` seconds. Create it on the
    /// loop's thread: it sets that thread's timer slack to 1 ns.
    pub fn new(origin: Instant, dt: f64) -> Self {
        // SAFETY: prctl(PR_SET_TIMERSLACK) only changes this thread's timer
        // slack (1 ns instead of the default 50 µs); no memory is touched.
        unsafe {
            libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0);
        }
        Grid {
            origin,
            dt,
            next: 0,
            spin: Duration::from_micros(150),
            last_wake: None,
        }
    }

    /// The instant of cycle `n`.
    pub fn at(&self, n: u64) -> Instant {
        self.origin + Duration::from_secs_f64(n as f64 * self.dt)
    }

    /// The next cycle to run.
    pub fn next(&self) -> u64 {
        self.next
    }

    /// How many cycles are due at `now` and not run yet (0 when the next
    /// one's instant is still to come).
    pub fn due(&self, now: Instant) -> u64 {
        if self.at(self.next) > now {
            return 0;
        }
        let x = now.saturating_duration_since(self.origin).as_secs_f64() / self.dt;
        let mut last = (x.floor() as u64).max(self.next);
        // (the division may land a hair either side of a whole cycle)
        while last > self.next && self.at(last) > now {
            last -= 1;
        }
        while self.at(last + 1) <= now {
            last += 1;
        }
        last + 1 - self.next
    }

    /// Marks the next cycle as run; returns its number.
    pub fn advance(&mut self) -> u64 {
        self.next += 1;
        self.next - 1
    }

    /// Skips `n` cycles without running them (a loop too far behind).
    pub fn skip(&mut self, n: u64) {
        self.next += n;
    }

    /// Waits for the next cycle's instant and returns it: sleeps until
    /// shortly before, then spins the rest, so wake-ups are on time within
    /// microseconds. A loop that is behind returns at once, but at most
    /// twice a period, so its catching up is spread out (and runs as many
    /// cycles per wake-up as the caller allows).
    pub fn wait(&mut self) -> Instant {
        let deadline = self.at(self.next);
        let mut until = deadline;
        if let Some(w) = self.last_wake {
            until = until.max(w + Duration::from_secs_f64(0.5 * self.dt));
        }
        let now = Instant::now();
        if now + self.spin < until {
            std::thread::sleep(until - now - self.spin);
        }
        while Instant::now() < until {
            std::hint::spin_loop();
        }
        self.last_wake = Some(Instant::now());
        deadline
    }
}

/// Maps instants of the monotonic clock to the system (wall) clock, the
/// clock ROS stamps are in. Loops stamp their cycles with their grid
/// instants this way, so stamps are exactly a period apart whatever the
/// wake-up jitter, and in the clock every node on the host stamps with.
///
/// The offset between the clocks is measured by reading the wall clock
/// between two reads of the monotonic one; a measurement the thread was
/// interrupted in (the two more than [`WallClock::MAX_BRACKET`] apart)
/// keeps the previous offset, so a preemption between the reads never
/// shifts a stamp. The offset changes only when the system clock is
/// slewed or stepped; [`WallClock::update`] once a cycle follows that.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    anchor: Instant,
    /// wall clock (ns since the epoch) minus monotonic (ns since anchor)
    offset_ns: i128,
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl WallClock {
    /// The widest bracket a measurement of the offset may have.
    pub const MAX_BRACKET: Duration = Duration::from_micros(20);

    pub fn new() -> Self {
        let mut c = WallClock {
            anchor: Instant::now(),
            offset_ns: 0,
        };
        // the first measurement is taken whatever its bracket (a narrow
        // one is very likely within a few tries)
        let mut best: Option<(Duration, i128)> = None;
        for _ in 0..10 {
            if let Some((w, off)) = c.measure() {
                if best.is_none_or(|(bw, _)| w < bw) {
                    best = Some((w, off));
                }
                if w <= Self::MAX_BRACKET {
                    break;
                }
            }
        }
        if let Some((_, off)) = best {
            c.offset_ns = off;
        }
        c
    }

    /// (bracket, offset) of one measurement.
    fn measure(&self) -> Option<(Duration, i128)> {
        let m1 = Instant::now();
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .ok()?;
        let m2 = Instant::now();
        let mid =
            m1.duration_since(self.anchor).as_nanos() as i128 + (m2 - m1).as_nanos() as i128 / 2;
        Some((m2 - m1, wall.as_nanos() as i128 - mid))
    }

    /// Measures the offset again (kept when the measurement was interrupted).
    pub fn update(&mut self) {
        if let Some((w, off)) = self.measure() {
            if w <= Self::MAX_BRACKET {
                self.offset_ns = off;
            }
        }
    }

    /// The wall clock's time at `at`, ns since the epoch.
    pub fn ns_at(&self, at: Instant) -> i128 {
        let mono = match at.checked_duration_since(self.anchor) {
            Some(d) => d.as_nanos() as i128,
            None => -(self.anchor.duration_since(at).as_nanos() as i128),
        };
        mono + self.offset_ns
    }

    /// The wall clock's time at `at`, as a ROS stamp.
    pub fn stamp(&self, at: Instant) -> crate::Time {
        let ns = self.ns_at(at).max(0);
        crate::Time {
            sec: (ns / 1_000_000_000).min(i32::MAX as i128) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// Wake-up lateness of a loop, in 1 µs bins up to 20 ms (one overflow bin):
/// fixed memory, no allocation per record.
pub struct Lateness {
    bins: Vec<u64>,
    n: u64,
    max_us: f64,
    /// the record number of the worst one
    max_at: u64,
}

impl Default for Lateness {
    fn default() -> Self {
        Self::new()
    }
}

impl Lateness {
    const BINS: usize = 20_001;

    pub fn new() -> Self {
        Lateness {
            bins: vec![0; Self::BINS],
            n: 0,
            max_us: 0.0,
            max_at: 0,
        }
    }

    pub fn record(&mut self, late: Duration) {
        let us = late.as_secs_f64() * 1e6;
        let b = (us as usize).min(Self::BINS - 1);
        self.bins[b] += 1;
        self.n += 1;
        if us > self.max_us {
            self.max_us = us;
            self.max_at = self.n;
        }
    }

    /// The `p`-th percentile in µs (bin upper edge).
    pub fn percentile(&self, p: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let want = ((p / 100.0) * self.n as f64).ceil().max(1.0) as u64;
        let mut acc = 0;
        for (i, &c) in self.bins.iter().enumerate() {
            acc += c;
            if acc >= want {
                return (i + 1) as f64;
            }
        }
        self.max_us
    }

    pub fn count(&self) -> u64 {
        self.n
    }

    /// How many were later than `us` (whole µs, up to 20,000).
    pub fn over(&self, us: usize) -> u64 {
        self.bins[us.min(Self::BINS - 1)..].iter().sum()
    }

    /// `n=…, p50 … µs, p99 …, p99.9 …, max …, over 1 ms: …` (the counts
    /// are cumulative: two summaries give the wake-ups over 1 ms between)
    pub fn summary(&self) -> String {
        format!(
            "n={} p50<={:.0} us p99<={:.0} us p99.9<={:.0} us max={:.1} us (cycle {}) over_1ms={}",
            self.n,
            self.percentile(50.0),
            self.percentile(99.0),
            self.percentile(99.9),
            self.max_us,
            self.max_at,
            self.over(1000)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lateness_percentiles() {
        let mut l = Lateness::new();
        for i in 0..1000u64 {
            l.record(Duration::from_nanos(i * 1000 + 500));
        }
        assert_eq!(l.count(), 1000);
        assert_eq!(l.percentile(50.0), 500.0);
        assert_eq!(l.percentile(99.0), 990.0);
        assert!((l.max_us - 999.5).abs() < 1e-6);
        assert_eq!(l.over(990), 10);
        l.record(Duration::from_millis(30));
        assert_eq!(l.over(1000), 1);
        assert!(l.summary().ends_with("over_1ms=1"), "{}", l.summary());
    }

    #[test]
    fn grid_counts_missed_cycles_and_keeps_its_instants() {
        let o = Instant::now();
        let mut g = Grid::new(o, 0.001);
        assert_eq!(g.due(o), 1);
        assert_eq!(g.advance(), 0);
        assert_eq!(g.due(o), 0);
        assert_eq!(g.due(o + Duration::from_micros(999)), 0);
        assert_eq!(g.due(o + Duration::from_micros(1000)), 1);
        // woke 3.5 cycles late: cycles 1..=4 are due
        assert_eq!(g.due(o + Duration::from_micros(4500)), 4);
        g.skip(2);
        assert_eq!(g.next(), 3);
        assert_eq!(g.due(o + Duration::from_micros(4500)), 2);
        assert_eq!(g.due(o + Duration::from_micros(2999)), 0);
        // no drift: the instant of cycle n is n·dt from the origin
        let dt = 1.0 / 3000.0;
        let g = Grid::new(o, dt);
        let n = 3_000_000 * 3600;
        assert_eq!(g.at(n) - o, Duration::from_secs(3_600_000));
    }

    #[test]
    fn grid_waits_for_its_instants_and_spreads_a_catch_up() {
        let o = Instant::now() + Duration::from_millis(2);
        let mut g = Grid::new(o, 0.001);
        assert_eq!(g.wait(), o);
        assert!(Instant::now() >= o);
        g.advance();
        assert_eq!(g.wait(), g.at(1));
        assert!(Instant::now() >= g.at(1));
        // behind: the cycles are due at once, the wake-ups half a period apart
        std::thread::sleep(Duration::from_millis(5));
        g.advance();
        let w0 = Instant::now();
        g.wait();
        g.advance();
        g.wait();
        assert!(Instant::now() - w0 >= Duration::from_micros(500));
        assert!(g.due(Instant::now()) >= 2);
    }

    #[test]
    fn wall_clock_stamps_an_instant_with_the_wall_clock_then() {
        let mut c = WallClock::new();
        c.update();
        let now = Instant::now();
        let a = c.stamp(now - Duration::from_millis(20)).as_secs_f64();
        let w = super::wall_stamp().as_secs_f64();
        assert!((w - a - 0.020).abs() < 0.005, "{}", w - a);
        // instants a period apart are stamped a period apart, to the ns
        let d = c.ns_at(now + Duration::from_micros(1000)) - c.ns_at(now);
        assert_eq!(d, 1_000_000);
    }
}

/// Wall-clock time as a ROS stamp.
pub fn wall_stamp() -> crate::Time {
    let d = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    crate::Time {
        sec: d.as_secs().min(i32::MAX as u64) as i32,
        nanosec: d.subsec_nanos(),
    }
}

/// `namespace/base` as a ROS name.
pub fn name(ns: &str, base: &str) -> Result<ros2_client::Name, String> {
    ros2_client::Name::new(ns, base).map_err(|e| format!("name {ns}/{base}: {e:?}"))
}

/// (`pkg`, `Type`) of `pkg/msg/Type` or `pkg/srv/Type_Request`.
fn split_type<T: crate::RosType>() -> (&'static str, &'static str) {
    let mut it = T::ROS_NAME.split('/');
    let pkg = it.next().unwrap_or("");
    let ty = it.nth(1).unwrap_or("");
    (
        pkg,
        ty.trim_end_matches("_Request")
            .trim_end_matches("_Response"),
    )
}

fn topic<T: crate::RosType>(node: &Node, ns: &str, base: &str) -> Result<rustdds::Topic, String> {
    topic_with_qos::<T>(node, ns, base, &qos_default())
}

fn topic_with_qos<T: crate::RosType>(
    node: &Node,
    ns: &str,
    base: &str,
    qos: &QosProfile,
) -> Result<rustdds::Topic, String> {
    let (pkg, ty) = split_type::<T>();
    node.create_topic(
        &name(ns, base)?,
        ros2_client::MessageTypeName::new(pkg, ty),
        qos,
    )
    .map_err(|e| format!("topic {ns}/{base}: {e:?}"))
}

/// What `robot_state_publisher` gives `robot_description` and tf2's
/// static broadcaster `/tf_static`: reliable, transient local, keep last
/// 1, so a subscriber that joins later gets the last message.
pub fn qos_latched() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// What tf2's broadcaster gives `/tf`: reliable, volatile, keep last 100.
pub fn qos_tf() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 100 })
}

/// A publisher of `ns/base` with QoS `qos` (`ns` `/` for a global topic
/// such as `/tf`).
pub fn publisher_with_qos<T: crate::RosType + serde::Serialize>(
    node: &mut Node,
    ns: &str,
    base: &str,
    qos: &QosProfile,
) -> Result<ros2_client::Publisher<T>, String> {
    let t = topic_with_qos::<T>(node, ns, base, qos)?;
    node.create_publisher::<T>(&t, Some(qos.clone()))
        .map_err(|e| format!("publisher {ns}/{base}: {e:?}"))
}

/// A publisher like [`publisher`] whose reliable send window holds
/// `window` unacknowledged samples (rustdds's default is 8192).
///
/// rustdds keeps every sample a matched reliable reader has not yet
/// acknowledged, whatever the history depth, and refuses writes once the
/// window is full: for every reader. A subscriber that dies without leaving
/// (SIGKILL, a crash) stays matched until its participant's lease ends
/// (50 s for a rustdds peer, 20 s for Fast DDS), so a topic at 1 kHz
/// stopped for everyone about 8 s after such a death, for the rest of the
/// lease (tests/ros/test_faults.py, the simulator killed). A window of a
/// lease's worth of samples ([`lease_window`]) keeps it going; the samples
/// are held only while a dead reader lingers.
pub fn publisher_with_window<T: crate::RosType + serde::Serialize>(
    ctx: &Context,
    node: &mut Node,
    ns: &str,
    base: &str,
    window: usize,
) -> Result<ros2_client::Publisher<T>, String> {
    use rustdds::{policy, QosPolicies, QosPolicyBuilder};
    let (pkg, ty) = split_type::<T>();
    let window = i32::try_from(window).unwrap_or(i32::MAX);
    let limits = QosPolicyBuilder::new()
        .resource_limits(policy::ResourceLimits {
            max_samples: window,
            max_instances: 1,
            max_samples_per_instance: window,
        })
        .build();
    let qos = QosPolicies::from(&qos_default()).modify_by(&limits);
    let node_name = ros2_client::NodeName::new("/", "n").map_err(|e| format!("{e:?}"))?;
    let t = ctx
        .domain_participant()
        .create_topic(
            name(ns, base)?.to_dds_name("rt", &node_name, ""),
            ros2_client::MessageTypeName::new(pkg, ty).dds_msg_type(),
            &qos,
            rustdds::TopicKind::NoKey,
        )
        .map_err(|e| format!("topic {ns}/{base}: {e:?}"))?;
    node.create_publisher::<T>(&t, None)
        .map_err(|e| format!("publisher {ns}/{base}: {e:?}"))
}

/// The send window of a topic published at `rate_hz` that outlasts a dead
/// subscriber's lease: 60 s of samples (at least rustdds's 8192, at most
/// 2^21).
pub fn lease_window(rate_hz: f64) -> usize {
    ((rate_hz * 60.0).ceil() as usize).clamp(8192, 1 << 21)
}

/// A publisher of `ns/base` with rclpy's default QoS; the type name comes
/// from `T`.
pub fn publisher<T: crate::RosType + serde::Serialize>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::Publisher<T>, String> {
    let t = topic::<T>(node, ns, base)?;
    node.create_publisher::<T>(&t, None)
        .map_err(|e| format!("publisher {ns}/{base}: {e:?}"))
}

/// A subscription to `ns/base` with rclpy's default QoS.
pub fn subscription<T: crate::RosType + 'static>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::Subscription<T>, String> {
    let t = topic::<T>(node, ns, base)?;
    node.create_subscription::<T>(&t, None)
        .map_err(|e| format!("subscription {ns}/{base}: {e:?}"))
}

/// A service server `ns/base` (Fast DDS request/reply mapping).
pub fn server<Req, Resp>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::Server<Req, Resp>, String>
where
    Req: crate::RosType + ros2_client::Message + Clone + 'static,
    Resp: crate::RosType + ros2_client::Message + 'static,
{
    let (pkg, ty) = split_type::<Req>();
    let q = qos_services();
    node.create_server::<Req, Resp>(
        ros2_client::ServiceMapping::Enhanced,
        &name(ns, base)?,
        &ros2_client::ServiceTypeName::new(pkg, ty),
        q.clone(),
        q,
    )
    .map_err(|e| format!("service {ns}/{base}: {e:?}"))
}

/// A service client of `ns/base`.
pub fn client<Req, Resp>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::Client<Req, Resp>, String>
where
    Req: crate::RosType + ros2_client::Message + Clone + 'static,
    Resp: crate::RosType + ros2_client::Message + 'static,
{
    let (pkg, ty) = split_type::<Req>();
    let q = qos_services();
    node.create_client::<Req, Resp>(
        ros2_client::ServiceMapping::Enhanced,
        &name(ns, base)?,
        &ros2_client::ServiceTypeName::new(pkg, ty),
        q.clone(),
        q,
    )
    .map_err(|e| format!("client {ns}/{base}: {e:?}"))
}

#[cfg(test)]
mod type_names {
    #[test]
    fn split() {
        assert_eq!(
            super::split_type::<crate::JointState>(),
            ("sensor_msgs", "JointState")
        );
        assert_eq!(
            super::split_type::<crate::RunProgramRequest>(),
            ("cnc_msgs", "RunProgram")
        );
        assert_eq!(
            super::split_type::<crate::SetBoolResponse>(),
            ("std_srvs", "SetBool")
        );
    }
}

/// Re-publishes this context's node information on `ros_discovery_info`
/// every second for the first ten seconds, then every five seconds.
///
/// ros2-client publishes it only when a node's entities change, relying on
/// transient-local durability for late joiners; against Fast DDS that
/// delivery is sometimes lost at start-up, and an rclpy peer that started
/// at the same moment then never lists our nodes (`ros2 node list`). rmw's
/// graph cache keys the information by participant, so repeating it is
/// harmless.
pub fn keep_announcing(ctx: &Context) -> Result<(), String> {
    use ros2_client::builtin_topics::ros_discovery;
    use ros2_client::entities_info::ParticipantEntitiesInfo;
    let dp = ctx.domain_participant();
    let e = |e| format!("ros_discovery_info: {e:?}");
    let topic = dp
        .create_topic(
            ros_discovery::TOPIC_NAME.to_string(),
            ros_discovery::TYPE_NAME.to_string(),
            &ros_discovery::QOS_PUB,
            rustdds::TopicKind::NoKey,
        )
        .map_err(e)?;
    let publisher = dp.create_publisher(&ros_discovery::QOS_PUB).map_err(e)?;
    let writer = publisher
        .create_datawriter_no_key_cdr::<ParticipantEntitiesInfo>(&topic, None)
        .map_err(e)?;
    let ctx = ctx.clone();
    std::thread::Builder::new()
        .name("ros-announce".into())
        .spawn(move || {
            for i in 0u64.. {
                std::thread::sleep(Duration::from_secs(if i < 10 { 1 } else { 5 }));
                let _ = writer.write(ctx.participant_entities_info(), None);
            }
        })
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Puts the calling thread under the real-time FIFO policy at `priority`
/// (1..=99), as a control loop should run; `Err` says why not (e.g. no
/// permission: then it keeps the normal policy).
pub fn set_realtime(priority: i32) -> Result<(), String> {
    let param = libc::sched_param {
        sched_priority: priority.clamp(1, 99),
    };
    // SAFETY: sched_setscheduler on pid 0 changes only the calling thread's
    // scheduling policy; `param` is a valid, initialised struct.
    let r = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error().to_string())
    }
}

/// Puts the calling thread back under the normal (time-sharing) policy,
/// e.g. a worker spawned by a real-time thread, which inherits its policy.
pub fn set_normal() -> Result<(), String> {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: as in set_realtime: the calling thread's policy only.
    let r = unsafe { libc::sched_setscheduler(0, libc::SCHED_OTHER, &param) };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error().to_string())
    }
}

/// The real-time priority of a node's DDS threads when its loop runs at
/// `loop_priority` (0: none): below the loop, above every normal process,
/// so that messages the loop depends on (the spindle encoder) are not held
/// up by a busy machine. Set on the main thread before [`join`], it is
/// inherited by the threads DDS starts there.
pub fn dds_priority(loop_priority: i32) -> i32 {
    if loop_priority > 0 {
        (loop_priority - 20).max(1)
    } else {
        0
    }
}

/// Locks the process's memory (current and future) so a real-time loop
/// never waits on a page fault; `Err` says why not.
pub fn lock_memory() -> Result<(), String> {
    // SAFETY: mlockall only pins this process's pages; no memory is touched.
    let r = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error().to_string())
    }
}

/// Joins the graph as `namespace/name` on `domain`: the context (loopback
/// only when the environment says so), the node with its spinner, and the
/// re-announcement of the node information. Keep both alive.
pub fn join(domain: u16, namespace: &str, name: &str) -> Result<(Context, Node), String> {
    let ctx = context(domain, localhost_only_from_env())?;
    let node = node(&ctx, namespace, name)?;
    keep_announcing(&ctx)?;
    Ok((ctx, node))
}
