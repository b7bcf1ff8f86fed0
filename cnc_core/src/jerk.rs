//! Jerk limitation (issue 17): the budget that sizes the two setpoint
//! filters and the planner's caps, and the filters themselves.
//!
//! 1. The **path filter** is a moving average of M_s samples over the path
//!    length s the planner's trapezoid profiles give at each tick; the
//!    setpoint is the path at the filtered s̃, so it stays exactly on the
//!    (blended) path. Its tangential jerk is at most 2a/(M_s·dt) ≤
//!    [`S_FILTER_SHARE`]·j.
//! 2. The **XYZ filter**, a moving average of M_f samples of those
//!    points, spreads the steps of the normal acceleration (a line meeting
//!    an arc, a kink's velocity jump) over M_f·dt. For a moving average the
//!    filtered sampled jerk is (A_k − A_{k−M_f})/(M_f·dt), A the input's
//!    sampled acceleration, so two normal accelerations within M_f + 1
//!    samples (`step_span`) of each other may differ by at most `b_step` =
//!    [`NORMAL_JERK_SHARE`]·j·M_f·dt. Near the ends of an arc (within
//!    `step_span` at its speed: where a line, another arc or a kink may be
//!    in the same window) the planner keeps the normal acceleration under
//!    `a_n` ≤ b_step/2, a kink's velocity jump over one sample too, so any
//!    two differ by at most `b_step`. Inside a long arc, where the window
//!    sees nothing but the arc, the normal acceleration only turns and
//!    grows: v³κ²·W within a quarter of `b_step` and 2·v·a_t·κ·W within
//!    half of it (as fast as it may grow near the ends, 2·T·j·W: any two
//!    samples within W, on the end or the inside, differ in size by half
//!    of `b_step` at most), which leaves a quarter for a curvature step
//!    of a curve's junction ([`JerkBudget::curve_speed`]); the speed there
//!    may be higher ([`JerkBudget::arc_caps`]). The turn of
//!    the tangential acceleration, a_t·v·κ, stays under
//!    [`TURN_JERK_SHARE`]·j, and the path filter takes the rest. The XYZ
//!    filter moves a point off a smooth path by at most
//!    κ_max·Var(s)/2 ≤ v²κ·(M_f²−1)·dt²/24 (about the mean of the samples'
//!    path lengths): inside arcs the normal acceleration stays under
//!    `a_dev` for [`XYZ_FILTER_ERROR_MM`]; near kinks the chord's sagitta
//!    a_n·((M_f−1)·dt)²/8 is within it, and M_f is chosen so that `a_n` is
//!    as large as both allow.
//! 3. The path filter delays s̃ behind s by up to (M_s−1)·dt: the speed
//!    and acceleration s̃ has at a point are those the profile had within
//!    `lag_distance` of it. The planner therefore applies each speed and
//!    acceleration cap over that distance on either side (and splits long
//!    lines so that only their ends take a neighbour's cap).

use crate::geom::{Geom, V3};
use crate::shares::{
    NORMAL_JERK_SHARE, OWN_ARC_TANGENT_SHARE, S_FILTER_SHARE, TURN_JERK_SHARE, XYZ_FILTER_ERROR_MM,
    XYZ_FILTER_TOLERANCE_SHARE,
};
use std::collections::VecDeque;

/// Longest XYZ filter, samples.
const MAX_XYZ_SAMPLES: usize = 1000;

/// What a machine's jerk limit leaves the planner and the filters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JerkBudget {
    pub dt: f64,
    /// path filter length, samples (1: none)
    pub m_s: usize,
    /// XYZ filter length, samples (1: none)
    pub m_f: usize,
    /// the least jerk limit of the axes, mm/s³ (∞: none)
    pub j: f64,
    /// the largest normal acceleration near the ends of arcs and at kinks
    /// (centripetal, or a kink's velocity jump over one sample), mm/s²
    /// (∞: no cap)
    pub a_n: f64,
    /// the largest step of the normal acceleration (vector) between two
    /// samples M_f + 1 apart, mm/s²
    pub b_step: f64,
    /// the largest normal acceleration inside an arc for the deviation,
    /// mm/s²
    pub a_dev: f64,
    /// a single-average budget ([`JerkBudget::single_average`]): the XYZ filter's
    /// error bound, mm (None: the bound of the caps, [`JerkBudget::error_mm`])
    pub single_average_error_mm: Option<f64>,
    /// the machine's filters, from which [`JerkBudget::for_tolerance`]
    /// makes the budget under another tolerance
    pub base: Base,
}

/// A machine's filters: its path filter's length (samples) and, where one
/// XYZ moving average alone keeps the path within
/// [`crate::shares::SINGLE_AVERAGE_ERROR_MM`], that average's length
/// (samples) and error bound (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Base {
    pub m_s: usize,
    pub single: Option<(usize, f64)>,
}

impl JerkBudget {
    /// No jerk limit: no filters, no caps.
    pub fn none(dt: f64) -> Self {
        JerkBudget {
            dt,
            m_s: 1,
            m_f: 1,
            j: f64::INFINITY,
            a_n: f64::INFINITY,
            b_step: f64::INFINITY,
            a_dev: f64::INFINITY,
            single_average_error_mm: None,
            base: Base {
                m_s: 1,
                single: None,
            },
        }
    }

    /// The budget of a machine with jerk limit `j` (mm/s³, the least of
    /// the axes'), a path filter of `m_s` samples and, where one XYZ
    /// moving average alone keeps the path within
    /// [`crate::shares::SINGLE_AVERAGE_ERROR_MM`], that average `single`
    /// (samples, error bound in mm), under path tolerance `tol`
    /// ([`JerkBudget::for_tolerance`]).
    pub fn for_machine(
        dt: f64,
        m_s: usize,
        j: Option<f64>,
        single: Option<(usize, f64)>,
        tol: f64,
    ) -> Self {
        let mut b = JerkBudget::new(dt, m_s, j);
        b.base = Base {
            m_s: m_s.max(1),
            single,
        };
        b.for_tolerance(tol)
    }

    /// At high jerk, where one XYZ moving average of `m` samples alone (M =
    /// ⌈2a/(j·dt)⌉, [`crate::Machine::single_average_samples`]) keeps the
    /// path within [`crate::shares::SINGLE_AVERAGE_ERROR_MM`] (its bound `error_mm`,
    /// [`crate::Machine::single_average_error_mm`]): no path filter
    /// (M_s = 1), that XYZ filter, no caps in the planner (as if
    /// unlimited), M − 1 ticks of hold after stops and blends shrunk by
    /// `error_mm`.
    pub fn single_average(dt: f64, m: usize, j: f64, error_mm: f64) -> Self {
        JerkBudget {
            m_f: m.max(1),
            j,
            single_average_error_mm: Some(if m > 1 { error_mm } else { 0.0 }),
            ..JerkBudget::none(dt)
        }
    }

    /// The budget for jerk limit `j` (mm/s³, the least of the axes'), with
    /// a path filter of `m_s` samples, for an exact path (G61): the XYZ
    /// filter within [`XYZ_FILTER_ERROR_MM`].
    pub fn new(dt: f64, m_s: usize, j: Option<f64>) -> Self {
        JerkBudget::with_error(dt, m_s, j, XYZ_FILTER_ERROR_MM)
    }

    /// [`new`](Self::new) with the XYZ filter within `error_mm` of the
    /// path (at least [`XYZ_FILTER_ERROR_MM`]); for a larger error no
    /// longer than the path filter or G61's XYZ filter (at M_f = M_s its
    /// normal acceleration is 0.8 of the path's, and the hold after a stop
    /// twice the path filter's).
    pub fn with_error(dt: f64, m_s: usize, j: Option<f64>, error_mm: f64) -> Self {
        let Some(j) = j.filter(|j| j.is_finite() && *j > 0.0) else {
            return JerkBudget::none(dt);
        };
        let error_mm = error_mm.max(XYZ_FILTER_ERROR_MM);
        // (a larger error: no longer than the path filter, or than G61's)
        let top = if error_mm > XYZ_FILTER_ERROR_MM {
            JerkBudget::new(dt, m_s, Some(j)).m_f.max(m_s)
        } else {
            MAX_XYZ_SAMPLES
        };
        // the XYZ filter: the longest normal acceleration both the jerk and
        // the deviation allow
        let (mut best_m, mut best_a) = (1, 0.0);
        for m in 2..=top.min(MAX_XYZ_SAMPLES) {
            let w = (m - 1) as f64 * dt;
            let by_jerk = NORMAL_JERK_SHARE * j * m as f64 * dt / 2.0;
            let by_error = 8.0 * error_mm / (w * w);
            let a = by_jerk.min(by_error);
            if a > best_a {
                best_m = m;
                best_a = a;
            }
            if by_error < by_jerk {
                break;
            }
        }
        let m = best_m as f64;
        JerkBudget {
            dt,
            m_s: m_s.max(1),
            m_f: best_m,
            j,
            a_n: best_a,
            b_step: NORMAL_JERK_SHARE * j * m * dt,
            a_dev: 24.0 * error_mm / ((m * m - 1.0) * dt * dt),
            single_average_error_mm: None,
            base: Base {
                m_s: m_s.max(1),
                single: None,
            },
        }
    }

    /// The budget under path tolerance `tol` (G64 P, mm; 0: G61): the XYZ
    /// filter may take [`XYZ_FILTER_TOLERANCE_SHARE`] of the tolerance
    /// (never less than [`XYZ_FILTER_ERROR_MM`]), the corner blends keep
    /// within the rest. A longer XYZ filter allows more normal
    /// acceleration where curvature steps (lines meeting arcs, kinks): at
    /// 50 m/s³ and P 0.01 mm, M_f 10 → 16 samples and `a_n` 99 → 160
    /// mm/s². Where the machine's single average
    /// ([`JerkBudget::single_average`], [`Base::single`]) keeps within that
    /// share, that average alone; where it does not (G61 or a small P on
    /// a machine whose average would cut arcs by more), the caps. Without
    /// a jerk limit the budget does not depend on the tolerance.
    pub fn for_tolerance(&self, tol: f64) -> JerkBudget {
        if !self.j.is_finite() {
            return *self;
        }
        let error = (XYZ_FILTER_TOLERANCE_SHARE * tol).max(XYZ_FILTER_ERROR_MM);
        let mut b = match self.base.single {
            Some((m, e)) if e <= error => JerkBudget::single_average(self.dt, m, self.j, e),
            _ => JerkBudget::with_error(self.dt, self.base.m_s, Some(self.j), error),
        };
        b.base = self.base;
        b
    }

    /// Whether the planner caps speeds and accelerations for the jerk
    /// (a jerk limit that the filters alone do not keep: not a single-average
    /// budget, [`JerkBudget::single_average`]).
    #[inline]
    pub fn limited(&self) -> bool {
        self.j.is_finite() && self.a_n.is_finite()
    }

    /// Whether there are setpoint filters (either longer than a sample).
    #[inline]
    pub fn filtered(&self) -> bool {
        self.m_s > 1 || self.m_f > 1
    }

    /// How long the path filter's window is, s.
    #[inline]
    pub fn lag_s(&self) -> f64 {
        (self.m_s.saturating_sub(1)) as f64 * self.dt
    }

    /// The time between two samples whose normal accelerations the XYZ
    /// filter's jerk compares, s ((M_f + 1)·dt).
    #[inline]
    pub fn step_span(&self) -> f64 {
        (self.m_f + 1) as f64 * self.dt
    }

    /// How far, along the path, a speed or acceleration cap reaches on
    /// either side when the profile runs at up to `v` mm/s.
    #[inline]
    pub fn lag_distance(&self, v: f64) -> f64 {
        self.lag_s() * v
    }

    /// Ticks the setpoints hold still after each stop so that both filters
    /// settle on the stop point.
    pub fn hold_ticks(&self) -> u64 {
        (self.m_s - 1 + self.m_f - 1) as u64
    }

    /// A line's own path filter, for a run from rest to rest: a moving
    /// average of M samples keeps the tangential jerk within
    /// (A_k − A_{k−M})/(M·dt), A the profile's sampled path acceleration.
    /// The line's profile never has +a and −a in one window (its cruise
    /// lasts at least M + 2 samples, [`own_peak_cap`](Self::own_peak_cap),
    /// and a feed hold or override keeps any two within M samples of each
    /// other within a, `exec.rs`), so A steps by at most a: on axis i that
    /// is |u_i|·a (`u`: |direction| per axis), and a line needs no share
    /// for normal accelerations or their turn, so M = ⌈a·max|u_i| /
    /// (j·dt)⌉, never longer than the path filter itself. 0 without the
    /// path filter. (The planner sizes the filter with it, `limits.rs`,
    /// and the blender reckons its hold, `blend.rs`.)
    #[inline]
    pub(crate) fn own_filter_samples(&self, u: &V3, a: f64) -> u32 {
        self.own_samples(a * u.max(), self.j)
    }

    /// A filter of its own that turns steps of `step` (mm/s²) into a jerk
    /// within `jerk`: ⌈step/(jerk·dt)⌉ samples, never longer than the path
    /// filter; 0 without the path filter.
    #[inline]
    fn own_samples(&self, step: f64, jerk: f64) -> u32 {
        if !(self.limited() && self.m_s > 1) {
            return 0;
        }
        let m = (step / (jerk * self.dt) - 1e-9).ceil();
        if m.is_finite() {
            m.clamp(1.0, self.m_s as f64) as u32
        } else {
            self.m_s as u32
        }
    }

    /// An arc's own path filter, for a run from rest to rest (its normal
    /// acceleration v²κ then starts and ends at 0: no step for an XYZ
    /// filter to spread): M = ⌈a/([`OWN_ARC_TANGENT_SHARE`]·j·dt)⌉ for
    /// its tangential acceleration a (steps of at most a, as a line's:
    /// [`own_filter_samples`](Self::own_filter_samples)), never longer
    /// than the path filter. The rest of the jerk is for the normal
    /// acceleration's growth and turn ([`own_arc_cap`](Self::own_arc_cap)).
    /// 0 without the path filter.
    #[inline]
    pub(crate) fn own_arc_samples(&self, a: f64) -> u32 {
        self.own_samples(a, OWN_ARC_TANGENT_SHARE * self.j)
    }

    /// The jerk an arc run from rest to rest under its own path filter
    /// leaves its normal acceleration's growth and turn, mm/s³.
    #[inline]
    fn own_arc_share(&self) -> f64 {
        (1.0 - OWN_ARC_TANGENT_SHARE) * self.j
    }

    /// Whether speed `v` keeps such an arc's 3·v·a·κ + v³·κ² within its
    /// share ([`own_arc_cap`](Self::own_arc_cap) is the fastest that does).
    #[inline]
    pub(crate) fn own_arc_keeps(&self, kappa: f64, a: f64, v: f64) -> bool {
        v * kappa * (3.0 * a + v * v * kappa) <= self.own_arc_share()
    }

    /// The fastest an arc of curvature at most `kappa` may run from rest
    /// to rest with its own path filter, at tangential acceleration up to
    /// `a`: on the arc (or helix) the jerk is s⃛·T + 3·ṡ·s̈·κ·N + ṡ³·r⃛(s),
    /// |r⃛| ≤ κ², so it stays within j where 3·v·a·κ + v³·κ² is within
    /// the share the tangential jerk leaves. (Newton's method from above,
    /// on an increasing convex function: it never passes the root.)
    pub(crate) fn own_arc_cap(&self, kappa: f64, a: f64) -> f64 {
        let r = self.own_arc_share();
        let (k2, k1) = (kappa * kappa, 3.0 * a * kappa);
        if !(k2 > 0.0 && r > 0.0) {
            return f64::INFINITY;
        }
        // (either term alone reaching r bounds the root from above)
        let mut v = (r / k2).cbrt();
        if k1 > 0.0 {
            v = v.min(r / k1);
        }
        for _ in 0..8 {
            let f = k2 * v * v * v + k1 * v - r;
            let d = 3.0 * k2 * v * v + k1;
            if !(f > 0.0 && d > 0.0) {
                break;
            }
            v -= f / d;
        }
        v * (1.0 - 1e-9)
    }

    /// The speed cap `vcap` of a line run from rest to rest with its own
    /// path filter of `m` samples, acceleration `a` over `length`, lowered
    /// where need be so that its cruise
    /// lasts at least M + 2 samples, so that no window of the filter holds
    /// both its acceleration and its deceleration (v²/a + v·T ≤ length, T
    /// = (M + 2)·dt). Against a filter sized for a step of 2·a (2·M
    /// samples, a hold of 2·M − 1) a line that cruises anyway runs M − 2
    /// samples shorter (a tick's wait and a hold of M, `timeline.rs`), and
    /// one whose peak this caps 2·(v/a − √(length/a)) + 4·dt longer: shorter
    /// unless its triangle would have lasted only a few samples.
    #[inline]
    pub(crate) fn own_peak_cap(&self, m: u32, a: f64, length: f64, vcap: f64) -> f64 {
        let t = (m as f64 + 2.0) * self.dt;
        // (most lines cruise that long at their feed: no square root)
        if vcap * (vcap / a + t) <= length {
            return vcap;
        }
        vcap.min(0.5 * a * ((t * t + 4.0 * length / a).sqrt() - t))
    }

    /// The largest distance by which the XYZ filter moves a setpoint off
    /// the path, mm: on smooth stretches v²κ·(M_f²−1)·dt²/24 with the arcs'
    /// `a_dev`; near kinks the sagitta of a curve with the normal
    /// acceleration `a_n` over the filter's window (straight lines are not
    /// moved; kinks' velocity jumps are normal accelerations of one sample
    /// and count in the same bound).
    pub fn error_mm(&self) -> f64 {
        if let Some(e) = self.single_average_error_mm {
            return e;
        }
        if self.m_f <= 1 || !self.a_n.is_finite() {
            return 0.0;
        }
        let w = (self.m_f - 1) as f64 * self.dt;
        let m = self.m_f as f64;
        let smooth = self.a_dev * (m * m - 1.0) * self.dt * self.dt / 24.0;
        (self.a_n * w * w / 8.0).max(smooth)
    }

    /// An arc's speed cap and tangential acceleration cap for curvature
    /// `kappa` (1/mm) on `part` of it ([`ArcPart`]). Near an end: the
    /// normal acceleration within `a_n`, the turn of the tangential
    /// acceleration a_t·v·κ within [`TURN_JERK_SHARE`]·j. Beside a tangent
    /// line or a stop: the normal acceleration within `b_step` (and
    /// `a_dev`), its turn over the filter's span W, v³κ²·W, within a
    /// quarter of `b_step`, and the same turn of the tangential one.
    /// Inside (the XYZ filter's window sees only the arc): also any faster
    /// speed at which the normal acceleration stays within `a_dev` and,
    /// over W, its turn within a quarter of `b_step` and its growth
    /// 2·v·a_t·κ·W within half of it.
    pub fn arc_caps(&self, kappa: f64, part: ArcPart) -> (f64, f64) {
        self.arc_caps_below(kappa, part, f64::INFINITY)
    }

    /// [`arc_caps`](Self::arc_caps) for an arc fed at `v_top`: beside a
    /// line its speed cap is no higher than that (nor under the end's), so
    /// that its tangential acceleration cap, which falls as the speed cap
    /// rises, is as high as that speed allows.
    pub fn arc_caps_below(&self, kappa: f64, part: ArcPart, v_top: f64) -> (f64, f64) {
        if !self.limited() || kappa <= 0.0 {
            return (f64::INFINITY, f64::INFINITY);
        }
        // (under `a_n` any two normal accelerations differ by at most
        // `b_step`, however they turn or grow)
        let by_size = (self.a_n / kappa).sqrt();
        let w = self.step_span();
        let q = 0.25 * self.b_step;
        // (a cube root: only for the parts that use it)
        let by_turn = || (q / (w * kappa * kappa)).cbrt();
        let end = |v: f64| (v, TURN_JERK_SHARE * self.j / (v * kappa));
        match part {
            ArcPart::End => end(by_size),
            // (beside a line or a stop the window holds the arc and normal
            // accelerations of 0: any two of size up to `b_step` that turn
            // by at most a quarter of it differ by at most `b_step`)
            ArcPart::Beside => end((self.b_step.min(self.a_dev) / kappa)
                .sqrt()
                .min(by_turn())
                .min(v_top)
                .max(by_size)),
            ArcPart::Inside => {
                let by_change = (self.a_dev / kappa).sqrt().min(by_turn());
                if by_change <= by_size {
                    return end(by_size);
                }
                let v = by_change;
                let a = (TURN_JERK_SHARE * self.j / (v * kappa)).min(q / (v * kappa * w));
                (v, a)
            }
        }
    }

    /// The speed cap of a kink whose unit tangent changes by `d` on some
    /// axis: its velocity jump over one sample within `a_n`.
    pub fn kink_cap(&self, d: f64) -> f64 {
        if !self.limited() || d <= 0.0 {
            return f64::INFINITY;
        }
        self.a_n * self.dt / d
    }

    /// The path filter's tangential jerk share, mm/s³.
    pub fn s_share(&self) -> f64 {
        S_FILTER_SHARE * self.j
    }
}

/// Where on an arc a piece lies, for its jerk caps
/// ([`JerkBudget::arc_caps`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcPart {
    /// within the XYZ filter's span of an end that anything may meet (a
    /// line, another arc, a kink)
    End,
    /// within that span only of ends met by a stop or, tangent, by a line
    /// at least that span long at the fastest path speed (so the window
    /// holds no other curvature or kink), or farther than the span from
    /// either end
    Beside,
    /// farther than the span from its ends, for the faster inside caps
    /// (only where an arc is long enough to be worth it)
    Inside,
}

/// A long move's end pieces halve this many times towards its ends, down
/// to this length (mm).
const SPLIT_LEVELS: usize = 6;
const MIN_PIECE_MM: f64 = 0.02;
/// Moves shorter than this many times the reach stay whole (a cap over
/// all of such a short move costs little time; its pieces cost the
/// look-ahead a walk over each: on the bundled mill, the check of a
/// 10,000-line G64 contour 119 → 64 ms for 0.005 s of its 47.9 s).
const SPLIT_FROM: f64 = 0.1;
/// Most cuts [`piece_cuts`] makes.
pub(crate) const MAX_CUTS: usize = 2 * SPLIT_LEVELS + 4;

/// The shortest piece [`piece_cuts`] cuts for caps reaching `reach` mm:
/// reach/64, at least [`MIN_PIECE_MM`]. (A cap holds over the whole of
/// each piece it reaches.)
#[inline]
pub(crate) fn least_piece(reach: f64) -> f64 {
    (reach / f64::from(1u32 << SPLIT_LEVELS)).max(MIN_PIECE_MM)
}

/// Where a move of `length` mm is cut into pieces so that caps reaching
/// `reach` mm into it reach only its ends: at reach/64, /64, /32, ..., /2
/// from either end (a shorter move: up to a third of it; one under
/// `SPLIT_FROM`·reach stays whole), and at
/// `inner_at` from either end (an arc's inside, `Lookahead::split`); the
/// cuts in order and their number, or None if the move stays whole.
pub(crate) fn piece_cuts(
    reach: f64,
    length: f64,
    inner_at: Option<f64>,
) -> Option<([f64; MAX_CUTS], usize)> {
    let least = least_piece(reach);
    if !(least > 0.0 && length > 3.0 * least && length > SPLIT_FROM * reach) {
        return None;
    }
    let r = reach.min(length / 3.0);
    let mut cuts = [0.0; MAX_CUTS];
    let mut n = 0;
    for i in 0..=SPLIT_LEVELS {
        let d = r / f64::from(1u32 << (SPLIT_LEVELS - i));
        if d >= least || i == SPLIT_LEVELS {
            cuts[n] = d;
            n += 1;
        }
    }
    if let Some(at) = inner_at.filter(|at| *at > r && 2.0 * at < length) {
        cuts[n] = at;
        n += 1;
    }
    for i in 0..n {
        cuts[n + i] = length - cuts[n - 1 - i];
    }
    Some((cuts, 2 * n))
}

/// The curvature vector of a move at its start or end (1/mm, towards the
/// centre): 0 for lines; for an arc its [`curvature`] along the in-plane
/// normal (a helix's principal normal lies in the plane).
pub fn curvature_vector(g: &Geom, at_end: bool) -> V3 {
    match g {
        Geom::Arc(a) if a.radius > 0.0 => {
            let p = if at_end { a.end } else { a.start };
            let (pa, qa, _) = a.plane.axes();
            let mut n = V3::zeros();
            n[pa] = a.center[pa] - p[pa];
            n[qa] = a.center[qa] - p[qa];
            let len = n.norm();
            if len > 0.0 {
                n * (curvature(g) / len)
            } else {
                V3::zeros()
            }
        }
        _ => V3::zeros(),
    }
}

impl JerkBudget {
    /// The largest path speed at which a junction whose unit tangent
    /// changes by `dt_turn` (norm; tangent or a fine kink) from curvature
    /// vector `k1` into `k2` keeps the step of the normal acceleration,
    /// the curvature's and the velocity jump's over one sample together,
    /// v²·|k1 − k2| + v·`dt_turn`/dt, within a quarter of `b_step` (0:
    /// none, or the move before is no arc). Under it the XYZ filter's
    /// window across the junction sees one curve (a chain of blend arcs, a
    /// circle programmed in quadrants): the arcs' insides' caps hold there
    /// with the step beside the turn and growth they allow
    /// ([`arc_caps`](Self::arc_caps)). At the top path speed or over, the
    /// arcs run as one curve as they are; under it, with a cap on the
    /// junction (held over the path filter's reach as any junction's), so
    /// that two arcs of a CAM curve whose curvatures differ by its
    /// rounding still do.
    pub fn curve_speed(&self, k1: &V3, k2: &V3, dt_turn: f64) -> f64 {
        if !self.limited() || k1.norm() <= 0.0 {
            return 0.0;
        }
        // A·v² + B·v ≤ q
        let (a, b, q) = ((k1 - k2).norm(), dt_turn / self.dt, 0.25 * self.b_step);
        if a > 0.0 {
            // (the positive root, in the form without cancellation)
            2.0 * q / (b + (b * b + 4.0 * a * q).sqrt())
        } else if b > 0.0 {
            q / b
        } else {
            f64::INFINITY
        }
    }
}

/// The curvature of a move (1/mm): 0 for lines; an arc's in-plane
/// curvature scaled by its plane fraction squared (a helix).
pub fn curvature(g: &Geom) -> f64 {
    match g {
        Geom::Line { .. } => 0.0,
        Geom::Arc(a) if a.radius > 0.0 => {
            let c = a.plane_fraction();
            c * c / a.radius
        }
        Geom::Arc(_) => 0.0,
    }
}

/// The moving average of the path length: the last M_s raw values, the
/// moves they may fall on (with the path length at their starts), and the
/// raw path speeds.
#[derive(Clone, Debug)]
pub(crate) struct PathFilter {
    s: Vec<f64>,
    speed: Vec<f64>,
    i: usize,
    /// (path length at the start, move): the moves the window reaches
    segs: VecDeque<(f64, Geom)>,
}

impl PathFilter {
    pub(crate) fn new(m: usize, s0: f64, at: V3) -> Self {
        let mut segs = VecDeque::with_capacity(16);
        segs.push_back((s0, Geom::Line { start: at, end: at }));
        PathFilter {
            s: vec![s0; m.max(1)],
            speed: vec![0.0; m.max(1)],
            i: 0,
            segs,
        }
    }

    /// Forgets the past: standing at `p`, path length `s0`.
    pub(crate) fn reset(&mut self, s0: f64, p: V3, v: f64) {
        self.s.fill(s0);
        self.speed.fill(v);
        self.segs.clear();
        self.segs.push_back((s0, Geom::Line { start: p, end: p }));
    }

    /// A move starts at path length `s0`.
    pub(crate) fn add_move(&mut self, s0: f64, g: Geom) {
        self.segs.push_back((s0, g));
    }

    /// Every slot holds the same path length.
    pub(crate) fn settled(&self) -> bool {
        self.s.iter().all(|x| *x == self.s[0])
    }

    /// Adds a raw path length and speed; the filtered position (`raw`
    /// itself once settled: exactly the raw point) and speed.
    pub(crate) fn push(&mut self, s: f64, v: f64, raw: V3) -> (V3, f64) {
        self.s[self.i] = s;
        self.speed[self.i] = v;
        self.i = (self.i + 1) % self.s.len();
        let n = self.s.len() as f64;
        let speed = self.speed.iter().sum::<f64>() / n;
        if self.settled() {
            return (raw, speed);
        }
        // the oldest value is the least (s never decreases): moves ending
        // before it are behind the window
        let oldest = self.s[self.i];
        // (the mean of the differences to the oldest, which are exact and
        // short: summed whole, path lengths of hundreds of mm rounded the
        // mean by 1e-11 mm, a sampled jerk of 0.1 mm/s³, where a line's
        // own filter meets the jerk limit exactly)
        let sf = oldest + self.s.iter().map(|x| x - oldest).sum::<f64>() / n;
        while self.segs.len() > 1 && self.segs[1].0 <= oldest.min(sf) {
            self.segs.pop_front();
        }
        let k = self.segs.partition_point(|(s0, _)| *s0 <= sf);
        let p = match self.segs.get(k.saturating_sub(1)) {
            Some((s0, g)) => g.eval(sf - s0),
            None => raw,
        };
        (p, speed)
    }
}

/// A moving average of the last M setpoints (and path speeds).
#[derive(Clone, Debug)]
pub(crate) struct Smoother {
    pos: Vec<V3>,
    speed: Vec<f64>,
    /// where the next sample goes
    i: usize,
}

impl Smoother {
    pub(crate) fn new(m: usize, at: V3) -> Self {
        Smoother {
            pos: vec![at; m.max(1)],
            speed: vec![0.0; m.max(1)],
            i: 0,
        }
    }

    /// Forgets the past: every slot holds `p` (bypassed samples).
    pub(crate) fn reset(&mut self, p: V3, v: f64) {
        self.pos.fill(p);
        self.speed.fill(v);
    }

    /// Adds a sample; the filtered position and speed. A full window of
    /// equal positions gives that position exactly.
    pub(crate) fn push(&mut self, p: V3, v: f64) -> (V3, f64) {
        self.pos[self.i] = p;
        self.speed[self.i] = v;
        self.i = (self.i + 1) % self.pos.len();
        let n = self.pos.len() as f64;
        let avg = if self.settled() {
            p
        } else {
            self.pos.iter().fold(V3::zeros(), |acc, q| acc + q) / n
        };
        (avg, self.speed.iter().sum::<f64>() / n)
    }

    /// Every slot holds the same position.
    pub(crate) fn settled(&self) -> bool {
        self.pos.iter().all(|q| *q == self.pos[0])
    }
}

#[cfg(test)]
mod tests;
