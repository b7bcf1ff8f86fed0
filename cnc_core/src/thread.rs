//! Spindle-synchronized motion: G33 thread cutting (the spindle tracker
//! that G33 and G95 follow is `tracker.rs`).
//!
//! A thread block is a function of the spindle angle, not of time. Let θ be
//! the spindle angle in revolutions, counted in the direction of rotation,
//! and θ₀ the angle at which the *ideal thread line* passes the block's
//! start: the instant the spindle, counted from its index pulse, passes the
//! start angle `I`. On the ideal line the lead axis has travelled
//! `u = pitch × (θ − θ₀)`; every pass at any speed follows that same line,
//! so every pass cuts the same groove.
//!
//! The axis cannot jump to the line's speed. The first block of a chain
//! starts with a *run-in*: `Δ` revolutions of the spindle over which the
//! lead axis accelerates from rest at the start point into the line it
//! meets tangentially, for θs = θ₀ − Δ/2 ≤ θ ≤ θ₀ + Δ/2. Without a jerk
//! limit it is a parabola in θ, `u = pitch (θ − θs)² / (2Δ)`, whose
//! acceleration is `pitch ω² / Δ`; with one, an S-curve in θ ([`s_ramp`]):
//! the acceleration grows at the jerk limit, holds, and falls back to zero
//! where the run-in meets the line. Either is symmetric, so it meets the
//! line Δ/2 after θ₀ whatever its shape. Δ is chosen from the axis limits
//! at the programmed speed (plus
//! [`SPEED_MARGIN`](crate::shares::SPEED_MARGIN)), and the run-in begins Δ/2 before θ₀ as predicted from
//! the measured spindle. The last block of a chain ends with the mirror
//! image, a deceleration into the end point. Blocks in between follow the
//! line without a new index wait (θ₀ of the next block is where this one
//! ends on the line). Run-in and deceleration are lengths of lead travel
//! (`pitch Δ / 2`) that the check makes sure fit in their blocks.
//!
//! With a runout `J` (machine constant 8) the runout axis moves in
//! addition by `(u − (len − J)) tan α` over the last `J` millimetres; the
//! kink where it begins is rounded by a curve of width `blend` centred on
//! it (a parabola, or with a jerk limit an S-curve), so the runout axis's
//! acceleration and jerk stay within its limits. The end point is exactly
//! `J tan α` from the programmed one.
//!
//! The jerk of a thread block is that of its run-in, deceleration and
//! runout at the planned spindle speed, plus whatever the spindle's own
//! speed changes add; a chained block's start (a kink within one cycle's
//! share of the acceleration) is not jerk-limited. (A controlled stop
//! inside the thread, on an abort or a fault, is: `exec.rs`, `StopRun`.)

use crate::canon::{RunoutPath, ThreadMove, ThreadSeg};
use crate::geom::V3;
use crate::shares::{
    KINK_SHARE, SPEED_MARGIN, THREAD_JERK_FLOOR, THREAD_SHARE, TRACKER_JERK_COUNTS,
};

/// Encoder readings older than this many interpolation cycles mean the
/// signal is lost (during G33 or G95 motion: controlled stop, error),
/// unless the machine file sets `spindle.encoder_timeout_ms`. (25 ms at
/// 1 kHz: a host without a real-time kernel holds up the simulator's or
/// the node's loop for 5-8 ms several times a minute, and with 10 cycles
/// three of four lathe thread jobs ended in error on such a host; until
/// the readings are missed the executor follows the spindle's predicted
/// angle, which at a steady speed is where it is.)
pub const ENCODER_TIMEOUT_CYCLES: f64 = 25.0;
/// The measured speed must be within this fraction of S before a thread
/// starts (the spindle is at speed) ...
pub const AT_SPEED_TOLERANCE: f64 = 0.05;
/// ... for this long plus the time the spindle's ramp takes over the
/// tolerance band, s (so the thread does not start at the end of the ramp).
pub const AT_SPEED_SETTLE_S: f64 = 0.05;

/// The lead for the servo's lag under the spindle's acceleration eases in
/// over this much of a thread line's start after a run-in, and out over
/// its end before a deceleration, s at the programmed speed
/// ([`ThreadMove::accel_lead_weight`]). Its third derivative adds at most
/// 60/T³ × that lead: about 8 m/s³ at S2000 with a spindle rippling ±2 %
/// at 5 Hz on the bundled lathe (T = 10 ms: 63). Switched on at once, the
/// lead stepped the setpoint by up to a micrometre within a cycle (2045
/// m/s³). The price is the groove where it eases: the axis trails there
/// as without the lead (the spread of the groove at S2000 with that
/// ripple: 0.290° → 0.337° at 1 kHz, 0.102° → 0.271° at 10 kHz).
pub const ACCEL_LEAD_EASE_S: f64 = 0.02;

/// A ramp of a slope from 0 to `r` over a width `w`, with a jerk phase
/// of length `c` at either end (0 ≤ c ≤ w/2): the second derivative grows
/// linearly from 0 to `r / (w − c)` over the first `c`, holds, and falls
/// back to 0 over the last `c`. Its value and slope at `y`, clamped to
/// 0..=w: both 0 at 0, `r·w/2` and `r` at `w`. The ramp is symmetric, so
/// whatever `c`, it meets tangentially at `w` the line of slope `r` that
/// leaves 0 at `w/2`. `c = 0`: the parabola `r·y²/(2w)`.
pub fn s_ramp(y: f64, r: f64, w: f64, c: f64) -> (f64, f64) {
    let y = y.clamp(0.0, w);
    if c <= 0.0 {
        return (r * y * y / (2.0 * w), r * y / w);
    }
    let a = r / (w - c);
    let j = a / c;
    if y < c {
        (j * y * y * y / 6.0, 0.5 * j * y * y)
    } else if y <= w - c {
        let s = y - c;
        (
            a * c * c / 6.0 + 0.5 * a * c * s + 0.5 * a * s * s,
            0.5 * a * c + a * s,
        )
    } else {
        let z = w - y;
        (
            0.5 * r * w - (r * z - j * z * z * z / 6.0),
            r - 0.5 * j * z * z,
        )
    }
}

/// The second derivative of [`s_ramp`] at `y` (0 outside 0..=w).
pub fn s_ramp_curvature(y: f64, r: f64, w: f64, c: f64) -> f64 {
    if !(0.0..=w).contains(&y) {
        return 0.0;
    }
    if c <= 0.0 {
        return r / w;
    }
    let a = r / (w - c);
    if y < c {
        a * y / c
    } else if y <= w - c {
        a
    } else {
        a * (w - y) / c
    }
}

/// A symmetric change of speed by `dv` (> 0) from and to zero
/// acceleration, within acceleration `a` and jerk `j` (finite): its
/// duration and the length of either jerk phase, s.
fn s_curve_time(dv: f64, a: f64, j: f64) -> (f64, f64) {
    if dv * j >= a * a {
        (dv / a + a / j, a / j)
    } else {
        // a triangle of acceleration, below `a`
        let tj = (dv / j).sqrt();
        (2.0 * tj, tj)
    }
}

/// The Δ of a run-in or deceleration of lead acceleration `accel` and jerk
/// `jerk` (infinite: none) into the line of `pitch` at spindle speed `w_p`
/// rev/s, and its jerk phase ([`s_ramp`]'s `c`), both in revolutions.
pub fn ramp_revs(pitch: f64, w_p: f64, accel: f64, jerk: f64) -> (f64, f64) {
    if !jerk.is_finite() {
        return (pitch * w_p * w_p / accel, 0.0);
    }
    let (t, tj) = s_curve_time(pitch * w_p, accel, jerk);
    (t * w_p, tj * w_p)
}

impl RunoutPath {
    /// The runout axis's offset after lead travel `u`.
    pub fn offset(&self, u: f64) -> f64 {
        let h = 0.5 * self.blend;
        if u <= self.from - h {
            0.0
        } else if u < self.from + h {
            let x = u - (self.from - h);
            s_ramp(x, self.tan, self.blend, self.jerk_phase).0
        } else {
            self.tan * (u - self.from)
        }
    }
}

impl ThreadSeg {
    /// The position after lead travel `u` (0..=len); exact at both ends.
    pub fn pos(&self, u: f64) -> V3 {
        if u <= 0.0 {
            return self.start;
        }
        if u >= self.len {
            return self.end;
        }
        let f = u / self.len;
        let mut p = self.start + (self.prog_end - self.start) * f;
        let s = (self.prog_end[self.lead] - self.start[self.lead]).signum();
        p[self.lead] = self.start[self.lead] + s * u;
        if let Some(r) = self.runout {
            p[r.axis] += r.offset(u);
        }
        p
    }

    /// Axis velocities per unit of lead velocity, far from the runout's
    /// kink: (before the runout, in it).
    pub fn ratios(&self) -> (V3, V3) {
        let d = (self.prog_end - self.start) / self.len;
        let mut r = d;
        if let Some(ro) = self.runout {
            r[ro.axis] += ro.tan;
        }
        (d, r)
    }
}

/// Where a sample falls in a thread block's run-in or deceleration
/// ([`ThreadMove::at`]).
enum Ramp {
    In { y: f64, d: f64 },
    Out { y: f64, d: f64 },
}

impl ThreadMove {
    /// Spindle turning direction the angles count in: +1 M03, −1 M04.
    pub fn dir(&self) -> f64 {
        if self.rpm < 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// Where the block starts moving, revolutions from θ₀ (≤ 0).
    pub fn start_x(&self) -> f64 {
        self.runin.map_or(0.0, |(_, d)| -0.5 * d)
    }

    /// Where the block is done, revolutions from θ₀: the end of the line
    /// (the next block takes over there) or the end of the deceleration.
    pub fn end_x(&self) -> f64 {
        self.seg.len / self.seg.pitch + self.decel.map_or(0.0, |d| 0.5 * d)
    }

    /// Lead travel at `x` = θ − θ₀ revolutions (clamped to the block) and
    /// its rate du/dθ (mm/rev) there.
    pub fn at(&self, x: f64) -> (f64, f64) {
        let (p, l) = (self.seg.pitch, self.seg.len);
        match self.ramp(x) {
            Some(Ramp::In { y, d }) => s_ramp(y, p, d, self.jerk_phase()),
            Some(Ramp::Out { y, d }) => {
                let (u, du) = s_ramp(y, p, d, self.jerk_phase());
                (l - u, du)
            }
            None => ((p * x).clamp(0.0, l), p),
        }
    }

    /// d²u/dθ² at `x` (see [`ThreadMove::at`]), mm/rev².
    pub fn d2u_dx2(&self, x: f64) -> f64 {
        let p = self.seg.pitch;
        match self.ramp(x) {
            Some(Ramp::In { y, d }) => s_ramp_curvature(y, p, d, self.jerk_phase()),
            Some(Ramp::Out { y, d }) => -s_ramp_curvature(y, p, d, self.jerk_phase()),
            None => 0.0,
        }
    }

    /// Which ramp `x` is in, with its coordinate `y` from the ramp's end at
    /// rest (negative before the run-in begins) and its Δ; `None` on the
    /// line.
    fn ramp(&self, x: f64) -> Option<Ramp> {
        if let Some((_, d)) = self.runin {
            if x < 0.5 * d {
                return Some(Ramp::In { y: x + 0.5 * d, d });
            }
        }
        let d = self.decel?;
        let xl = self.seg.len / self.seg.pitch;
        (x > xl - 0.5 * d).then_some(Ramp::Out {
            y: xl + 0.5 * d - x,
            d,
        })
    }

    /// The jerk phase of the run-in and the deceleration, revolutions (0:
    /// no jerk limit, parabolas).
    pub fn jerk_phase(&self) -> f64 {
        if !self.jerk.is_finite() {
            return 0.0;
        }
        let (w_p, _) = lead_speed(self.seg.pitch, self.rpm);
        ramp_revs(self.seg.pitch, w_p, self.accel, self.jerk).1
    }

    /// How much of the lead for the servo's lag under the spindle's
    /// acceleration (`thread_accel_lead`) a setpoint at `x` on the line
    /// takes: 1, eased in over the line's first [`ACCEL_LEAD_EASE_S`] after
    /// a run-in and out over its last before a deceleration (a smootherstep
    /// in θ, with no slope and no curvature at either end), so that the
    /// lead comes and goes without a step. (Off the line the lead is 0:
    /// eased in over the run-in instead, the tracker's noise in it added
    /// to the S-curve's own jerk where that is largest, 211 m/s³ at S2000
    /// on the bundled lathe.)
    pub fn accel_lead_weight(&self, x: f64) -> f64 {
        let ease = (self.rpm.abs() / 60.0 * ACCEL_LEAD_EASE_S).max(1e-12);
        let xl = self.seg.len / self.seg.pitch;
        let from = self.runin.map_or(f64::NEG_INFINITY, |(_, d)| 0.5 * d);
        let to = self.decel.map_or(f64::INFINITY, |d| xl - 0.5 * d);
        let step = |z: f64| {
            let z = z.clamp(0.0, 1.0);
            z * z * z * (z * (6.0 * z - 15.0) + 10.0)
        };
        step((x - from) / ease) * step((to - x) / ease)
    }

    /// Lead travel at `x` (see [`ThreadMove::at`]).
    pub fn u_at(&self, x: f64) -> f64 {
        self.at(x).0
    }

    /// du/dθ at `x`, mm/rev (see [`ThreadMove::at`]).
    pub fn du_dx(&self, x: f64) -> f64 {
        self.at(x).1
    }

    /// θ₀ for a chain's first block: the first instant the spindle, counted
    /// from the index at `index`, passes the start angle while the run-in
    /// can still begin at or after `now` (all in revolutions, counted in
    /// the direction of rotation).
    pub fn sync_angle(&self, now: f64, index: f64) -> f64 {
        let i = self.runin.map_or(0.0, |(i, _)| i);
        let first = index + i;
        let n = (now - self.start_x() - first).max(0.0).ceil();
        let mut theta0 = first + n;
        // (the ceil may land a hair short by rounding; a few steps at most,
        // and none where a revolution is below the angles' resolution)
        for _ in 0..4 {
            if theta0 + self.start_x() >= now {
                break;
            }
            theta0 += 1.0;
        }
        theta0
    }
}

/// What a thread block may ask of the machine: each axis's speed and
/// acceleration, the interpolation period, and which axes exist.
#[derive(Clone, Copy, Debug)]
pub struct ThreadLimits {
    pub vmax: V3,
    pub amax: V3,
    /// jerk, mm/s³ (infinite: none)
    pub jmax: V3,
    pub dt: f64,
    pub present: [bool; 3],
    /// the spindle encoder's counts per revolution (0: none configured)
    pub cpr: f64,
}

impl ThreadLimits {
    /// The jerk the spindle tracker's quantization puts on the lead of a
    /// thread of `pitch`, mm/s³ ([`TRACKER_JERK_COUNTS`]; 0 without an
    /// encoder).
    pub fn noise_jerk(&self, pitch: f64) -> f64 {
        if self.cpr > 0.0 && self.dt > 0.0 {
            TRACKER_JERK_COUNTS * pitch.abs() / (self.cpr * self.dt.powi(3))
        } else {
            0.0
        }
    }
}

/// The jerk a run-in or deceleration may give an axis of jerk limit
/// `jmax` that carries `noise` mm/s³ of the tracker's: what the limit
/// leaves beside it, within [`THREAD_SHARE`] and [`THREAD_JERK_FLOOR`] of
/// the limit.
fn run_in_jerk(jmax: f64, noise: f64) -> f64 {
    (THREAD_SHARE * jmax)
        .min(jmax - noise)
        .max(THREAD_JERK_FLOOR * jmax)
}

/// Why a thread block cannot be cut at its programmed speed. The
/// interpreter words each for the block's author.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FitError {
    /// axis `axis` would move at `speed` mm/s, over its `vmax`; the
    /// spindle speed that keeps it within, rpm
    TooFast {
        axis: usize,
        speed: f64,
        vmax: f64,
        s_max: f64,
    },
    /// a chain's first block: the run-in needs `ramp` mm of lead travel,
    /// the block has `room`
    RunIn { ramp: f64, room: f64 },
    /// a chained block: axis `axis`'s speed would jump by `jump` mm/s at
    /// its start
    Kink { axis: usize, jump: f64 },
}

/// A thread block fitted to the axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadFit {
    /// lead acceleration of the run-in and the deceleration, mm/s²
    pub accel: f64,
    /// their lead jerk, mm/s³ (infinite: no axis has a jerk limit)
    pub jerk: f64,
    /// the run-in's Δ, revolutions, and its lead travel, mm
    pub delta: f64,
    pub ramp: f64,
    /// axis velocities at the programmed speed at the block's end, mm/s
    pub v_end: V3,
}

/// The spindle's speed a run-in or deceleration is planned for, rev/s
/// ([`SPEED_MARGIN`] over `rpm`), and the lead's speed then, mm/s.
pub fn lead_speed(pitch: f64, rpm: f64) -> (f64, f64) {
    let w_p = rpm.abs() * SPEED_MARGIN / 60.0;
    (w_p, pitch * w_p)
}

/// The width of the curve that rounds a runout's kink and its jerk phase
/// ([`s_ramp`]), mm of lead travel, so that the runout axis accelerates
/// within half its share of `amax` and, with a jerk limit `jmax` (finite),
/// of `jmax` (the other half: the deceleration). Without one the curve is
/// a parabola (jerk phase 0).
pub fn runout_blend(tan: f64, v_lead: f64, amax: f64, jmax: f64) -> (f64, f64) {
    if !jmax.is_finite() {
        return (
            tan.abs() * v_lead * v_lead / (0.5 * THREAD_SHARE * amax),
            0.0,
        );
    }
    let (t, tj) = s_curve_time(
        tan.abs() * v_lead,
        0.5 * THREAD_SHARE * amax,
        0.5 * THREAD_SHARE * jmax,
    );
    (t * v_lead, tj * v_lead)
}

/// Fits a thread block to the axes at `rpm`: every axis within its speed
/// in the thread, the lead acceleration within [`THREAD_SHARE`] of every
/// axis's and the jerk within what the tracker's noise leaves of it
/// ([`run_in_jerk`]; half of each for the runout axis), the run-in within the block
/// before its runout (`chained`: none), and a chained block's start
/// continuing the previous block's end velocity `prev` within the kink
/// share of one cycle.
pub fn fit(
    seg: &ThreadSeg,
    rpm: f64,
    lim: &ThreadLimits,
    chained: bool,
    prev: Option<V3>,
) -> Result<ThreadFit, FitError> {
    let (w_p, v_lead) = lead_speed(seg.pitch, rpm);
    let (r0, r1) = seg.ratios();
    let mut accel = f64::INFINITY;
    let mut jerk = f64::INFINITY;
    for i in 0..3 {
        let r = r0[i].abs().max(r1[i].abs());
        if !lim.present[i] || r < 1e-12 {
            continue;
        }
        if v_lead * r > lim.vmax[i] {
            return Err(FitError::TooFast {
                axis: i,
                speed: v_lead * r,
                vmax: lim.vmax[i],
                s_max: lim.vmax[i] / (r * seg.pitch * SPEED_MARGIN) * 60.0,
            });
        }
        let share = if seg.runout.is_some_and(|ro| ro.axis == i) {
            0.5
        } else {
            1.0
        };
        accel = accel.min(THREAD_SHARE * share * lim.amax[i] / r);
        jerk = jerk.min(share * run_in_jerk(lim.jmax[i], r * lim.noise_jerk(seg.pitch)) / r);
    }
    let (delta, _) = ramp_revs(seg.pitch, w_p, accel, jerk); // revolutions
    let ramp = 0.5 * seg.pitch * delta; // lead travel, mm
    let room = seg.runout.map_or(seg.len, |ro| ro.from - 0.5 * ro.blend);
    if !chained && ramp > room {
        return Err(FitError::RunIn { ramp, room });
    }
    if let Some(v_prev) = prev {
        let v_now = r0 * v_lead;
        for i in 0..3 {
            let jump = (v_now[i] - v_prev[i]).abs();
            if lim.present[i] && jump > KINK_SHARE * lim.amax[i] * lim.dt {
                return Err(FitError::Kink { axis: i, jump });
            }
        }
    }
    Ok(ThreadFit {
        accel,
        jerk,
        delta,
        ramp,
        v_end: r1 * v_lead,
    })
}

/// How long the spindle's measured acceleration is averaged over before
/// G33's lead for the servo's lag under acceleration multiplies it, s
/// ([`LeadAccel`]).
pub const LEAD_ACCEL_WINDOW_S: f64 = 0.008;

/// The spindle acceleration that G33's lead for the servo's lag under
/// acceleration (`interpolation.thread_accel_lead`) multiplies: the
/// tracker's, averaged over the last [`LEAD_ACCEL_WINDOW_S`] with weights
/// that ramp in and out (sin², so a new value enters, and an old one
/// leaves, without a step). The tracker's acceleration is its fit's
/// curvature, which the counts' quantization makes swing by steps of
/// thousands of counts/s² from one cycle to the next, where a real
/// spindle's changes by about a hundredth of that; the lead, τ/kp (33 µs²
/// on the bundled lathe) times the pitch times that, turned each swing into
/// jerk. The price is the average's delay, half the window: on a spindle
/// rippling ±2 % at 5 Hz at S2000 the lead then lags the ripple's
/// acceleration by 4 ms (about 0.03° of groove).
#[derive(Clone, Debug)]
pub struct LeadAccel {
    /// the last accelerations, a ring (newest at `at`)
    hist: Vec<f64>,
    /// the weight by age (0: newest)
    weights: Vec<f64>,
    at: usize,
    /// how many of `hist` hold values
    n: usize,
}

impl LeadAccel {
    /// An average over [`LEAD_ACCEL_WINDOW_S`] at samples `dt` s apart (at
    /// least one sample, at most 4096).
    pub fn new(dt: f64) -> LeadAccel {
        let n = if dt > 0.0 {
            (LEAD_ACCEL_WINDOW_S / dt).round().clamp(1.0, 4096.0) as usize
        } else {
            1
        };
        let weights = (0..n)
            .map(|i| {
                let s = (core::f64::consts::PI * (i as f64 + 0.5) / n as f64).sin();
                s * s
            })
            .collect();
        LeadAccel {
            hist: vec![0.0; n],
            weights,
            at: 0,
            n: 0,
        }
    }

    /// Forgets every value (a new pass).
    pub fn reset(&mut self) {
        self.n = 0;
    }

    /// Takes this sample's acceleration and returns the average (over the
    /// values there are, while fewer than the window's).
    pub fn push(&mut self, a: f64) -> f64 {
        let len = self.hist.len();
        self.at = (self.at + 1) % len;
        self.hist[self.at] = a;
        self.n = (self.n + 1).min(len);
        let (mut sum, mut w_sum) = (0.0, 0.0);
        for (age, w) in self.weights.iter().take(self.n).enumerate() {
            sum += w * self.hist[(self.at + len - age) % len];
            w_sum += w;
        }
        if w_sum > 0.0 {
            sum / w_sum
        } else {
            a
        }
    }
}

/// The deceleration of a chain's last block into its end at lead
/// acceleration `accel`: Δ, revolutions, and its lead travel, mm.
pub fn deceleration(m: &ThreadMove, accel: f64) -> (f64, f64) {
    let (w_p, _) = lead_speed(m.seg.pitch, m.rpm);
    let (delta, _) = ramp_revs(m.seg.pitch, w_p, accel, m.jerk);
    (delta, 0.5 * m.seg.pitch * delta)
}

#[cfg(test)]
mod tests;
