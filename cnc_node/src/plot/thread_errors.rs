//! The lead error of G33 passes against the spindle angle, collected from
//! the steps of an offline run ([`ThreadErrors`], a [`Sink`]).

use super::decimate::{Decimator, MAX_SERIES_POINTS};
use crate::offline::{SimSummary, Sink, Step};
use cnc_core::Machine;

/// One sample of a thread pass: the lead error against the spindle angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadErrorPoint {
    /// spindle angle the setpoint is for, degrees from the pass's θ₀
    /// (`(theta − theta0) × 360`, counted in the direction of rotation)
    pub deg: f64,
    /// setpoint lead travel minus the ideal thread line
    /// `pitch × (true spindle angle − θ₀)`, µm
    pub set_um: f64,
    /// the same for the simulated actual position, µm
    pub act_um: f64,
    /// in the synchronized part (not run-in or deceleration)
    pub on_line: bool,
}

/// One pass of a thread: a chain of G33 blocks from its run-in to its
/// deceleration, one sync.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadPass {
    /// the pass's first G33 block
    pub line: u32,
    pub block_no: Option<u64>,
    /// lead axis (0 X, 1 Y, 2 Z) and the first block's pitch, mm/rev
    pub lead: usize,
    pub pitch: f64,
    /// θ₀ of the first block, revolutions (the x axis's zero)
    pub theta0: f64,
    /// one encoder count along the lead at `pitch`, µm
    pub count_um: f64,
    /// samples of the pass (from the start of the run-in), and of those
    /// on the thread line
    pub samples: u64,
    pub on_line_samples: u64,
    /// the synchronized parts, degrees from θ₀ (first to last sample
    /// on the line; one span per chain)
    pub sync_deg: Vec<(f64, f64)>,
    /// largest |error| on the line: setpoint and actual, in µm and in
    /// encoder counts (each block's own pitch), over every sample
    pub max_set_um: f64,
    pub max_set_counts: f64,
    pub max_act_um: f64,
    pub max_act_counts: f64,
    /// the angle from which the actual error stays within one count for
    /// the rest of the synchronized part (`None`: not at its end)
    pub act_within_count_from_deg: Option<f64>,
    /// the error curve, thinned to at most [`MAX_SERIES_POINTS`] points
    /// (the ends of run-in, line and deceleration kept)
    pub points: Vec<ThreadErrorPoint>,
}

/// The lead error of every G33 pass of a run ([`thread_error_series`](super::thread_error_series)).
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadErrorSeries {
    /// encoder counts per spindle revolution
    pub counts_per_rev: u32,
    pub passes: Vec<ThreadPass>,
    /// why the run stopped early, if it did
    pub fault: Option<String>,
}

/// The pass being collected.
struct PassAcc {
    pass: ThreadPass,
    points: Decimator<ThreadErrorPoint>,
    /// the latest sample still at rest at the start (waiting for the sync
    /// angle), kept until the run-in moves
    waiting: Option<ThreadErrorPoint>,
    moved: bool,
    /// the previous sample was on the line
    prev_on: bool,
}

/// Collects [`ThreadErrorSeries`] from the steps of an offline run (a
/// [`Sink`] of [`crate::offline::run`], or fed by
/// [`crate::offline::simulate`]): a pass begins at a
/// sample with `sync` after one without. The lead error compares the
/// lead axis's travel from the block's start (setpoint, simulated actual)
/// with `pitch × (θ − θ₀)` at the simulated spindle's true angle θ (the
/// angle after the step, the instant the setpoint is for), for each
/// block's own θ₀ and pitch. Samples at rest before the run-in begins
/// (waiting for the sync angle) are left out but the last.
pub struct ThreadErrors {
    joints: Vec<usize>,
    cpr: u32,
    cur: Option<PassAcc>,
    passes: Vec<ThreadPass>,
    /// the run's fault, once it has finished (as a sink)
    fault: Option<String>,
}

impl ThreadErrors {
    pub fn new(machine: &Machine) -> ThreadErrors {
        ThreadErrors {
            joints: machine.joint_indices(),
            cpr: machine
                .spindle
                .as_ref()
                .map_or(0, |s| s.encoder_counts_per_rev),
            cur: None,
            passes: Vec::new(),
            fault: None,
        }
    }

    /// Takes one step of the run.
    pub fn step(&mut self, st: &Step) {
        let (Some(sync), Some(sp)) = (st.sample.sync, st.spindle) else {
            self.close();
            return;
        };
        let Some(j) = self.joints.iter().position(|&i| i == sync.lead) else {
            return;
        };
        let cpr = sp.encoder().counts_per_rev.max(1);
        self.cpr = cpr;
        let dir = if st.sample.spindle_rpm < 0.0 {
            -1.0
        } else {
            1.0
        };
        let theta_true = dir * sp.revolutions();
        let acc = self.cur.get_or_insert_with(|| PassAcc {
            pass: ThreadPass {
                line: st.sample.src.line,
                block_no: st.sample.src.block_no,
                lead: sync.lead,
                pitch: sync.pitch,
                theta0: sync.theta0,
                count_um: sync.pitch / f64::from(cpr) * 1000.0,
                samples: 0,
                on_line_samples: 0,
                sync_deg: Vec::new(),
                max_set_um: 0.0,
                max_set_counts: 0.0,
                max_act_um: 0.0,
                max_act_counts: 0.0,
                act_within_count_from_deg: None,
                points: Vec::new(),
            },
            points: Decimator::new(MAX_SERIES_POINTS),
            waiting: None,
            moved: false,
            prev_on: false,
        });
        let ideal = sync.pitch * (theta_true - sync.theta0);
        let u_set =
            sync.lead_sign * (st.setpoints.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let u_act =
            sync.lead_sign * (st.actual.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let pt = ThreadErrorPoint {
            deg: (sync.theta - acc.pass.theta0) * 360.0,
            set_um: (u_set - ideal) * 1000.0,
            act_um: (u_act - ideal) * 1000.0,
            on_line: sync.on_line,
        };
        if !acc.moved {
            if sync.u == 0.0 && !sync.on_line {
                acc.waiting = Some(pt);
                return;
            }
            acc.moved = true;
            if let Some(w) = acc.waiting.take() {
                acc.pass.samples += 1;
                acc.points.push(0, w);
            }
        }
        let p = &mut acc.pass;
        p.samples += 1;
        acc.points.push(u8::from(pt.on_line), pt);
        let prev_on = std::mem::replace(&mut acc.prev_on, pt.on_line);
        if !pt.on_line {
            return;
        }
        let count_um = sync.pitch / f64::from(cpr) * 1000.0;
        p.on_line_samples += 1;
        p.max_set_um = p.max_set_um.max(pt.set_um.abs());
        p.max_set_counts = p.max_set_counts.max(pt.set_um.abs() / count_um);
        p.max_act_um = p.max_act_um.max(pt.act_um.abs());
        p.max_act_counts = p.max_act_counts.max(pt.act_um.abs() / count_um);
        match p.sync_deg.last_mut() {
            Some(span) if prev_on => span.1 = pt.deg,
            _ => p.sync_deg.push((pt.deg, pt.deg)),
        }
        if pt.act_um.abs() > count_um {
            p.act_within_count_from_deg = None;
        } else if p.act_within_count_from_deg.is_none() {
            p.act_within_count_from_deg = Some(pt.deg);
        }
    }

    /// Ends the pass being collected, if any.
    fn close(&mut self) {
        if let Some(acc) = self.cur.take() {
            let mut pass = acc.pass;
            let mut points = Vec::new();
            for (k, (_, run)) in acc.points.finish().into_iter().enumerate() {
                // each run after the first begins with the previous one's end
                points.extend(run.into_iter().skip(usize::from(k > 0)));
            }
            points.extend(acc.waiting);
            pass.points = points;
            self.passes.push(pass);
        }
    }

    /// The passes collected; `fault` as the run reported it.
    pub fn finish(mut self, fault: Option<String>) -> ThreadErrorSeries {
        self.fault = fault;
        self.into_series()
    }

    /// The passes collected, with the fault of the run that finished this
    /// sink.
    pub fn into_series(mut self) -> ThreadErrorSeries {
        self.close();
        ThreadErrorSeries {
            counts_per_rev: self.cpr,
            passes: self.passes,
            fault: self.fault,
        }
    }
}

impl Sink for ThreadErrors {
    fn step(&mut self, st: &Step) -> Result<(), String> {
        ThreadErrors::step(self, st);
        Ok(())
    }

    fn finish(&mut self, summary: &SimSummary) -> Result<(), String> {
        self.close();
        self.fault = summary.fault.clone();
        Ok(())
    }
}
