//! `sim_axes`'s settings: its options, its `--ros-args` and the ROS
//! parameters they are while it runs (docs/ros_interface.md §6).
//!
//! Every option `--foo-bar X` is the parameter `foo_bar`, except
//! `--namespace` (`-r __ns:=/ns`) and `--domain` (`ROS_DOMAIN_ID`); given
//! both ways, the ROS parameter wins (with a warning). `ripple`,
//! `noise_rpm` and `setpoint_delay_ms` can be set while it runs.

use clap::Parser;
use cnc_core::machine::MAX_SETPOINT_DELAY_MS;
use cnc_msgs::options::{self, Options};
use cnc_msgs::params::{Kind, Param};
use cnc_msgs::ros::affinity;
use cnc_msgs::ros_args;
use ros2_client::ParameterValue as V;

#[derive(Parser, Debug)]
#[command(
    name = "sim_axes",
    version,
    about = "Simulated lathe/mill axes and spindle encoder as a ROS 2 node",
    after_help = "ROS arguments (after --ros-args, up to --): -r __ns:=/NS, -r __node:=NAME, \
                  -r FROM:=TO, -p NAME:=VALUE (each option below is a parameter, e.g. -p \
                  setpoint_delay_ms:=3), --params-file FILE, --log-level LEVEL"
)]
pub struct Args {
    /// machine file, or a bundled machine: mill, lathe
    #[arg(long, default_value = "mill")]
    pub machine: String,
    /// namespace of this node's topics
    #[arg(long, default_value = "/sim")]
    pub namespace: String,
    /// namespace of the controller whose setpoints are followed
    #[arg(long, default_value = "/cnc")]
    pub controller_namespace: String,
    /// DDS domain (default: ROS_DOMAIN_ID, else 0)
    #[arg(long)]
    pub domain: Option<u16>,
    /// simulation rate, Hz (default: the machine file's interpolation rate)
    #[arg(long)]
    pub rate: Option<f64>,
    /// spindle speed ripple as a fraction, e.g. 0.02 (default: machine file)
    #[arg(long)]
    pub ripple: Option<f64>,
    /// spindle speed noise, rpm (default: machine file)
    #[arg(long)]
    pub noise_rpm: Option<f64>,
    /// apply each setpoint this long after its stamp, ms; 0: on arrival
    /// (default: the machine file's interpolation.setpoint_delay_ms)
    #[arg(long)]
    pub setpoint_delay_ms: Option<f64>,
    /// seed of the spindle noise
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// real-time (SCHED_FIFO) priority of the simulation loop, 1-99; 0 keeps
    /// the normal policy
    #[arg(long, default_value_t = 70)]
    pub rt_priority: i32,
    /// pin the node's threads to these CPUs, e.g. 1 or 0,2 (default: any);
    /// a twin's two nodes on one CPU cost about a quarter less CPU on a VM
    #[arg(long, value_name = "CPUS", value_delimiter = ',')]
    pub cpu_affinity: Vec<usize>,
    /// stop after this many seconds (default: run until killed)
    #[arg(long)]
    pub duration: Option<f64>,
}

pub const NODE: &str = "sim_axes";

pub type Setup = options::Setup<Args>;

/// The settings from this process's command line (clap's errors, `--help`
/// and `--version` exit here as usual).
pub fn from_env() -> Result<Setup, String> {
    options::setup(std::env::args_os())
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

fn declare(a: &Args) -> Vec<Param> {
    let opt = |v: Option<f64>| v.map_or(V::NotSet, V::Double);
    vec![
        Param::fixed("machine", Kind::String, "machine file, or a bundled machine: mill, lathe")
            .value(V::String(a.machine.clone())),
        Param::fixed(
            "controller_namespace",
            Kind::String,
            "namespace of the controller whose joint_setpoints and spindle_command are followed",
        )
        .value(V::String(a.controller_namespace.clone())),
        Param::fixed("rate", Kind::Double, "simulation rate, Hz (the machine file's interpolation rate unless given)")
            .range(10.0, 20_000.0)
            .value(opt(a.rate)),
        Param::live("ripple", Kind::Double, "spindle speed ripple, a fraction of the speed (the machine file's unless given)")
            .range(0.0, 0.99)
            .value(opt(a.ripple)),
        Param::live("noise_rpm", Kind::Double, "spindle speed noise, rpm (the machine file's unless given)")
            .range(0.0, 10_000.0)
            .value(opt(a.noise_rpm)),
        Param::live(
            "setpoint_delay_ms",
            Kind::Double,
            "each setpoint is applied this long after its stamp, ms; 0: on arrival (the machine file's unless given; also the setpoint_delay service)",
        )
        .range(0.0, MAX_SETPOINT_DELAY_MS)
        .value(opt(a.setpoint_delay_ms)),
        Param::fixed("seed", Kind::Integer, "seed of the spindle noise")
            .range(0.0, 9.0e15)
            .value(V::Integer(i64::try_from(a.seed).unwrap_or(i64::MAX))),
        Param::fixed(
            "rt_priority",
            Kind::Integer,
            "SCHED_FIFO priority of the simulation loop (DDS threads at 60, or just below the loop); 0: normal scheduling",
        )
        .range(0.0, 99.0)
        .value(V::Integer(i64::from(a.rt_priority))),
        affinity::param(&a.cpu_affinity),
        Param::fixed("duration", Kind::Double, "stop after this many seconds; 0: run until stopped")
            .range(0.0, 1.0e9)
            .value(V::Double(a.duration.unwrap_or(0.0))),
    ]
}

fn read_back(a: &mut Args, params: &[Param]) {
    for p in params {
        match (p.name, &p.value) {
            ("machine", V::String(s)) => a.machine = s.clone(),
            ("controller_namespace", V::String(s)) => {
                a.controller_namespace = ros_args::absolute(s)
            }
            ("rate", V::Double(r)) => a.rate = Some(*r),
            ("ripple", V::Double(r)) => a.ripple = Some(*r),
            ("noise_rpm", V::Double(n)) => a.noise_rpm = Some(*n),
            ("setpoint_delay_ms", V::Double(d)) => a.setpoint_delay_ms = Some(*d),
            ("seed", V::Integer(s)) => a.seed = (*s).max(0) as u64,
            ("rt_priority", V::Integer(p)) => a.rt_priority = *p as i32,
            ("cpu_affinity", V::IntegerArray(c)) => a.cpu_affinity = affinity::cpus_of(c),
            ("duration", V::Double(d)) => a.duration = (*d > 0.0).then_some(*d),
            _ => {}
        }
    }
}

/// The parameters with the values the simulator runs with.
pub fn in_force(
    setup: &Setup,
    rate: f64,
    ripple: f64,
    noise_rpm: f64,
    delay_ms: f64,
) -> Vec<Param> {
    let mut params = setup.params.clone();
    for p in params.iter_mut() {
        match p.name {
            "rate" => p.value = V::Double(rate),
            "ripple" => p.value = V::Double(ripple),
            "noise_rpm" => p.value = V::Double(noise_rpm),
            "setpoint_delay_ms" => p.value = V::Double(delay_ms),
            _ => {}
        }
    }
    params
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup(v: &[&str]) -> Result<Setup, String> {
        options::setup(
            std::iter::once("sim_axes")
                .chain(v.iter().copied())
                .map(std::ffi::OsString::from),
        )
    }

    #[test]
    fn ros_parameters_set_the_options() {
        let s = setup(&[
            "--seed",
            "4",
            "--ros-args",
            "-r",
            "__ns:=/m2sim",
            "-p",
            "controller_namespace:=/m2",
            "-p",
            "setpoint_delay_ms:=2",
            "-p",
            "seed:=9",
        ])
        .unwrap();
        assert_eq!(s.args.namespace, "/m2sim");
        assert_eq!(s.args.controller_namespace, "/m2");
        assert_eq!(s.args.setpoint_delay_ms, Some(2.0));
        assert_eq!(s.args.seed, 9);
        let e = setup(&["--ros-args", "-p", "ripple:=1.5"]).unwrap_err();
        assert!(
            e.contains("out of its range 0 to 0.99 (from -p ripple:=1.5)"),
            "{e}"
        );
    }
}
