//! The lead error of G33 passes against the spindle angle, collected from
//! the steps of an offline run ([`ThreadErrors`], a [`Sink`]) or measured
//! from a recording (`crate::bag::measure_recording`); either way one
//! `PassBuilder` makes each [`ThreadPass`].

use super::decimate::{Decimator, MAX_SERIES_POINTS};
use crate::offline::{SimSummary, Sink, Step};
use cnc_core::Machine;

/// One sample of a thread pass: the lead error against the spindle angle.
/// (Of a recording: the angle is the recorded encoder's at the setpoint's
/// stamp plus the controller's lead, the actual position the joint states'
/// at that instant.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadErrorPoint {
    /// spindle angle the setpoint is for, degrees from the pass's θ₀
    /// (`(theta − theta0) × 360`, counted in the direction of rotation)
    pub deg: f64,
    /// setpoint lead travel minus the ideal thread line
    /// `pitch × (true spindle angle − θ₀)`, µm
    pub set_um: f64,
    /// the same for the simulated actual position, µm (NaN: none there)
    pub act_um: f64,
    /// in the synchronized part (not run-in or deceleration)
    pub on_line: bool,
}

/// The groove's phase over the synchronized part of a pass: at each
/// sample on the line, the lead error as an angle of the spindle,
/// `error / pitch × 360°` wrapped to (−180°, 180°] — 0 on the programmed
/// thread line (the start angle `I` after the index); the same as
/// `((lead travel) / pitch − revolutions from the index) × 360° + I`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseStats {
    /// samples measured
    pub n: u64,
    /// their mean, largest |phase| and max − min, degrees (0 when `n` is 0)
    pub mean_deg: f64,
    pub worst_deg: f64,
    pub spread_deg: f64,
}

/// `deg` as printed with a sign and four decimals: rounded to them, and a
/// value that rounds to zero is +0 (not "-0.0000°").
pub fn signed_deg4(deg: f64) -> f64 {
    (deg * 1e4).round() / 1e4 + 0.0
}

/// `deg` wrapped to (−180, 180].
pub fn wrap_deg(deg: f64) -> f64 {
    let d = deg.rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// The phase of a lead error of `err_um` at `pitch` mm/rev, degrees in
/// (−180, 180].
pub fn phase_deg(err_um: f64, pitch: f64) -> f64 {
    wrap_deg(err_um / 1000.0 / pitch * 360.0)
}

/// Collects [`PhaseStats`].
#[derive(Clone, Copy, Debug)]
struct PhaseAcc {
    n: u64,
    sum: f64,
    worst: f64,
    min: f64,
    max: f64,
}

impl Default for PhaseAcc {
    fn default() -> Self {
        PhaseAcc {
            n: 0,
            sum: 0.0,
            worst: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }
}

impl PhaseAcc {
    fn push(&mut self, deg: f64) {
        if !deg.is_finite() {
            return;
        }
        self.n += 1;
        self.sum += deg;
        self.worst = self.worst.max(deg.abs());
        self.min = self.min.min(deg);
        self.max = self.max.max(deg);
    }

    fn stats(&self) -> PhaseStats {
        if self.n == 0 {
            return PhaseStats::default();
        }
        PhaseStats {
            n: self.n,
            mean_deg: self.sum / self.n as f64,
            worst_deg: self.worst,
            spread_deg: self.max - self.min,
        }
    }
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
    /// θ₀ of the first block, revolutions (the x axis's zero; of a
    /// recording, from the index the pass's first encoder reading saw)
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
    /// the groove's phase on the line: of the setpoints and of the actual
    /// positions ([`PhaseStats`])
    pub groove_set: PhaseStats,
    pub groove_act: PhaseStats,
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

/// Builds one [`ThreadPass`] from its samples in order: the numbers of
/// the synchronized part and the thinned error curve. An offline run
/// ([`ThreadErrors`]) gives each sample's setpoint and actual error
/// together; a recording (`crate::bag::thread_phase`) gives the setpoints'
/// samples and measures the actual positions at their own stamps
/// ([`push_act`](Self::push_act)).
pub(crate) struct PassBuilder {
    pass: ThreadPass,
    points: Decimator<ThreadErrorPoint>,
    /// the previous sample was on the line
    prev_on: bool,
    set_phase: PhaseAcc,
    act_phase: PhaseAcc,
}

impl PassBuilder {
    /// A pass whose first block is at source `line` (`block_no`), lead
    /// axis `lead`, `pitch` mm/rev, θ₀ `theta0` revolutions, with an
    /// encoder of `cpr` counts per revolution.
    pub(crate) fn new(
        line: u32,
        block_no: Option<u64>,
        lead: usize,
        pitch: f64,
        theta0: f64,
        cpr: u32,
    ) -> PassBuilder {
        PassBuilder {
            pass: ThreadPass {
                line,
                block_no,
                lead,
                pitch,
                theta0,
                count_um: pitch / f64::from(cpr.max(1)) * 1000.0,
                samples: 0,
                on_line_samples: 0,
                sync_deg: Vec::new(),
                max_set_um: 0.0,
                max_set_counts: 0.0,
                max_act_um: 0.0,
                max_act_counts: 0.0,
                act_within_count_from_deg: None,
                groove_set: PhaseStats::default(),
                groove_act: PhaseStats::default(),
                points: Vec::new(),
            },
            points: Decimator::new(MAX_SERIES_POINTS),
            prev_on: false,
            set_phase: PhaseAcc::default(),
            act_phase: PhaseAcc::default(),
        }
    }

    /// The next sample of the pass, of a block of `pitch` mm/rev; with
    /// `with_act`, its actual error counts in the pass's numbers too.
    pub(crate) fn push(&mut self, pt: ThreadErrorPoint, pitch: f64, cpr: u32, with_act: bool) {
        let p = &mut self.pass;
        p.samples += 1;
        self.points.push(u8::from(pt.on_line), pt);
        let prev_on = std::mem::replace(&mut self.prev_on, pt.on_line);
        if !pt.on_line {
            return;
        }
        let count_um = pitch / f64::from(cpr.max(1)) * 1000.0;
        p.on_line_samples += 1;
        p.max_set_um = p.max_set_um.max(pt.set_um.abs());
        p.max_set_counts = p.max_set_counts.max(pt.set_um.abs() / count_um);
        self.set_phase.push(phase_deg(pt.set_um, pitch));
        match p.sync_deg.last_mut() {
            Some(span) if prev_on => span.1 = pt.deg,
            _ => p.sync_deg.push((pt.deg, pt.deg)),
        }
        if with_act {
            self.push_act(pt.deg, pt.act_um, true, pitch, cpr);
        }
    }

    /// An actual position's error `act_um` at `deg` from θ₀, of a block of
    /// `pitch` mm/rev, measured on its own (in the order of the actual
    /// positions); only those on the line count.
    pub(crate) fn push_act(&mut self, deg: f64, act_um: f64, on_line: bool, pitch: f64, cpr: u32) {
        if !on_line || !act_um.is_finite() {
            return;
        }
        let p = &mut self.pass;
        let count_um = pitch / f64::from(cpr.max(1)) * 1000.0;
        p.max_act_um = p.max_act_um.max(act_um.abs());
        p.max_act_counts = p.max_act_counts.max(act_um.abs() / count_um);
        self.act_phase.push(phase_deg(act_um, pitch));
        if act_um.abs() > count_um {
            p.act_within_count_from_deg = None;
        } else if p.act_within_count_from_deg.is_none() {
            p.act_within_count_from_deg = Some(deg);
        }
    }

    /// The pass, with `tail` (a last sample still at rest) after its points.
    pub(crate) fn finish(self, tail: Option<ThreadErrorPoint>) -> ThreadPass {
        let mut pass = self.pass;
        let mut points = Vec::new();
        for (k, (_, run)) in self.points.finish().into_iter().enumerate() {
            // each run after the first begins with the previous one's end
            points.extend(run.into_iter().skip(usize::from(k > 0)));
        }
        points.extend(tail);
        pass.points = points;
        pass.groove_set = self.set_phase.stats();
        pass.groove_act = self.act_phase.stats();
        pass
    }
}

/// A lead axis within this of a pass's start stands there, mm (a run-in
/// that is an S-curve moves less than that in its first cycle).
pub(crate) const AT_START_MM: f64 = 1e-6;

/// The pass being collected from an offline run.
struct PassAcc {
    pass: PassBuilder,
    /// the latest sample still at rest at the start (waiting for the sync
    /// angle), kept until the run-in moves
    waiting: Option<ThreadErrorPoint>,
    moved: bool,
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
            pass: PassBuilder::new(
                st.sample.src.line,
                st.sample.src.block_no,
                sync.lead,
                sync.pitch,
                sync.theta0,
                cpr,
            ),
            waiting: None,
            moved: false,
        });
        let ideal = sync.pitch * (theta_true - sync.theta0);
        let u_set =
            sync.lead_sign * (st.setpoints.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let u_act =
            sync.lead_sign * (st.actual.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let pt = ThreadErrorPoint {
            deg: (sync.theta - acc.pass.pass.theta0) * 360.0,
            set_um: (u_set - ideal) * 1000.0,
            act_um: (u_act - ideal) * 1000.0,
            on_line: sync.on_line,
        };
        if !acc.moved {
            if sync.u.abs() <= AT_START_MM && !sync.on_line {
                acc.waiting = Some(pt);
                return;
            }
            acc.moved = true;
            if let Some(w) = acc.waiting.take() {
                acc.pass.push(w, sync.pitch, cpr, true);
            }
        }
        acc.pass.push(pt, sync.pitch, cpr, true);
    }

    /// Ends the pass being collected, if any.
    fn close(&mut self) {
        if let Some(acc) = self.cur.take() {
            self.passes.push(acc.pass.finish(acc.waiting));
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
