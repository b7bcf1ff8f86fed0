//! The speed caps of the stations, and the straight stretches.
//!
//! Each station's cap is the lower of its hard cap (every axis's velocity
//! over its share of the tangent, the speed at which the curvature alone
//! takes an axis's whole acceleration, and the one at which it takes the
//! normal acceleration the machine allows for its drives' contour error,
//! `limit_normal_accel`) and its feed times the feed override in force.
//! A state the override has just put over the caps is not over a limit
//! of the axes: its brakings are checked under the override it was
//! decided under while it comes down (`soft_scale`).
//! Stations on a straight line with one cap are grouped into stretches,
//! so that a braking that certainly ends within one is not simulated
//! (`clearly_viable`).

use super::{Bounds, Planner, State, Station, A_MARGIN};

/// Curvature (1/mm) and its change (1/mm²) under this count as straight.
const STRAIGHT: f64 = 1e-6;
/// Caps within this share of each other count as one for `clear`.
const FLAT: f64 = 1e-6;

impl Planner {
    /// The largest normal acceleration (`|K| v²`) the path may take, mm/s²
    /// (`∞`, the default: none but the axes'): a cap of every station,
    /// those kept included.
    pub fn limit_normal_accel(&mut self, a: f64) {
        if a > 0.0 && a != self.a_normal {
            self.a_normal = a;
            let base = self.path.base;
            for i in base..self.path.count() {
                let st = *self.path.station(i);
                self.caps[i - base].0 = self.hard_cap(&st);
            }
            self.recap();
        }
    }

    /// The straight stretches of every kept station again, under its cap
    /// now (after the override or the normal acceleration changed); the
    /// next sample is tried anew.
    pub(super) fn recap(&mut self) {
        let (base, n) = (self.path.base, self.path.count());
        self.open = None;
        for i in base..n {
            let st = *self.path.station(i);
            let c = self.cap(i);
            self.clear[i - base] = (0.0, 0.0);
            self.group(i, &st, c);
        }
        if self.path.len().is_some() {
            if let Some((f, _)) = self.open.take() {
                self.close(f, n);
            }
        }
        self.d.need = 0;
    }

    /// Station `i` (`st`, cap `c`) into the straight stretches.
    pub(super) fn group(&mut self, i: usize, st: &Station, c: f64) {
        // stations are grouped into stretches that are straight (curvature
        // and its change under `STRAIGHT`) with caps within `FLAT` of the
        // stretch's first; a station that does not join the open stretch
        // closes it
        let starts = (!bent(st)).then_some((i, c));
        match self.open {
            Some((_, c0)) if !bent(st) && (c - c0).abs() <= FLAT * c0 => {}
            Some((f, _)) => {
                self.close(f, i);
                self.open = starts;
            }
            None => self.open = starts,
        }
    }

    /// Station `i`'s speed cap under the override in force.
    pub(super) fn cap(&self, i: usize) -> f64 {
        self.cap_at(i, self.scale)
    }

    /// Station `i`'s speed cap under the override `scale`.
    pub(super) fn cap_at(&self, i: usize, scale: f64) -> f64 {
        let (hard, feed) = self.caps[i - self.path.base];
        (feed * scale).min(hard)
    }

    /// The override a braking is checked under: the one in force, or a
    /// higher one the run's state is still coming down from (`commit`).
    pub(super) fn soft_scale(&self) -> f64 {
        self.d.ceiling.max(self.scale)
    }

    /// Closes the stretch of stations `f..j`: each gets the stretch's end
    /// (the last station's place: the interval after it is shared with a
    /// station outside) and the lowest cap from it to there.
    pub(super) fn close(&mut self, f: usize, j: usize) {
        let stop = self.path.place(j - 1);
        let mut low = f64::INFINITY;
        for k in (f.max(self.path.base)..j).rev() {
            low = low.min(self.cap(k));
            self.clear[k - self.path.base] = (stop, low);
        }
    }

    /// Whether braking from `x` (speed, acceleration; bounds `b` there) on
    /// a straight stretch certainly ends within it: an upper bound of its
    /// peak speed within the cap there, an upper bound of its length
    /// before `clear` and the end.
    pub(super) fn clearly_viable(&self, x: State, b: &Bounds, end: f64) -> bool {
        let i = ((x.s / self.path.h) as usize).clamp(self.path.base, self.path.count() - 1);
        let jm = -b.s_lo;
        let am = -b.a_lo * (1.0 - 2.0 * A_MARGIN);
        if !(jm > 0.0 && am > 0.0) {
            return false;
        }
        let up = x.a.max(0.0);
        let v_peak = x.v + up * up / (2.0 * jm);
        let t = up / jm + v_peak / am + 2.0 * am / jm + 20.0 * self.dt;
        let (stop, cap) = self.clear[i - self.path.base];
        v_peak <= cap && x.s + v_peak * t <= stop.min(end)
    }

    /// The lowest speed cap of the stations about the path from `s0` to
    /// `s1` (those of the intervals both ends are in, and all between).
    pub(super) fn cap_over(&self, s0: f64, s1: f64) -> f64 {
        self.cap_over_at(s0, s1, self.scale)
    }

    /// `cap_over` under the override `scale`.
    pub(super) fn cap_over_at(&self, s0: f64, s1: f64, scale: f64) -> f64 {
        let (base, n) = (self.path.base, self.path.count());
        let (lo, hi) = (s0.min(s1).max(0.0), s0.max(s1));
        let i0 = ((lo / self.path.h) as usize).clamp(base, n - 2);
        let i1 = (((hi / self.path.h) as usize) + 1).clamp(base, n - 1);
        // (the feed times a positive scale rounds monotonically: the least
        // of the products is the product of the least feed, bit for bit)
        let (hard, feed) = self
            .caps
            .range(i0 - base..=i1 - base)
            .fold((f64::INFINITY, f64::INFINITY), |(h, f), c| {
                (h.min(c.0), f.min(c.1))
            });
        (feed * scale).min(hard)
    }

    /// The speed cap at a station but the feed's: every axis's velocity,
    /// the speed at which the curvature alone takes an axis's whole
    /// acceleration, and the one at which it takes `limit_normal_accel`'s.
    pub(super) fn hard_cap(&self, g: &Station) -> f64 {
        let mut cap = f64::INFINITY;
        for i in 0..3 {
            let t = g.t[i].abs();
            if t > 1e-12 {
                cap = cap.min(self.lim.v[i] / t);
            }
            // the curvature's own acceleration within the axis's limit:
            // as a cap of the stations a sample passes (`cap_over`), it
            // holds where the curvature peaks between two samples
            let k = g.k[i].abs();
            if k > 1e-12 {
                cap = cap.min((self.lim.a[i] / k).sqrt());
            }
        }
        if self.a_normal.is_finite() {
            let k = (g.k[0] * g.k[0] + g.k[1] * g.k[1] + g.k[2] * g.k[2]).sqrt();
            if k > 1e-12 {
                cap = cap.min((self.a_normal / k).sqrt());
            }
        }
        cap
    }
}

/// Whether a station bends: curvature or its change over `STRAIGHT`.
fn bent(g: &Station) -> bool {
    g.k.iter().chain(g.kd.iter()).any(|c| c.abs() > STRAIGHT)
}
