//! What both nodes need to join a ROS 2 graph: a context on the right
//! domain (loopback only when `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, as
//! ROS 2 does), QoS profiles that match rclpy's defaults, a spinner thread,
//! and a fixed-rate ticker for control loops.

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
/// (graph and discovery information for `ros2 node list`).
pub fn node(ctx: &Context, namespace: &str, name: &str) -> Result<Node, String> {
    let nn = NodeName::new(namespace, name)
        .map_err(|e| format!("node name {namespace}/{name}: {e:?}"))?;
    let mut node = ctx
        .new_node(nn, NodeOptions::new().enable_rosout(true))
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

/// For services: reliable, keep last 10, volatile, as rclpy's services.
pub fn qos_services() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// Wakes at a fixed period on absolute deadlines: sleeps until shortly
/// before the deadline, then spins the rest, so the period does not drift
/// and the wake-up jitter stays in microseconds.
pub struct Ticker {
    period: Duration,
    next: Instant,
    spin: Duration,
}

impl Ticker {
    pub fn new(period: Duration) -> Self {
        // SAFETY: prctl(PR_SET_TIMERSLACK) only changes this thread's timer
        // slack (1 ns instead of the default 50 µs); no memory is touched.
        unsafe {
            libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0);
        }
        Ticker {
            period,
            next: Instant::now() + period,
            spin: Duration::from_micros(150),
        }
    }

    /// Waits for the next deadline; returns that deadline. A loop that fell
    /// more than a period behind starts afresh from now.
    pub fn wait(&mut self) -> Instant {
        let deadline = self.next;
        let now = Instant::now();
        if now + self.spin < deadline {
            std::thread::sleep(deadline - now - self.spin);
        }
        while Instant::now() < deadline {
            std::hint::spin_loop();
        }
        self.next += self.period;
        let now = Instant::now();
        if now > self.next {
            self.next = now + self.period;
        }
        deadline
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

    /// `n=…, p50 … µs, p99 …, p99.9 …, max …`
    pub fn summary(&self) -> String {
        format!(
            "n={} p50<={:.0} us p99<={:.0} us p99.9<={:.0} us max={:.1} us (cycle {})",
            self.n,
            self.percentile(50.0),
            self.percentile(99.0),
            self.percentile(99.9),
            self.max_us,
            self.max_at
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
    let (pkg, ty) = split_type::<T>();
    node.create_topic(
        &name(ns, base)?,
        ros2_client::MessageTypeName::new(pkg, ty),
        &qos_default(),
    )
    .map_err(|e| format!("topic {ns}/{base}: {e:?}"))
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
