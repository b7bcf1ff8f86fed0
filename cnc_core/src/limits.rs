//! The planner's limits: its settings from the machine file, and what it
//! works out of one move alone (length, tangents, speed cap and
//! acceleration for both acceleration shares, and under a jerk limit the
//! caps of [`crate::jerk`]), apart from the look-ahead (`plan.rs`) so the
//! check can compute it on another thread.

use crate::canon::{Event, Feed};
use crate::geom::{Arc, Geom, V3};
use crate::jerk::{ArcPart, JerkBudget};
use crate::machine::Machine;
use crate::shares::{
    ARC_NORMAL_MAX, FINE_KINK_SHARE, FINE_SHARE, KINK_SHARE, LINE_SHARE, SMOOTH_SHARE,
};

/// Whether a move at `feed` may run from rest to rest with a path filter
/// of its own: not under G95, whose follow-up of the measured spindle is
/// documented and tested against the machine's filters' delay.
#[inline]
fn own_filter_allowed(feed: &Feed) -> bool {
    !matches!(feed, Feed::PerRev { .. })
}

/// Speed cap, path acceleration and geometric speed limit of a move
/// planned with one acceleration share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MoveLimits {
    /// speed cap at the programmed feed
    pub vcap: f64,
    /// path acceleration
    pub a: f64,
    /// speed cap at any feed, with acceleration `a`
    /// ([`Profile::vlim`](crate::profile::Profile::vlim))
    pub vlim: f64,
    /// a line or an arc under the path filter: the length of the path
    /// filter of its own that keeps its jerk, should it run from rest to
    /// rest ([`Profile::own_m`](crate::profile::Profile::own_m)); 0
    /// otherwise
    pub own_m: u32,
    /// an arc's curvature bound 1/r for that run, 1/mm (0: a line), for
    /// its speed cap then ([`PlanLimits::own_run`])
    pub own_kappa: f32,
}

/// What the planner needs of a move before it looks at its neighbours:
/// a function of the move and the limits alone, so whichever thread has
/// time may compute it (the same bits either way).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MovePrep {
    /// path length (a move of length 0 or less is skipped: the rest is
    /// then not computed)
    pub length: f64,
    /// unit tangents at the start and the end
    pub t_start: V3,
    pub t_end: V3,
    /// the limits with [`LINE_SHARE`] of the acceleration (next to a kink)
    pub red: MoveLimits,
    /// the limits with [`FINE_SHARE`] (next to a fine kink, no kink)
    pub fine: MoveLimits,
    /// the limits with the whole acceleration
    pub full: MoveLimits,
    /// with `red`, `fine` and `full`: the largest speed from which the
    /// move can stop over its length, √(2·a·length)
    pub stop: [f64; 3],
}

impl MovePrep {
    /// A move of length 0 or less (or NaN): skipped by the planner.
    fn skipped(length: f64) -> Self {
        let none = MoveLimits {
            vcap: 0.0,
            a: 0.0,
            vlim: 0.0,
            own_m: 0,
            own_kappa: 0.0,
        };
        MovePrep {
            length,
            t_start: V3::zeros(),
            t_end: V3::zeros(),
            red: none,
            fine: none,
            full: none,
            stop: [0.0; 3],
        }
    }
}

/// √(2·a·length) with each limits' acceleration.
#[inline]
fn stops(l: &[MoveLimits; 3], length: f64) -> [f64; 3] {
    l.map(|l| (2.0 * l.a * length).sqrt())
}

/// Length of the vector of the finite components of `v` (the axes a
/// machine has).
fn finite_norm(v: &V3) -> f64 {
    v.iter()
        .filter(|x| x.is_finite())
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
}

/// Planner settings derived from the machine file.
#[derive(Clone, Copy, Debug)]
pub struct PlanLimits {
    pub vmax: V3,
    pub amax: V3,
    pub dt: f64,
    pub exact_stop_cos: f64,
    pub lookahead: usize,
    /// the jerk budget: filters and caps ([`crate::jerk`])
    pub jerk: JerkBudget,
    /// the fastest path speed, every axis at its limit, mm/s
    pub top: f64,
    /// per axis, the largest change of the unit tangent at a junction
    /// that counts as smooth ([`SMOOTH_SHARE`] at the fastest speed)
    pub smooth_turn: V3,
    /// per axis, the largest change that counts as a fine kink
    /// ([`FINE_KINK_SHARE`] at the fastest speed)
    pub fine_turn: V3,
}

impl PlanLimits {
    pub fn from_machine(m: &Machine) -> Self {
        let (vmax, amax, dt) = (m.vmax(), m.amax(), m.dt());
        // the fastest path speed: every axis at its limit
        let top = finite_norm(&vmax);
        PlanLimits {
            vmax,
            amax,
            dt,
            exact_stop_cos: m.planner.exact_stop_angle_deg.to_radians().cos(),
            lookahead: m.planner.lookahead_blocks,
            jerk: m.jerk_budget(),
            top,
            smooth_turn: amax.map(|a| SMOOTH_SHARE * a * dt / top),
            fine_turn: amax.map(|a| FINE_KINK_SHARE * a * dt / top),
        }
    }

    /// The largest path acceleration any move may have: every axis at its
    /// limit, mm/s².
    pub fn max_path_acceleration(&self) -> f64 {
        finite_norm(&self.amax)
    }

    /// Length, tangents and the limits for both shares of a move. (A
    /// line's tangent is its difference divided by its norm, which is the
    /// length: what `normalize()` computes.) Without `vlim` an arc's
    /// [`MoveLimits::vlim`] is not computed (NaN): the check does not use
    /// it, unless there is a jerk limit (the planner caps its neighbours
    /// with it).
    #[inline]
    pub(crate) fn prepare(&self, geom: &Geom, feed: &Feed, vlim: bool) -> MovePrep {
        self.prepare_piece(geom, feed, vlim, ArcPart::End)
    }

    /// [`prepare`](Self::prepare), for `part` of an arc under a jerk
    /// limit ([`JerkBudget::arc_caps`]).
    #[inline]
    pub(crate) fn prepare_piece(
        &self,
        geom: &Geom,
        feed: &Feed,
        vlim: bool,
        part: ArcPart,
    ) -> MovePrep {
        let vlim = vlim || self.jerk.limited();
        let f = feed.speed_mm_s();
        match geom {
            Geom::Line { start, end } => {
                let d = end - start;
                let length = d.norm();
                if length <= 0.0 {
                    return MovePrep::skipped(length);
                }
                let t = d.unscale(length);
                // |d| / length per axis is |t| (a quotient's sign is exact)
                // (a G95 line keeps the machine's filters: the follow-up of
                // the measured spindle is documented and tested against
                // their delay)
                let own = own_filter_allowed(feed);
                let l = self.line_limits(&t.abs(), f, own);
                MovePrep {
                    length,
                    t_start: t,
                    t_end: t,
                    red: l[0],
                    fine: l[1],
                    full: l[2],
                    stop: stops(&l, length),
                }
            }
            Geom::Arc(arc) => {
                if arc.length <= 0.0 {
                    return MovePrep::skipped(arc.length);
                }
                let own = own_filter_allowed(feed);
                let l = self.arc_limits(arc, f, vlim, part, own);
                MovePrep {
                    length: arc.length,
                    t_start: geom.start_tangent(),
                    t_end: geom.end_tangent(),
                    red: l[0],
                    fine: l[1],
                    full: l[2],
                    stop: stops(&l, arc.length),
                }
            }
        }
    }

    /// Follows `ev` as the look-ahead does: a tolerance change
    /// ([`Event::Tolerance`]) changes the jerk budget of the moves after it.
    #[inline]
    pub(crate) fn follow(&mut self, ev: &Event) {
        if let Event::Tolerance { mm } = *ev {
            self.jerk = self.jerk.for_tolerance(mm);
        }
    }

    /// `prep` (what [`prepare`](Self::prepare) made of `geom`) with the
    /// jerk caps of `part` of an arc: its limits anew, its length and
    /// tangents as they are (a line's as it is, and an arc's beside a line
    /// when it is fed so slowly that it keeps the end's caps).
    pub(crate) fn repart(
        &self,
        prep: &MovePrep,
        geom: &Geom,
        feed: &Feed,
        part: ArcPart,
    ) -> MovePrep {
        let Geom::Arc(arc) = geom else {
            return *prep;
        };
        let f = feed.speed_mm_s();
        // (beside a line an arc fed at f with f²κ ≤ a_n keeps the end's
        // caps; κ ≤ 1/r)
        let slow = part == ArcPart::Beside && f * f <= self.jerk.a_n * arc.radius;
        if arc.length <= 0.0 || !self.jerk.limited() || slow {
            return *prep;
        }
        let own = own_filter_allowed(feed);
        let l = self.arc_limits(arc, f, true, part, own);
        MovePrep {
            red: l[0],
            fine: l[1],
            full: l[2],
            stop: stops(&l, arc.length),
            ..*prep
        }
    }

    /// `lim` of a move known to run from rest to rest under a path filter
    /// of its own (`lim.own_m` > 0), `length` long: a line's speed cap so
    /// that its cruise outlasts the filter ([`JerkBudget::own_peak_cap`]);
    /// an arc's also within [`JerkBudget::own_arc_cap`] (its speed limit
    /// for an override too), or, where that makes it slower than the
    /// machine's filters with their hold, those (`own_m` 0). `vlim`:
    /// whether the speed limit over the feed is wanted (the check's
    /// estimate does not read it, and it decides nothing here).
    #[inline]
    pub(crate) fn own_run(&self, mut lim: MoveLimits, length: f64, vlim: bool) -> MoveLimits {
        let jb = &self.jerk;
        let vcap = jb.own_peak_cap(lim.own_m, lim.a, length, lim.vcap);
        if lim.own_kappa <= 0.0 {
            lim.vcap = vcap;
            return lim;
        }
        // (the usual arc: its feed keeps 3·v·a·κ + v³·κ² within the share,
        // its cruise outlasts the filter, and the filter's ticks are fewer
        // than the machine filters' hold; no cube root, no choice)
        let kappa = f64::from(lim.own_kappa);
        if vcap == lim.vcap
            && jb.own_arc_keeps(kappa, lim.a, vcap)
            && u64::from(lim.own_m) < jb.hold_ticks()
        {
            if vlim && !jb.own_arc_keeps(kappa, lim.a, lim.vlim) {
                lim.vlim = jb.own_arc_cap(kappa, lim.a);
            }
            return lim;
        }
        let cap = jb.own_arc_cap(kappa, lim.a);
        let v = jb.own_peak_cap(lim.own_m, lim.a, length, lim.vcap.min(cap));
        // (rest to rest at peak v: its trapezoid and the ticks after it)
        let a = lim.a;
        let time = |v: f64, ticks: f64| {
            let v = v.min((a * length).sqrt());
            length / v + v / a + ticks * jb.dt
        };
        let own = time(v, f64::from(lim.own_m) + 1.0);
        if v > 0.0 && own < time(lim.vcap, jb.hold_ticks() as f64) {
            lim.vcap = v;
            lim.vlim = lim.vlim.min(cap);
        } else {
            lim.own_m = 0;
        }
        lim
    }

    /// A line's limits with [`LINE_SHARE`], [`FINE_SHARE`] and the whole acceleration:
    /// `u` holds |direction| per axis, `f` is the feed's speed. (What does
    /// not depend on the share is computed once.)
    #[inline]
    fn line_limits(&self, u: &V3, f: f64, own: bool) -> [MoveLimits; 3] {
        let mut vlim = f64::INFINITY;
        let mut a = [f64::INFINITY; 3];
        for i in 0..3 {
            let u = u[i];
            if u > 0.0 {
                vlim = vlim.min(self.vmax[i] / u);
                a[0] = a[0].min(LINE_SHARE * self.amax[i] / u);
                a[1] = a[1].min(FINE_SHARE * self.amax[i] / u);
                a[2] = a[2].min(1.0 * self.amax[i] / u);
            }
        }
        let own_m = if own {
            self.jerk.own_filter_samples(u, a[2])
        } else {
            0
        };
        let limits = |a: f64| MoveLimits {
            vcap: f.min(vlim),
            a,
            vlim,
            own_m,
            own_kappa: 0.0,
        };
        a.map(limits)
    }

    /// An arc's limits with [`LINE_SHARE`], [`FINE_SHARE`] and the whole acceleration, `f`
    /// the feed's speed; `vlim` as at [`prepare`](Self::prepare). On an
    /// arc the centripetal part takes what the feed needs, up to
    /// [`ARC_NORMAL_MAX`]·share, and the tangential part the rest, so
    /// their vector sum stays under the share on every axis.
    #[inline]
    fn arc_limits(
        &self,
        arc: &Arc,
        f: f64,
        vlim: bool,
        part: ArcPart,
        own: bool,
    ) -> [MoveLimits; 3] {
        let mut l = self.arc_limits_filtered(arc, f, vlim, part);
        // (run from rest to rest: a path filter of its own, sized for the
        // whole tangential acceleration, and the curvature for its speed
        // cap then; `as f32` rounded up, it stays a bound)
        let own_m = if own && arc.radius > 0.0 {
            self.jerk.own_arc_samples(l[2].a)
        } else {
            0
        };
        if own_m > 0 {
            let kappa = (1.0 / arc.radius * (1.0 + 1e-6)) as f32;
            if kappa.is_finite() {
                for x in &mut l {
                    x.own_m = own_m;
                    x.own_kappa = kappa;
                }
            }
        }
        l
    }

    /// [`arc_limits`](Self::arc_limits) under the machine's filters, with
    /// no filter of its own.
    #[inline]
    fn arc_limits_filtered(&self, arc: &Arc, f: f64, vlim: bool, part: ArcPart) -> [MoveLimits; 3] {
        // A flat arc's length is its length in the plane, r·|sweep|, and
        // its plane fraction r·|sweep| / length is then exactly 1: the
        // limits with the literal 1, which the compiler takes out of its
        // divisions and products (x / 1 and x · 1 are x), and no axial
        // fraction |axial| / length (0).
        let plane_len = arc.radius * arc.sweep.abs();
        if arc.axial == 0.0 && arc.length == plane_len && plane_len.is_finite() && plane_len != 0.0
        {
            self.arc_limits_with(arc, f, vlim, part, 1.0, 0.0)
        } else {
            let h = if arc.length > 0.0 {
                arc.axial.abs() / arc.length
            } else {
                0.0
            };
            self.arc_limits_with(arc, f, vlim, part, arc.plane_fraction(), h)
        }
    }

    /// [`arc_limits`](Self::arc_limits) with the arc's plane fraction `c`
    /// and axial fraction `h`.
    #[inline(always)]
    fn arc_limits_with(
        &self,
        arc: &Arc,
        f: f64,
        vlim: bool,
        part: ArcPart,
        c: f64,
        h: f64,
    ) -> [MoveLimits; 3] {
        let (p, q, n) = arc.plane.axes();
        let apq = self.amax[p].min(self.amax[q]);
        let mut vgeo = self.vmax[p].min(self.vmax[q]) / c;
        if h > 0.0 {
            vgeo = vgeo.min(self.vmax[n] / h);
        }
        // centripetal share the feed needs, and what is left
        let vc = f.min(vgeo) * c;
        let needed = vc * vc / (apq * arc.radius);
        let centripetal = |k: f64| (k * apq * arc.radius).sqrt() / c;
        // jerk: the normal acceleration and the turn of the tangential one
        // within their budgets (the curvature of a helix is c²/r)
        let (vj, aj) = if self.jerk.limited() {
            let kappa = if arc.radius > 0.0 {
                c * c / arc.radius
            } else {
                0.0
            };
            // (beside a line no faster than its feed: an override over
            // 100 % has no more room than at the end's caps)
            self.jerk.arc_caps_below(kappa, part, f.min(vgeo))
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        let limits = |share: f64| {
            let normal_max = ARC_NORMAL_MAX * share;
            let normal = needed.min(normal_max);
            let mut a = (share * share - normal * normal).max(0.0).sqrt() * apq / c;
            if h > 0.0 {
                a = a.min(share * self.amax[n] / h);
            }
            // with the tangential acceleration taken, the centripetal
            // share left for speeds over the feed
            let vlim = if vlim {
                let tangential = a * c / apq;
                let normal_left = (share * share - tangential * tangential)
                    .max(0.0)
                    .sqrt()
                    .min(normal_max)
                    .max(normal);
                vgeo.min(centripetal(normal_left)).min(vj)
            } else {
                f64::NAN
            };
            MoveLimits {
                vcap: f.min(vgeo).min(centripetal(normal)).min(vj),
                a: a.min(aj),
                vlim,
                own_m: 0,
                own_kappa: 0.0,
            }
        };
        [limits(LINE_SHARE), limits(FINE_SHARE), limits(1.0)]
    }

    /// The junction from unit tangent `t1` into `t2`: its own speed limit
    /// (0: an exact stop; ∞: smooth) and what it asks of the moves that
    /// meet there ([`Turn`]).
    #[inline]
    pub(crate) fn junction(&self, t1: &V3, t2: &V3) -> (f64, Turn) {
        self.spaced_junction(t1, t2, f64::INFINITY)
    }

    /// [`junction`](Self::junction) with `gap`, the path length (mm) to
    /// the nearest other junction that may turn: kinks closer than a
    /// sample's path share its reserve ([`spaced_cap`]).
    #[inline]
    pub(crate) fn spaced_junction(&self, t1: &V3, t2: &V3, gap: f64) -> (f64, Turn) {
        if t1.dot(t2) < self.exact_stop_cos {
            return (0.0, Turn::Smooth);
        }
        let mut v = f64::INFINITY;
        let mut turn = Turn::Smooth;
        for i in 0..3 {
            let d = (t2[i] - t1[i]).abs();
            if d > self.smooth_turn[i] {
                let share = if d <= self.fine_turn[i] {
                    turn = turn.max(Turn::Fine);
                    FINE_KINK_SHARE
                } else {
                    turn = Turn::Kink;
                    KINK_SHARE
                };
                v = v
                    .min(spaced_cap(share * self.amax[i] * self.dt / d, gap, self.dt))
                    .min(spaced_cap(self.jerk.kink_cap(d), gap, self.dt));
            }
        }
        // (a fine kink's own limit is the fastest path speed or more: only
        // the jerk caps it, and kinks that crowd a sample)
        (v, turn)
    }
}

/// A kink's speed cap `cap` (its velocity jump over one sample within a
/// reserve), for kinks `gap` mm or more apart. A sample's acceleration (the
/// second difference of the positions) weighs each kink's jump by a tent of
/// half-width v·dt about the sample; kinks at least v·dt apart have weights
/// that sum to 1 at most, so up to the speed gap/dt `cap` holds as it is.
/// Faster, several kinks' jumps fall in one sample: with each jump within
/// gap/(gap + v·dt) of the reserve they add up to the reserve at most
/// (evenly spaced kinks' weights sum to 1 + v·dt/gap at most; uneven ones:
/// `dense_polylines_keep_every_limit`, `tests/wild.rs`), so
/// v·(gap + v·dt) ≤ cap·gap; the cap is the larger of the two speeds.
#[inline]
pub(crate) fn spaced_cap(cap: f64, gap: f64, dt: f64) -> f64 {
    if !cap.is_finite() || cap * dt <= gap {
        return cap;
    }
    // (the root of dt·v² + gap·v − cap·gap, in its stable form)
    let crowded = 2.0 * cap * gap / (gap + (gap * gap + 4.0 * dt * cap * gap).sqrt());
    crowded.max(gap / dt)
}

/// What a junction asks of the moves that meet there.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Turn {
    /// tangent (within rounding): the moves may take their whole
    /// acceleration
    Smooth,
    /// a velocity jump within [`FINE_KINK_SHARE`] at any speed: the
    /// moves keep [`FINE_SHARE`]
    Fine,
    /// a velocity jump that needs [`KINK_SHARE`]: the moves keep
    /// [`LINE_SHARE`]
    Kink,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Arc, Plane};

    /// The limits for one share as the planner computed them before they
    /// were prepared for both shares at once.
    fn one_share(lim: &PlanLimits, geom: &Geom, len: f64, feed: &Feed, share: f64) -> MoveLimits {
        let f = feed.speed_mm_s();
        match geom {
            Geom::Line { start, end } => {
                let mut vlim = f64::INFINITY;
                let mut a = f64::INFINITY;
                for i in 0..3 {
                    let u = (end[i] - start[i]).abs() / len;
                    if u > 0.0 {
                        vlim = vlim.min(lim.vmax[i] / u);
                        a = a.min(share * lim.amax[i] / u);
                    }
                }
                MoveLimits {
                    vcap: f.min(vlim),
                    a,
                    vlim,
                    own_m: 0,
                    own_kappa: 0.0,
                }
            }
            Geom::Arc(arc) => {
                let (p, q, n) = arc.plane.axes();
                let c = arc.plane_fraction();
                let h = if arc.length > 0.0 {
                    arc.axial.abs() / arc.length
                } else {
                    0.0
                };
                let apq = lim.amax[p].min(lim.amax[q]);
                let mut vgeo = lim.vmax[p].min(lim.vmax[q]) / c;
                if h > 0.0 {
                    vgeo = vgeo.min(lim.vmax[n] / h);
                }
                let normal_max = ARC_NORMAL_MAX * share;
                let vc = f.min(vgeo) * c;
                let normal = (vc * vc / (apq * arc.radius)).min(normal_max);
                let centripetal = |k: f64| (k * apq * arc.radius).sqrt() / c;
                let mut a = (share * share - normal * normal).max(0.0).sqrt() * apq / c;
                if h > 0.0 {
                    a = a.min(share * lim.amax[n] / h);
                }
                let tangential = a * c / apq;
                let normal_left = (share * share - tangential * tangential)
                    .max(0.0)
                    .sqrt()
                    .min(normal_max)
                    .max(normal);
                MoveLimits {
                    vcap: f.min(vgeo).min(centripetal(normal)),
                    a,
                    vlim: vgeo.min(centripetal(normal_left)),
                    own_m: 0,
                    own_kappa: 0.0,
                }
            }
        }
    }

    #[test]
    fn prepared_moves_are_each_share_bit_for_bit() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || (crate::xorshift64(&mut x) >> 11) as f64 / (1u64 << 53) as f64;
        let mut flat = 0;
        for m in [Machine::builtin_mill(), Machine::builtin_lathe()] {
            // (the shares alone: no jerk caps)
            let lim = PlanLimits {
                jerk: JerkBudget::none(m.dt()),
                ..PlanLimits::from_machine(&m)
            };
            for k in 0..20_000 {
                let start = V3::new(next() * 100.0, next() * 100.0, next() * 20.0);
                let mut end = V3::new(next() * 100.0, next() * 100.0, next() * 20.0);
                // axis-parallel and flat moves too
                for i in 0..3 {
                    if k % (i + 2) == 0 {
                        end[i] = start[i];
                    }
                }
                let feed = match k % 4 {
                    0 => Feed::Rapid,
                    1 => Feed::PerMin(next() * 20_000.0),
                    2 => Feed::PerRev {
                        mm_per_rev: next(),
                        rpm: next() * 3000.0,
                    },
                    _ => Feed::PerMin(next() * 100.0),
                };
                let plane = [Plane::XY, Plane::ZX, Plane::YZ][k % 3];
                let (p, q, _) = plane.axes();
                let mut center = start;
                center[p] += next() * 10.0 - 5.0;
                center[q] += next() * 10.0 - 5.0;
                let arc = Arc::new(start, end, center, plane, k % 2 == 0, (k % 5 == 0) as u32);
                // (flat arcs take their own way through the limits)
                flat += (arc.axial == 0.0 && arc.length == arc.radius * arc.sweep.abs()) as usize;
                for geom in [Geom::Line { start, end }, Geom::Arc(arc)] {
                    let len = geom.length();
                    let want = [LINE_SHARE, FINE_SHARE, 1.0]
                        .map(|s| one_share(&lim, &geom, len, &feed, s));
                    let p = lim.prepare(&geom, &feed, true);
                    if len.is_nan() || len <= 0.0 {
                        // skipped by the planner: nothing else counts
                        assert_eq!(p.length.to_bits(), len.to_bits());
                        continue;
                    }
                    let got = (
                        p.length,
                        p.t_start,
                        p.t_end,
                        [p.red, p.fine, p.full],
                        p.stop,
                    );
                    let stop = want.map(|l| (2.0 * l.a * len).sqrt());
                    let want = (len, geom.start_tangent(), geom.end_tangent(), want, stop);
                    assert_eq!(format!("{got:?}"), format!("{want:?}"), "{geom:?} {feed:?}");
                    // without the speed limit over the feed: the rest the same
                    let q = lim.prepare(&geom, &feed, false);
                    for (q, p) in [(q.red, p.red), (q.fine, p.fine), (q.full, p.full)] {
                        assert_eq!(
                            format!("{:?}", (q.vcap, q.a)),
                            format!("{:?}", (p.vcap, p.a))
                        );
                    }
                }
            }
        }
        assert!(flat > 1000, "{flat} flat arcs");
    }

    #[test]
    fn kinks_closer_than_a_sample_share_its_reserve() {
        let dt = 0.001;
        // far apart, or no cap: the cap as it is
        assert_eq!(spaced_cap(15.0, f64::INFINITY, dt), 15.0);
        assert_eq!(spaced_cap(15.0, 0.015, dt), 15.0);
        assert_eq!(spaced_cap(f64::INFINITY, 0.001, dt), f64::INFINITY);
        // 10 µm apart, a cap of 15 mm/s (15 µm a sample): the kinks a
        // sample apart, 10 mm/s, is faster than the root of v·(gap + v·dt)
        // = cap·gap, 8.229 mm/s
        assert_eq!(spaced_cap(15.0, 0.01, dt), 10.0);
        // 1 µm apart, a cap of 30 mm/s: the root, 5 mm/s (v² + v = 30), at
        // which each jump is within 1/6 of the reserve
        let v = spaced_cap(30.0, 0.001, dt);
        assert!((v - 5.0).abs() < 1e-12, "{v}");
        // 50 µm apart, 1000 mm/s: 200 mm/s (v² + 50·v = 50,000)
        let v = spaced_cap(1000.0, 0.05, dt);
        assert!((v - 200.0).abs() < 1e-9, "{v}");
    }
}
