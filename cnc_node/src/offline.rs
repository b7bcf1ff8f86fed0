//! The offline run: executor samples drive the in-process axis and spindle
//! model (the same model the simulator node uses).

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::ProgramSource;
use cnc_core::{Dialect, Machine};
use sim_axes::{Axis, AxisParams, MachineModel, Spindle, SpindleParams};

/// Drive headroom of the simulated axes over the planner's limits.
pub const DRIVE_HEADROOM: f64 = 1.25;

/// The axis and spindle model for a machine file, axes in joint order.
pub fn model_for(machine: &Machine) -> MachineModel {
    let axes = machine
        .axes
        .iter()
        .map(|a| {
            Axis::new(
                AxisParams {
                    max_velocity: a.max_velocity_mm_s * DRIVE_HEADROOM,
                    max_acceleration: a.max_acceleration_mm_s2 * DRIVE_HEADROOM,
                    kp: a.servo_kp,
                    velocity_feed_forward: a.servo_feed_forward,
                    velocity_lag: a.servo_lag_s,
                },
                a.home_mm,
            )
        })
        .collect();
    let spindle = machine.spindle.as_ref().map(|s| {
        Spindle::new(SpindleParams {
            max_rpm: s.max_rpm,
            acceleration_rpm_per_s: s.acceleration_rpm_s,
            encoder_counts_per_rev: s.encoder_counts_per_rev,
            ripple_fraction: s.sim_ripple_fraction,
            ripple_hz: s.sim_ripple_hz,
            noise_rpm: s.sim_noise_rpm,
            seed: 1,
        })
    });
    MachineModel::new(axes, spindle)
}

/// What a simulation run measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSummary {
    pub samples: u64,
    /// s
    pub cycle_time: f64,
    /// largest |setpoint - actual| per joint, mm
    pub max_following_error: Vec<f64>,
}

/// One step of the run, for sinks (CSV, recordings, progress).
pub struct Step<'a> {
    pub sample: &'a Sample,
    /// setpoints per joint, mm
    pub setpoints: &'a [f64],
    /// simulated actual positions per joint, mm
    pub actual: &'a [f64],
}

/// Runs a checked program to its end against the model.
pub fn simulate<S: ProgramSource>(
    source: S,
    dialect: Dialect,
    machine: &Machine,
    mut sink: impl FnMut(&Step),
) -> SimSummary {
    let joints = machine.joint_indices();
    let mut model = model_for(machine);
    let mut exec = Executor::new(source, dialect, machine);
    let dt = exec.dt();
    let n = joints.len();
    let mut set = vec![0.0; n];
    let mut act = vec![0.0; n];
    let mut max_err = vec![0.0f64; n];
    let mut samples = 0u64;
    let mut cycle_time = 0.0;
    while let Some(s) = exec.next_sample() {
        for (j, &i) in joints.iter().enumerate() {
            set[j] = s.pos[i];
        }
        if s.k > 0 {
            model.step(&set, s.spindle_rpm, dt);
        }
        model.positions_into(&mut act);
        for j in 0..n {
            max_err[j] = max_err[j].max((set[j] - act[j]).abs());
        }
        sink(&Step {
            sample: &s,
            setpoints: &set,
            actual: &act,
        });
        samples += 1;
        cycle_time = s.t;
    }
    SimSummary {
        samples,
        cycle_time,
        max_following_error: max_err,
    }
}
