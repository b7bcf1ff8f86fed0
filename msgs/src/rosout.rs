//! Logging as a ROS 2 node logs: every line goes to stderr (as
//! `<program>: <message>`, the nodes' log format since the start) and,
//! once [`init`] has joined the node to its graph, to `/rosout` as an
//! `rcl_interfaces/msg/Log` with the node's logger name, the level, the
//! file, function and line, and the stamp, for `ros2 topic echo /rosout`,
//! rqt_console and Foxglove's log panel.
//!
//! One logging function ([`log`], through the macros [`ros_info!`],
//! [`ros_warn!`], [`ros_error!`], [`ros_debug!`]) for every thread: a line
//! is handed to a thread of its own that publishes it (a bounded queue,
//! `try_send`), so a real-time loop that logs never waits on DDS.
//!
//! `/rosout` has rclcpp's QoS (`rmw_qos_profile_rosout_default`): reliable,
//! transient local, keep last 1000, lifespan 10 s, so a late subscriber
//! still gets the lines of the last 10 s. ros2-client's own rosout writer
//! (depth 1) is not used ([`crate::ros::node`] turns it off).

use crate::Log;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::OnceLock;

/// Severity of a line (the values of `rcl_interfaces/msg/Log`); lines
/// below the level `--ros-args --log-level` set are not logged.
pub use crate::ros_args::Level;

/// Lines waiting for the publishing thread; more are dropped (and counted).
pub const QUEUE: usize = 1024;

/// rclcpp's `/rosout` history depth.
pub const DEPTH: usize = 1000;

/// rclcpp's `/rosout` lifespan, s.
pub const LIFESPAN_S: u64 = 10;

struct Sink {
    /// the logger name (`cnc.cnc_node`)
    name: String,
    tx: SyncSender<Log>,
}

static PROGRAM: OnceLock<String> = OnceLock::new();
static SINK: OnceLock<Sink> = OnceLock::new();
static DROPPED: AtomicU64 = AtomicU64::new(0);

/// The stderr prefix: the program's file name (`cnc_node`, `sim_axes`).
fn program() -> &'static str {
    PROGRAM.get_or_init(|| {
        std::env::args_os()
            .next()
            .and_then(|a| {
                std::path::Path::new(&a)
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
            })
            .unwrap_or_else(|| "node".to_string())
    })
}

/// The logger name rcl gives a node `name` in `namespace`: the namespace
/// without its leading `/`, `/` as `.`, then the name (`/cnc`, `cnc_node`:
/// `cnc.cnc_node`; `/`, `n`: `n`).
pub fn logger_name(namespace: &str, name: &str) -> String {
    let ns = namespace.trim_matches('/');
    if ns.is_empty() {
        name.to_string()
    } else {
        format!("{}.{name}", ns.replace('/', "."))
    }
}

/// The `/rosout` QoS of rclcpp: reliable, transient local, keep last
/// [`DEPTH`], lifespan [`LIFESPAN_S`].
pub fn qos() -> ros2_client::QosProfile {
    use ros2_client::qos::{Durability, History, WhenFull};
    ros2_client::QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: DEPTH })
        .lifespan(Some(std::time::Duration::from_secs(LIFESPAN_S)))
}

/// Publishes every later line on `/rosout` as `node` (in `namespace`,
/// named `name`) from a thread of its own. Lines logged before go to
/// stderr only. A second call changes nothing.
pub fn init(
    ctx: &ros2_client::Context,
    node: &mut ros2_client::Node,
    namespace: &str,
    name: &str,
) -> Result<(), String> {
    if SINK.get().is_some() {
        return Ok(());
    }
    let publisher = node
        .create_publisher::<Log>(&ctx.get_rosout_topic(), Some(qos()))
        .map_err(|e| format!("publisher /rosout: {e:?}"))?;
    let (tx, rx) = mpsc::sync_channel::<Log>(QUEUE);
    std::thread::Builder::new()
        .name("rosout".into())
        .spawn(move || {
            while let Ok(m) = rx.recv() {
                let _ = publisher.publish(m);
            }
        })
        .map_err(|e| e.to_string())?;
    let _ = SINK.set(Sink {
        name: logger_name(namespace, name),
        tx,
    });
    Ok(())
}

/// Lines dropped because the publishing thread fell behind.
pub fn dropped() -> u64 {
    DROPPED.load(Ordering::Relaxed)
}

/// Logs `msg` at `level` from `file`:`line` in `function`: to stderr, and
/// to `/rosout` once [`init`] was called. Use the macros.
pub fn log(level: Level, file: &str, function: &str, line: u32, msg: fmt::Arguments) {
    if !crate::ros_args::log_enabled(level) {
        return;
    }
    let text = msg.to_string();
    eprintln!("{}: {text}", program());
    if let Some(s) = SINK.get() {
        let m = Log {
            stamp: crate::ros::wall_stamp(),
            level: level as u8,
            name: s.name.clone(),
            msg: text,
            file: file.to_string(),
            function: function.to_string(),
            line,
        };
        if let Err(TrySendError::Full(_)) = s.tx.try_send(m) {
            DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The function a macro was called in (`cnc_node::Loop::cycle`), closures
/// left out.
#[doc(hidden)]
pub fn function_name(full: &'static str) -> &'static str {
    let mut f = full.strip_suffix("::__f").unwrap_or(full);
    while let Some(g) = f.strip_suffix("::{{closure}}") {
        f = g;
    }
    f
}

/// Logs at a level: `ros_log!(Level::Warn, "{} late", n)`.
#[macro_export]
macro_rules! ros_log {
    ($lvl:expr, $($arg:tt)+) => {{
        fn __f() {}
        fn __name<T>(_: T) -> &'static str {
            ::std::any::type_name::<T>()
        }
        $crate::rosout::log(
            $lvl,
            ::std::file!(),
            $crate::rosout::function_name(__name(__f)),
            ::std::line!(),
            ::std::format_args!($($arg)+),
        )
    }};
}

/// Logs at level INFO (stderr and `/rosout`).
#[macro_export]
macro_rules! ros_info {
    ($($arg:tt)+) => { $crate::ros_log!($crate::rosout::Level::Info, $($arg)+) };
}

/// Logs at level WARN (stderr and `/rosout`).
#[macro_export]
macro_rules! ros_warn {
    ($($arg:tt)+) => { $crate::ros_log!($crate::rosout::Level::Warn, $($arg)+) };
}

/// Logs at level ERROR (stderr and `/rosout`).
#[macro_export]
macro_rules! ros_error {
    ($($arg:tt)+) => { $crate::ros_log!($crate::rosout::Level::Error, $($arg)+) };
}

/// Logs at level DEBUG (stderr and `/rosout`).
#[macro_export]
macro_rules! ros_debug {
    ($($arg:tt)+) => { $crate::ros_log!($crate::rosout::Level::Debug, $($arg)+) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logger_names_as_rcl_makes_them() {
        assert_eq!(logger_name("/cnc", "cnc_node"), "cnc.cnc_node");
        assert_eq!(logger_name("/a/b", "n"), "a.b.n");
        assert_eq!(logger_name("/", "sim_axes"), "sim_axes");
        assert_eq!(logger_name("", "x"), "x");
    }

    #[test]
    fn the_function_is_named_without_closures() {
        fn __f() {}
        fn name<T>(_: T) -> &'static str {
            std::any::type_name::<T>()
        }
        let f = function_name(name(__f));
        assert!(f.ends_with("the_function_is_named_without_closures"), "{f}");
        let in_closure = || {
            fn __f() {}
            function_name(name(__f))
        };
        let g = in_closure();
        assert!(g.ends_with("the_function_is_named_without_closures"), "{g}");
        // before init: stderr only, nothing queued
        ros_info!("a test line {}", 1);
        assert_eq!(dropped(), 0);
    }

    #[test]
    fn levels_are_the_log_message_constants() {
        assert_eq!(Level::Debug as u8, Log::DEBUG);
        assert_eq!(Level::Info as u8, Log::INFO);
        assert_eq!(Level::Warn as u8, Log::WARN);
        assert_eq!(Level::Error as u8, Log::ERROR);
        assert_eq!(Level::Fatal as u8, Log::FATAL);
    }
}
