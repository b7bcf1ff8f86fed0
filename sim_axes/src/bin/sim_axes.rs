//! The simulator node: simulated axes (servo with following error) and a
//! spindle with an incremental encoder, as a ROS 2 node.
//!
//! Subscribes `<cnc>/joint_setpoints` (sensor_msgs/JointState, m) and
//! `<cnc>/spindle_command` (std_msgs/Float64, rad/s); publishes
//! `<ns>/joint_states` (m, m/s) and `<ns>/spindle_encoder`
//! (cnc_msgs/SpindleEncoder) at a fixed rate.

use clap::Parser;
use cnc_msgs::ros::{self, Ticker};
use cnc_msgs::{Float64, Header, JointState, SpindleEncoder};
use sim_axes::machine::{load_machine, model_for};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "sim_axes",
    version,
    about = "Simulated lathe/mill axes and spindle encoder as a ROS 2 node"
)]
struct Args {
    /// machine file, or a bundled machine: mill, lathe
    #[arg(long, default_value = "mill")]
    machine: String,
    /// namespace of this node's topics
    #[arg(long, default_value = "/sim")]
    namespace: String,
    /// namespace of the controller whose setpoints are followed
    #[arg(long, default_value = "/cnc")]
    controller_namespace: String,
    /// DDS domain (default: ROS_DOMAIN_ID, else 0)
    #[arg(long)]
    domain: Option<u16>,
    /// simulation rate, Hz (default: the machine file's interpolation rate)
    #[arg(long)]
    rate: Option<f64>,
    /// spindle speed ripple as a fraction, e.g. 0.02 (default: machine file)
    #[arg(long)]
    ripple: Option<f64>,
    /// spindle speed noise, rpm (default: machine file)
    #[arg(long)]
    noise_rpm: Option<f64>,
    /// seed of the spindle noise
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// real-time (SCHED_FIFO) priority of the simulation loop, 1-99; 0 keeps
    /// the normal policy
    #[arg(long, default_value_t = 70)]
    rt_priority: i32,
    /// stop after this many seconds (default: run until killed)
    #[arg(long)]
    duration: Option<f64>,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("sim_axes: {e}");
        std::process::exit(2);
    }
}

fn run(a: Args) -> Result<(), String> {
    let mut machine = load_machine(&a.machine)?;
    if let Some(s) = machine.spindle.as_mut() {
        if let Some(r) = a.ripple {
            s.sim_ripple_fraction = r;
        }
        if let Some(n) = a.noise_rpm {
            s.sim_noise_rpm = n;
        }
    }
    let rate = a.rate.unwrap_or(machine.interpolation.rate_hz);
    if !(rate.is_finite() && (10.0..=20_000.0).contains(&rate)) {
        return Err(format!("--rate {rate}: must be between 10 and 20000 Hz"));
    }
    let dt = 1.0 / rate;
    let domain = a.domain.unwrap_or_else(ros::domain_from_env);
    let (_ctx, mut node) = ros::join(domain, &a.namespace, "sim_axes")?;
    let cns = a.controller_namespace.as_str();
    let sub_set = ros::subscription::<JointState>(&mut node, cns, "joint_setpoints")?;
    let sub_spin = ros::subscription::<Float64>(&mut node, cns, "spindle_command")?;
    let pub_js = ros::publisher::<JointState>(&mut node, &a.namespace, "joint_states")?;
    let pub_enc = ros::publisher::<SpindleEncoder>(&mut node, &a.namespace, "spindle_encoder")?;

    let names: Vec<String> = machine.axes.iter().map(|x| x.name.clone()).collect();
    let mut model = model_for(&machine, a.seed);
    let mut set: Vec<f64> = machine.axes.iter().map(|x| x.home_mm).collect();
    let mut act = vec![0.0; set.len()];
    let mut spindle_rpm = 0.0;
    if a.rt_priority > 0 {
        if let Err(e) = ros::set_realtime(a.rt_priority) {
            eprintln!(
                "sim_axes: loop stays at normal priority (SCHED_FIFO {}: {e})",
                a.rt_priority
            );
        }
    }
    let mut ticker = Ticker::new(Duration::from_secs_f64(dt));
    let start = Instant::now();
    eprintln!(
        "sim_axes: {} ({}), {} Hz, domain {domain}, {}/joint_states, {}/spindle_encoder",
        machine.name,
        names.join(" "),
        rate,
        a.namespace.trim_end_matches('/'),
        a.namespace.trim_end_matches('/')
    );
    loop {
        while let Ok(Some((m, _))) = sub_set.take() {
            for (n, p) in m.name.iter().zip(&m.position) {
                if let Some(j) = names.iter().position(|x| x == n) {
                    if p.is_finite() {
                        set[j] = p * 1000.0;
                    }
                }
            }
        }
        while let Ok(Some((m, _))) = sub_spin.take() {
            if m.data.is_finite() {
                spindle_rpm = m.data * 60.0 / std::f64::consts::TAU;
            }
        }
        model.step(&set, spindle_rpm, dt);
        model.positions_into(&mut act);
        let now = ros::wall_stamp();
        let js = JointState {
            header: Header {
                stamp: now,
                frame_id: String::new(),
            },
            name: names.clone(),
            position: act.iter().map(|p| p / 1000.0).collect(),
            velocity: model.axes.iter().map(|x| x.velocity() / 1000.0).collect(),
            effort: Vec::new(),
        };
        let _ = pub_js.publish(js);
        if let Some(sp) = model.spindle.as_ref() {
            let e = sp.encoder();
            let _ = pub_enc.publish(SpindleEncoder {
                stamp: now,
                count: e.count,
                counts_per_rev: e.counts_per_rev,
                index_count: e.index_count,
                count_at_index: e.count_at_index,
                velocity: e.velocity,
            });
        }
        if a.duration
            .is_some_and(|d| start.elapsed().as_secs_f64() >= d)
        {
            return Ok(());
        }
        ticker.wait();
    }
}
