//! The simulation of an offline run: executor samples drive the
//! in-process axis and spindle model (the same model the simulator node
//! uses), one [`Step`] per sample.

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::ProgramSource;
use cnc_core::{Dialect, Machine};
pub use sim_axes::machine::{model_for as model_for_seed, DRIVE_HEADROOM};
use sim_axes::MachineModel;

/// The axis and spindle model for a machine file (spindle noise seed 1).
pub fn model_for(machine: &Machine) -> MachineModel {
    model_for_seed(machine, 1)
}

/// What a simulation run measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSummary {
    pub samples: u64,
    /// s
    pub cycle_time: f64,
    /// largest |setpoint - actual| per joint, mm
    pub max_following_error: Vec<f64>,
    /// why the run stopped early (lost encoder, spindle not turning)
    pub fault: Option<String>,
}

/// One step of the run, for sinks (CSV, recordings, progress).
pub struct Step<'a> {
    pub sample: &'a Sample,
    /// setpoints per joint, mm
    pub setpoints: &'a [f64],
    /// simulated actual positions per joint, mm
    pub actual: &'a [f64],
    /// the simulated spindle after this step (true angle and encoder)
    pub spindle: Option<&'a sim_axes::Spindle>,
}

/// Runs a checked program to its end against the model.
pub fn simulate<S: ProgramSource>(
    source: S,
    dialect: Dialect,
    machine: &Machine,
    sink: impl FnMut(&Step),
) -> SimSummary {
    simulate_with(source, dialect, machine, |_| {}, sink)
}

/// [`simulate`], with `alter` applied to every interpolator sample before
/// the model and the sinks see it (fault injection: e.g. the regression
/// test's deliberate one-micrometre interpolator error).
pub fn simulate_with<S: ProgramSource>(
    source: S,
    dialect: Dialect,
    machine: &Machine,
    mut alter: impl FnMut(&mut Sample),
    mut sink: impl FnMut(&Step),
) -> SimSummary {
    let joints = machine.joint_indices();
    let mut model = model_for(machine);
    let mut exec = Executor::new(source, dialect, machine);
    // G33 and G95 follow the simulated encoder, as in the node
    if model.spindle.is_some() {
        exec.attach_encoder();
    }
    let dt = exec.dt();
    let n = joints.len();
    let mut set = vec![0.0; n];
    let mut act = vec![0.0; n];
    let mut max_err = vec![0.0f64; n];
    let mut samples = 0u64;
    let mut cycle_time = 0.0;
    while let Some(mut s) = exec.next_sample() {
        alter(&mut s);
        for (j, &i) in joints.iter().enumerate() {
            set[j] = s.pos[i];
        }
        if s.k > 0 {
            model.step(&set, s.spindle_rpm, dt);
        }
        model.positions_into(&mut act);
        if let Some(sp) = model.spindle.as_ref() {
            exec.encoder(encoder_reading(&sp.encoder(), s.t));
        }
        for j in 0..n {
            max_err[j] = max_err[j].max((set[j] - act[j]).abs());
        }
        sink(&Step {
            sample: &s,
            setpoints: &set,
            actual: &act,
            spindle: model.spindle.as_ref(),
        });
        samples += 1;
        cycle_time = s.t;
    }
    SimSummary {
        samples,
        cycle_time,
        max_following_error: max_err,
        fault: exec.fault().map(str::to_string),
    }
}

/// The simulator's encoder reading at time `t` as the executor takes it.
pub fn encoder_reading(e: &sim_axes::EncoderReading, t: f64) -> cnc_core::tracker::EncoderReading {
    cnc_core::tracker::EncoderReading {
        t,
        count: e.count,
        counts_per_rev: e.counts_per_rev,
        index_count: e.index_count,
        count_at_index: e.count_at_index,
    }
}
