//! The approach onto a speed cap.
//!
//! Each sample takes the largest jerk whose next state is viable; near a
//! speed cap (the feed, an axis's velocity, a curve's) that greedy choice
//! overshoots: it accelerates as long as braking in time is still
//! possible, then must brake, then may accelerate again, and the jerk
//! flips between large values of either sign sample after sample (seen on
//! bench/motion's CAM program: 5,947 sign changes of an axis's jerk above
//! a fifth of its limit at 50 m/s³). Each of those samples also costs a
//! search of several braking simulations. So the jerk a sample may take
//! is also bounded by an approach curve onto the lowest cap ahead: with
//! that, the speed reaches the cap as the acceleration reaches zero.

use super::{Bounds, Planner, State};

/// The share of the jerk the approach onto a speed cap is planned with,
/// and the bisection steps that find it.
const APPROACH_SHARE: f64 = 0.9;
const APPROACH_BISECT: usize = 40;

impl Planner {
    /// The largest jerk whose next state is on or under the approach onto
    /// the lowest speed cap a landing from `x` may pass (`c`): acceleration
    /// `√(2 J (c − v))` under it, `−√(2 J (v − c))` over it, `J` a share of
    /// the jerk `b` allows, so that the speed reaches the cap as the
    /// acceleration reaches zero. The greedy jerk alone overshoots that
    /// approach and then chatters about the cap, a search each sample.
    /// `∞` where it does not bind; `Err(n)` while the stations it needs
    /// have not come.
    pub(super) fn approach(&self, x: State, b: &Bounds) -> Result<f64, usize> {
        let jl = APPROACH_SHARE * b.s_hi.min(-b.s_lo);
        if !(jl > 0.0 && jl.is_finite()) {
            return Ok(f64::INFINITY);
        }
        let up = x.a.max(0.0);
        let t = up / jl + 2.0 * self.dt;
        let end = x.s + (x.v + up * up / (2.0 * jl)) * t;
        let n = (end.max(0.0) / self.path.h) as usize + 2;
        if !self.path.finished && n > self.path.count() {
            return Err(n);
        }
        let c = self.cap_over(x.s, end);
        // (in samples: a landing from `a` takes at most one sample more
        // than a/J, so the speed it takes is at most a²/2J + a dt/2)
        let half = 0.5 * jl * self.dt;
        let over = |sig: f64| {
            let y = x.step(sig, self.dt);
            let d = c - y.v;
            y.a - d.signum() * ((half * half + 2.0 * jl * d.abs()).sqrt() - half)
        };
        let (mut lo, mut hi) = (b.s_lo, b.s_hi);
        if over(hi) <= 0.0 {
            return Ok(f64::INFINITY);
        }
        if over(lo) > 0.0 {
            return Ok(lo);
        }
        for _ in 0..APPROACH_BISECT {
            let mid = 0.5 * (lo + hi);
            if over(mid) <= 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(lo)
    }
}
