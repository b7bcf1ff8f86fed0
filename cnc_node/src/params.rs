//! `cnc_node`'s settings: its options, its `--ros-args` and the ROS
//! parameters they are while it runs (docs/ros_interface.md §6).
//!
//! Every option `--foo-bar X` is the parameter `foo_bar` (`-p
//! foo_bar:=X`), except `--namespace` (`-r __ns:=/ns`) and `--domain`
//! (`ROS_DOMAIN_ID`). A value given both ways is the ROS parameter's
//! (`--ros-args` come later, and later wins, as in rcl), with a warning.
//! `record_dir`, `record_all`, `loop_stats` and `max_feed_override` can be
//! set while the node runs (`ros2 param set`); the others are read-only.

use crate::admit::RecordOpts;
use clap::Parser;
use cnc_msgs::options::{self, Options};
use cnc_msgs::params::{Change, Kind, Param, Parameters};
use cnc_msgs::ros::affinity;
use cnc_msgs::ros_args;
use ros2_client::ParameterValue as V;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The node's options.
#[derive(Parser, Debug)]
#[command(
    name = "cnc_node",
    version,
    about = "CNC controller as a ROS 2 node",
    after_help = "ROS arguments (after --ros-args, up to --): -r __ns:=/NS, -r __node:=NAME, \
                  -r FROM:=TO, -p NAME:=VALUE (each option below is a parameter, e.g. -p \
                  rate:=500), --params-file FILE, --log-level LEVEL"
)]
pub struct Args {
    /// machine file, or a bundled machine: mill, lathe
    #[arg(long, default_value = "mill")]
    pub machine: String,
    /// namespace of the controller's services and topics
    #[arg(long, default_value = "/cnc")]
    pub namespace: String,
    /// namespace of the simulator (or hardware bridge) publishing the encoder
    #[arg(long, default_value = "/sim")]
    pub sim_namespace: String,
    /// DDS domain (default: ROS_DOMAIN_ID, else 0)
    #[arg(long)]
    pub domain: Option<u16>,
    /// interpolation rate, Hz (default: the machine file's)
    #[arg(long)]
    pub rate: Option<f64>,
    /// directory of programs sent by program_path (default: the machine
    /// file's program_dir, relative to the machine file)
    #[arg(long)]
    pub program_dir: Option<PathBuf>,
    /// directory of job recordings (MCAP)
    #[arg(long, default_value = "recordings")]
    pub record_dir: PathBuf,
    /// record every job (else only those whose request sets `record`)
    #[arg(long)]
    pub record_all: bool,
    /// real-time (SCHED_FIFO) priority of the control loop, 1-99; 0 keeps
    /// the normal policy
    #[arg(long, default_value_t = 80)]
    pub rt_priority: i32,
    /// pin the node's threads to these CPUs, e.g. 1 or 0,2 (default: any);
    /// a twin's two nodes on one CPU cost about a quarter less CPU on a VM
    #[arg(long, value_name = "CPUS", value_delimiter = ',')]
    pub cpu_affinity: Vec<usize>,
    /// log the control loop's wake-up lateness percentiles every N seconds
    #[arg(long, value_name = "SECONDS")]
    pub loop_stats: Option<f64>,
    /// the highest feed override taken on `<namespace>/feed_override`, %
    #[arg(long, default_value_t = MAX_OVERRIDE, value_name = "PERCENT")]
    pub max_feed_override: f64,
}

/// The highest feed override the executor runs, %.
pub const MAX_OVERRIDE: f64 = cnc_core::exec::MAX_OVERRIDE * 100.0;

/// The node's name unless `__node` says otherwise.
pub const NODE: &str = "cnc_node";

/// The node's settings at start.
pub type Setup = options::Setup<Args>;

/// The settings from this process's command line; a bad one is an error
/// (clap's own errors, `--help` and `--version` exit here as usual).
pub fn from_env() -> Result<Setup, String> {
    setup(std::env::args_os())
}

/// The settings from a command line (its first item the program's name).
pub fn setup<I: IntoIterator<Item = OsString>>(argv: I) -> Result<Setup, String> {
    options::setup(argv)
}

impl Options for Args {
    const NODE: &'static str = NODE;

    fn namespace_mut(&mut self) -> &mut String {
        &mut self.namespace
    }

    fn declare(&self) -> Vec<Param> {
        declare(self)
    }

    fn read_back(&mut self, params: &[Param]) {
        read_back(self, params)
    }
}

fn path_value(p: &std::path::Path) -> V {
    V::String(p.to_string_lossy().into_owned())
}

/// The parameters with the options' values (the machine's rate and
/// program directory come in [`serve`], once the machine is loaded).
fn declare(a: &Args) -> Vec<Param> {
    let opt = |v: Option<V>| v.unwrap_or(V::NotSet);
    vec![
        Param::fixed("machine", Kind::String, "machine file, or a bundled machine: mill, lathe")
            .value(V::String(a.machine.clone())),
        Param::fixed(
            "sim_namespace",
            Kind::String,
            "namespace of the simulator (or drive bridge) publishing joint_states and spindle_encoder",
        )
        .value(V::String(a.sim_namespace.clone())),
        Param::fixed("rate", Kind::Double, "interpolation rate, Hz (the machine file's unless given)")
            .range(10.0, 20_000.0)
            .value(opt(a.rate.map(V::Double))),
        Param::fixed(
            "program_dir",
            Kind::String,
            "directory of programs sent by program_path (the machine file's program_dir unless given)",
        )
        .value(opt(a.program_dir.as_deref().map(path_value))),
        Param::live("record_dir", Kind::String, "directory of job recordings (MCAP); the next job records there")
            .constraints("a directory, or a path where one can be made")
            .value(path_value(&a.record_dir)),
        Param::live("record_all", Kind::Bool, "record every job, not only those whose request sets record")
            .value(V::Boolean(a.record_all)),
        Param::fixed(
            "rt_priority",
            Kind::Integer,
            "SCHED_FIFO priority of the control loop (DDS threads at 60, or just below the loop); 0: normal scheduling",
        )
        .range(0.0, 99.0)
        .value(V::Integer(i64::from(a.rt_priority))),
        affinity::param(&a.cpu_affinity),
        Param::live("loop_stats", Kind::Double, "log the control loop's wake-up lateness every this many seconds; 0: off")
            .range(0.0, 86_400.0)
            .value(V::Double(a.loop_stats.unwrap_or(0.0))),
        Param::live(
            "max_feed_override",
            Kind::Double,
            "the highest feed override taken on <namespace>/feed_override, %; lowering it below the override in force lowers that",
        )
        .range(1.0, MAX_OVERRIDE)
        .value(V::Double(a.max_feed_override)),
    ]
}

/// The parameters' values back into the options.
fn read_back(a: &mut Args, params: &[Param]) {
    for p in params {
        match (p.name, &p.value) {
            ("machine", V::String(s)) => a.machine = s.clone(),
            ("sim_namespace", V::String(s)) => a.sim_namespace = ros_args::absolute(s),
            ("rate", V::Double(r)) => a.rate = Some(*r),
            ("program_dir", V::String(s)) => a.program_dir = Some(PathBuf::from(s)),
            ("record_dir", V::String(s)) => a.record_dir = PathBuf::from(s),
            ("record_all", V::Boolean(b)) => a.record_all = *b,
            ("rt_priority", V::Integer(i)) => a.rt_priority = *i as i32,
            ("cpu_affinity", V::IntegerArray(c)) => a.cpu_affinity = affinity::cpus_of(c),
            ("loop_stats", V::Double(s)) => a.loop_stats = (*s > 0.0).then_some(*s),
            ("max_feed_override", V::Double(m)) => a.max_feed_override = *m,
            _ => {}
        }
    }
}

/// What the running node reads of its parameters that can change.
pub struct Live {
    record_dir: Mutex<PathBuf>,
    record_all: AtomicBool,
    loop_stats: AtomicU64,
    max_override: AtomicU64,
    /// the override last passed on to the control loop, %
    last_override: AtomicU64,
    /// a lowered maximum the control loop has not been told yet
    clamp: AtomicBool,
    machine_toml: String,
}

fn f64_of(a: &AtomicU64) -> f64 {
    f64::from_bits(a.load(Ordering::Relaxed))
}

impl Live {
    fn new(a: &Args, machine_toml: String) -> Live {
        Live {
            record_dir: Mutex::new(a.record_dir.clone()),
            record_all: AtomicBool::new(a.record_all),
            loop_stats: AtomicU64::new(a.loop_stats.unwrap_or(0.0).to_bits()),
            max_override: AtomicU64::new(a.max_feed_override.to_bits()),
            last_override: AtomicU64::new(100f64.to_bits()),
            clamp: AtomicBool::new(false),
            machine_toml,
        }
    }

    /// How the next job records.
    pub fn record_opts(&self) -> RecordOpts {
        RecordOpts {
            dir: self
                .record_dir
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone(),
            all: self.record_all.load(Ordering::Relaxed),
            machine_toml: self.machine_toml.clone(),
        }
    }

    /// How often the loop's lateness is logged (None: not).
    pub fn loop_stats(&self) -> Option<Duration> {
        let s = f64_of(&self.loop_stats);
        (s.is_finite() && s > 0.0).then(|| Duration::from_secs_f64(s))
    }

    /// A feed override from the topic, %: what goes on to the control
    /// loop, or why not (above `max_feed_override`). Values the controller
    /// refuses itself (negative, NaN, ...) pass, for it to say so.
    pub fn feed_override(&self, percent: f64) -> Result<f64, String> {
        let max = f64_of(&self.max_override);
        if percent > max {
            return Err(format!(
                "feed override {percent} % refused: above max_feed_override {max} %"
            ));
        }
        if percent.is_finite() && (0.0..=MAX_OVERRIDE).contains(&percent) {
            self.last_override
                .store(percent.to_bits(), Ordering::Relaxed);
        }
        Ok(percent)
    }

    /// The override to put in force after `max_feed_override` was lowered
    /// below the one in force (once).
    pub fn take_clamp(&self) -> Option<f64> {
        if !self.clamp.swap(false, Ordering::Relaxed) {
            return None;
        }
        let max = f64_of(&self.max_override);
        (f64_of(&self.last_override) > max).then(|| {
            self.last_override.store(max.to_bits(), Ordering::Relaxed);
            max
        })
    }

    fn apply(&self, (name, v): Change) {
        match (name.as_str(), v) {
            ("record_dir", V::String(s)) => {
                *self.record_dir.lock().unwrap_or_else(|e| e.into_inner()) = PathBuf::from(s)
            }
            ("record_all", V::Boolean(b)) => self.record_all.store(b, Ordering::Relaxed),
            ("loop_stats", V::Double(s)) => self.loop_stats.store(s.to_bits(), Ordering::Relaxed),
            ("max_feed_override", V::Double(m)) => {
                self.max_override.store(m.to_bits(), Ordering::Relaxed);
                self.clamp.store(true, Ordering::Relaxed);
            }
            _ => {}
        }
    }
}

/// The node's own check of a value set while it runs.
fn check(name: &str, v: &V) -> Result<(), String> {
    match (name, v) {
        ("record_dir", V::String(s)) => {
            let p = std::path::Path::new(s);
            if s.is_empty() {
                Err("record_dir: an empty path; give a directory".into())
            } else if p.exists() && !p.is_dir() {
                Err(format!("record_dir: {s} is not a directory"))
            } else {
                Ok(())
            }
        }
        _ => Ok(()),
    }
}

/// Serves the parameters on `node` with the values in force (the rate and
/// program directory the node runs with) and keeps [`Live`] up to date
/// with what `ros2 param set` changes.
pub fn serve(
    ctx: &ros2_client::Context,
    node: &mut ros2_client::Node,
    setup: &Setup,
    rate_hz: f64,
    program_dir: &std::path::Path,
    machine_toml: String,
) -> Result<(Arc<Live>, Parameters), String> {
    let mut params = setup.params.clone();
    for p in params.iter_mut() {
        match p.name {
            "rate" => p.value = V::Double(rate_hz),
            "program_dir" => p.value = path_value(program_dir),
            _ => {}
        }
    }
    let (handle, changes) = Parameters::serve(ctx, node, NODE, params, Box::new(check))?;
    let live = Arc::new(Live::new(&setup.args, machine_toml));
    let l = live.clone();
    std::thread::Builder::new()
        .name("ros-param-apply".into())
        .spawn(move || {
            while let Ok(c) = changes.recv() {
                l.apply(c);
            }
        })
        .map_err(|e| e.to_string())?;
    Ok((live, handle))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn argv(v: &[&str]) -> Vec<OsString> {
        std::iter::once("cnc_node")
            .chain(v.iter().copied())
            .map(OsString::from)
            .collect()
    }

    #[test]
    fn options_and_ros_args_make_the_settings_and_the_ros_args_win() {
        let s = setup(argv(&[
            "--rate",
            "500",
            "--record-all",
            "--ros-args",
            "-r",
            "__ns:=/m2",
            "-r",
            "__node:=ctl",
            "-p",
            "rate:=800",
            "-p",
            "record_all:=false",
            "-p",
            "loop_stats:=5",
            "-p",
            "sim_namespace:=/m2sim",
        ]))
        .unwrap();
        assert_eq!(s.args.rate, Some(800.0));
        assert!(!s.args.record_all);
        assert_eq!(s.args.loop_stats, Some(5.0));
        assert_eq!(s.args.namespace, "/m2");
        assert_eq!(s.args.sim_namespace, "/m2sim");
        assert_eq!(s.start.fqn, "/m2/ctl");
        let s = setup(argv(&["--namespace", "/a"])).unwrap();
        assert_eq!(s.start.fqn, "/a/cnc_node");
        assert_eq!(s.args.rate, None);
        assert_eq!(s.args.max_feed_override, 200.0);
    }

    #[test]
    fn bad_values_are_errors_that_say_where_they_came_from() {
        for (a, want) in [
            (
                &["--ros-args", "-p", "rate:=5"][..],
                "parameter 'rate': 5.0 is out of its range 10 to 20000 (from -p rate:=5)",
            ),
            (
                &["--ros-args", "-p", "record_all:=maybe"][..],
                "parameter 'record_all' is a bool, not a string ('maybe')",
            ),
            (
                &["--ros-args", "-p", "rt_priority:=1.5"][..],
                "is an integer, not a double",
            ),
            (
                &["--max-feed-override", "300"][..],
                "--max-feed-override: parameter 'max_feed_override': 300.0 is out of its range",
            ),
            (
                &["--ros-args", "--bogus"][..],
                "unknown ROS argument '--bogus'",
            ),
        ] {
            let e = setup(argv(a)).expect_err("an error");
            assert!(e.contains(want), "{a:?}: {e}");
        }
    }

    #[test]
    fn the_override_is_held_to_its_maximum() {
        let s = setup(argv(&["--max-feed-override", "120"])).unwrap();
        let live = Live::new(&s.args, String::new());
        assert_eq!(live.feed_override(110.0), Ok(110.0));
        assert!(live
            .feed_override(150.0)
            .unwrap_err()
            .contains("above max_feed_override 120 %"));
        assert_eq!(live.take_clamp(), None);
        live.apply(("max_feed_override".into(), V::Double(100.0)));
        assert_eq!(live.take_clamp(), Some(100.0));
        assert_eq!(live.take_clamp(), None);
        live.apply(("record_dir".into(), V::String("/tmp/x".into())));
        assert_eq!(live.record_opts().dir, PathBuf::from("/tmp/x"));
        live.apply(("loop_stats".into(), V::Double(0.0)));
        assert_eq!(live.loop_stats(), None);
    }
}
