//! What both nodes need to join a ROS 2 graph: a context on the right
//! domain (loopback only when `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, as
//! ROS 2 does), QoS profiles that match rclpy's defaults, a spinner thread,
//! and the fixed-rate cycle grid of control loops.

use ros2_client::{
    qos::{Durability, History, WhenFull},
    Context, Node, NodeName, NodeOptions, QosProfile,
};
use std::net::{IpAddr, Ipv4Addr};
use std::time::Duration;

pub mod affinity;
mod pace;
pub mod shutdown;
mod timing;
pub use pace::{Pace, LINGER_S, REST_RATE_HZ};
pub use timing::{thread_cpu_time, Grid, Lateness, WallClock, MAX_SPIN};

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
    node_with(
        ctx,
        namespace,
        name,
        NodeOptions::new().enable_rosout(false),
    )
}

/// [`node`] with these options.
pub fn node_with(
    ctx: &Context,
    namespace: &str,
    name: &str,
    options: NodeOptions,
) -> Result<Node, String> {
    let nn = NodeName::new(namespace, name)
        .map_err(|e| format!("node name {namespace}/{name}: {e:?}"))?;
    let mut node = ctx
        .new_node(nn, options)
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

/// The process's remap rules (`--ros-args -r`), set once at start by a node.
static REMAPS: std::sync::OnceLock<crate::ros_args::Remapper> = std::sync::OnceLock::new();

/// Sets the remap rules the topics and services made by this module
/// follow (once; later calls change nothing).
pub fn set_remaps(r: crate::ros_args::Remapper) {
    let _ = REMAPS.set(r);
}

/// `namespace/base` as a topic (`service` false) or service name, after the
/// remap rules.
fn remapped(ns: &str, base: &str, service: bool) -> Result<ros2_client::Name, String> {
    let Some(r) = REMAPS.get().filter(|r| !r.is_empty()) else {
        return name(ns, base);
    };
    let full = crate::ros_args::resolve(base, &crate::ros_args::absolute(ns), "/");
    match r.apply(&full, service) {
        Some(to) => {
            let (ns, base) = to.rsplit_once('/').unwrap_or(("", to));
            name(if ns.is_empty() { "/" } else { ns }, base)
        }
        None => name(ns, base),
    }
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
        &remapped(ns, base, false)?,
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
            remapped(ns, base, false)?.to_dds_name("rt", &node_name, ""),
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
    subscription_with(node, ns, base, None)
}

/// A subscription to `ns/base` with `qos` (None: rclpy's default).
fn subscription_with<T: crate::RosType + 'static>(
    node: &mut Node,
    ns: &str,
    base: &str,
    qos: Option<QosProfile>,
) -> Result<ros2_client::Subscription<T>, String> {
    let t = topic::<T>(node, ns, base)?;
    node.create_subscription::<T>(&t, qos)
        .map_err(|e| format!("subscription {ns}/{base}: {e:?}"))
}

/// A subscription to a stream published every control cycle (setpoints,
/// joint states, encoder readings) with best-effort reliability, as
/// ROS's sensor-data profile, keep last [`STREAM_DEPTH`].
///
/// The publishers stay reliable (rclpy's default), so any subscriber
/// matches them; a reliable reader answers every sample's piggybacked
/// HEARTBEAT with an ACKNACK, which at 1 kHz doubled both nodes' DDS
/// wake-ups. A sample lost on the way is not repaired: the next one
/// comes a cycle later, and a repair would arrive later than it.
pub fn subscription_stream<T: crate::RosType + 'static>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::Subscription<T>, String> {
    subscription_with(node, ns, base, Some(qos_stream()))
}

/// The QoS of [`subscription_stream`]: best effort, volatile, keep last
/// [`STREAM_DEPTH`].
pub fn qos_stream() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_best_effort()
        .durability(Durability::Volatile)
        .history(History::KeepLast {
            depth: STREAM_DEPTH,
        })
}

/// Samples a stream subscription holds until they are taken: 100 cycles
/// at 1 kHz.
pub const STREAM_DEPTH: usize = 100;

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
        &remapped(ns, base, true)?,
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
        &remapped(ns, base, true)?,
        &ros2_client::ServiceTypeName::new(pkg, ty),
        q.clone(),
        q,
    )
    .map_err(|e| format!("client {ns}/{base}: {e:?}"))
}

/// rcl's QoS of an action's status topic: reliable, transient local,
/// keep last 1, so a client that comes later gets the latest statuses
/// (rclpy's action clients subscribe with it: a volatile publisher would
/// not match them).
pub fn qos_action_status() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// An action server `ns/base` of the action whose goal type is `G`,
/// result `R` (`pkg/action/Type_Result`, which names the action) and
/// feedback `F`, with the QoS of
/// rcl's action servers: its three services as [`qos_services`], the
/// feedback as [`qos_default`], the status as [`qos_action_status`].
pub fn action_server<G, R, F>(
    node: &mut Node,
    ns: &str,
    base: &str,
) -> Result<ros2_client::action::ActionServer<G, R, F>, String>
where
    G: ros2_client::Message + Clone + 'static,
    R: crate::RosType + ros2_client::Message + Clone + 'static,
    F: ros2_client::Message + 'static,
{
    let (pkg, ty) = action_type::<R>();
    let qos = ros2_client::action::ActionServerQosPolicies {
        goal_service: qos_services(),
        result_service: qos_services(),
        cancel_service: qos_services(),
        feedback_publisher: qos_default(),
        status_publisher: qos_action_status(),
    };
    node.create_action_server::<G, R, F>(
        ros2_client::ServiceMapping::Enhanced,
        &name(ns, base)?,
        &ros2_client::ActionTypeName::new(pkg, ty),
        qos,
    )
    .map_err(|e| format!("action {ns}/{base}: {e:?}"))
}

/// (`pkg`, `Type`) of an action's result type `pkg/action/Type_Result`.
fn action_type<R: crate::RosType>() -> (&'static str, &'static str) {
    let mut it = R::ROS_NAME.split('/');
    let pkg = it.next().unwrap_or("");
    let ty = it.nth(1).unwrap_or("");
    (pkg, ty.trim_end_matches("_Result"))
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

/// The next message of `sub`, as `Subscription::take`, for a real-time
/// loop: without waiting, spinning, for rustdds' event loop. `take` first
/// drains the reader's notification channel, a `std::sync::mpsc` channel
/// whose receiver spins while the event loop is between claiming a slot
/// and writing it; a loop that preempted the event loop on its CPU, with
/// the other CPU held by a loop too, spun there for good (BENCHMARKS.md,
/// "A loop that cannot keep its rate"). This polls `async_take` once
/// instead ([`now_or_never`]): it takes from the reader's cache and leaves
/// the notifications, which only a poll-based waiter needs (a full
/// channel only drops the event loop's next one).
pub fn take_now<M>(
    sub: &ros2_client::Subscription<M>,
) -> ros2_client::ReadResult<Option<(M, ros2_client::MessageInfo)>>
where
    M: 'static + serde::de::DeserializeOwned,
{
    now_or_never(sub.async_take()).transpose()
}

/// The next request to `srv`, as `Server::receive_request`, for a
/// real-time loop: without its drain, as [`take_now`].
pub fn receive_now<Req, Resp>(
    srv: &ros2_client::Server<Req, Resp>,
) -> ros2_client::ReadResult<Option<(ros2_client::RmwRequestId, Req)>>
where
    Req: ros2_client::Message + 'static,
    Resp: ros2_client::Message + 'static,
{
    now_or_never(srv.async_receive_request()).transpose()
}

/// `f`'s output if it is ready at its first poll (with a waker that does
/// nothing), else None; `f` is dropped either way.
pub fn now_or_never<F: std::future::Future>(f: F) -> Option<F::Output> {
    use std::task::{Context as TaskContext, Poll, Waker};
    let f = std::pin::pin!(f);
    match f.poll(&mut TaskContext::from_waker(Waker::noop())) {
        Poll::Ready(x) => Some(x),
        Poll::Pending => None,
    }
}

/// The real-time priority of a node's DDS threads when its loop runs at
/// `loop_priority` (0: none): [`DDS_PRIORITY`], or just below the loop if
/// that is lower; above every normal process, so that messages the loop
/// depends on (the spindle encoder) are not held up by a busy machine.
/// Set on the main thread before [`join`], it is inherited by the threads
/// DDS starts there.
pub fn dds_priority(loop_priority: i32) -> i32 {
    if loop_priority > 0 {
        DDS_PRIORITY.min(loop_priority - 1).max(1)
    } else {
        0
    }
}

/// The real-time priority of both nodes' DDS threads (with the loops at
/// their defaults, 80 and 70). One priority for all of them: a DDS thread
/// holds locks that its node's loop waits for (the simulator's loop takes
/// setpoints and publishes from rustdds' caches), and at a lower priority
/// than the other nodes' DDS threads it was preempted by them while it
/// held one; with six twins on two cores the simulators' loops stalled
/// for milliseconds and the controllers lost their encoder readings
/// (BENCHMARKS.md, the fleet).
pub const DDS_PRIORITY: i32 = 60;

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
    join_with(
        domain,
        namespace,
        name,
        NodeOptions::new().enable_rosout(false),
    )
}

/// [`join`] with these node options (e.g. without ros2-client's parameter
/// services, for a node that serves [`crate::params::Parameters`]).
pub fn join_with(
    domain: u16,
    namespace: &str,
    name: &str,
    options: NodeOptions,
) -> Result<(Context, Node), String> {
    let ctx = context(domain, localhost_only_from_env())?;
    let node = node_with(&ctx, namespace, name, options)?;
    keep_announcing(&ctx)?;
    Ok((ctx, node))
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
        assert_eq!(
            super::action_type::<crate::ExecuteProgramResult>(),
            ("cnc_msgs", "ExecuteProgram")
        );
    }
}

#[cfg(test)]
mod polling {
    use super::now_or_never;

    #[test]
    fn a_future_is_polled_once_and_never_waited_for() {
        assert_eq!(now_or_never(async { 7 }), Some(7));
        assert_eq!(now_or_never(std::future::pending::<u8>()), None);
        // one that would need a second poll is dropped after the first
        let mut polls = 0;
        let f = std::future::poll_fn(|_| {
            polls += 1;
            std::task::Poll::<()>::Pending
        });
        assert_eq!(now_or_never(f), None);
        assert_eq!(polls, 1);
    }
}
