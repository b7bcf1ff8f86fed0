//! The timeline: planned items on whole sample ticks (stops, the holds
//! after them, dwells and threads), shared by the executor and the check so
//! that the estimate equals the run to the tick.

use crate::canon::ThreadMove;
use crate::geom::ceil;
use crate::plan::{PlanLimits, PlannedMove};
use crate::profile::Profile;

/// Turns planned items into whole sample ticks. Motion that runs without a
/// stop forms a group; every group and dwell starts on a sample tick, so a
/// stop is sampled exactly at its end point. The executor and the check use
/// this same type, so the estimated cycle time equals the simulated one.
#[derive(Clone, Copy, Debug)]
pub struct Timeline {
    pub dt: f64,
    /// tick at which the current group started
    pub group_k0: u64,
    /// time from the group start to the start of the current move, s
    pub seg_t0: f64,
    /// the ideal spindle (turning exactly as commanded): rpm, and its
    /// angle in revolutions at tick `spin_k`
    pub spin_rpm: f64,
    pub spin_k: f64,
    pub spin_rev: f64,
    /// θ₀ of the thread block being run (revolutions, in the direction of
    /// rotation)
    pub theta0: f64,
    /// ticks the setpoints hold still after each stop, so that the jerk
    /// filters settle on the stop point (M_s + M_f − 2)
    pub hold: u64,
}

impl Timeline {
    pub fn new(dt: f64) -> Self {
        Timeline {
            dt,
            group_k0: 0,
            seg_t0: 0.0,
            spin_rpm: 0.0,
            spin_k: 0.0,
            spin_rev: 0.0,
            theta0: 0.0,
            hold: 0,
        }
    }

    /// The timeline of a planner with these limits (with its stop holds).
    pub fn for_limits(lim: &PlanLimits) -> Self {
        Timeline {
            hold: lim.jerk.hold_ticks(),
            ..Timeline::new(lim.dt)
        }
    }

    /// The jerk filters of the moves that follow changed (after a stop):
    /// the hold after their stops, ticks.
    pub(crate) fn set_hold(&mut self, ticks: u64) {
        self.hold = ticks;
    }

    /// Whole ticks covering `seconds` (a hair of rounding is forgiven).
    #[inline]
    pub fn ticks(&self, seconds: f64) -> u64 {
        let t = ceil(seconds / self.dt - 1e-9);
        if t > 0.0 {
            t as u64
        } else {
            0
        }
    }

    /// For a move that ends at rest: the tick of its end (the next group's start).
    pub fn stop_tick(&self, m: &PlannedMove) -> Option<u64> {
        (m.profile.v1 == 0.0).then(|| {
            self.group_k0.saturating_add(
                self.ticks(self.seg_t0 + self.lead(&m.profile) + m.profile.duration),
            )
        })
    }

    /// How long a move waits at its group's start, s: a line or an arc run
    /// from rest to rest under its own path filter of M samples, one tick.
    /// That filter's steps of the sampled jerk are the whole limit (a/M
    /// per sample), and the sampled jerk of the first step reaches back
    /// three samples: without the tick it would also hold the last step
    /// of the filters settling on the stop before.
    #[inline]
    fn lead(&self, p: &Profile) -> f64 {
        if p.own_filter().is_some() {
            self.dt
        } else {
            0.0
        }
    }

    /// Time of (virtual) tick `k` relative to the start of move `p` (the
    /// current one): [`local_time`](Self::local_time) less its
    /// [`lead`](Self::lead).
    #[inline]
    pub fn move_time(&self, k: f64, p: &Profile) -> f64 {
        self.local_time(k) - self.lead(p)
    }

    /// Time of (virtual) tick `k` relative to the start of the current move;
    /// `k` is the tick index unless the executor scales the feed.
    pub fn local_time(&self, k: f64) -> f64 {
        (k - self.group_k0 as f64) * self.dt - self.seg_t0
    }

    /// Advances past a finished move.
    pub fn finish_move(&mut self, m: &PlannedMove) {
        self.finish_profile(&m.profile);
    }

    /// Advances past a finished move with profile `p`.
    #[inline]
    pub(crate) fn finish_profile(&mut self, p: &Profile) {
        // as `stop_tick`, then the hold (a line or an arc run from rest to rest
        // with its own path filter of M samples: M, a tick more than the
        // filter takes to settle, for the same reason as its `lead`)
        if p.v1 == 0.0 {
            let hold = match p.own_filter() {
                Some(m) => u64::from(m),
                None => self.hold,
            };
            self.group_k0 = self
                .group_k0
                .saturating_add(self.ticks(self.seg_t0 + self.lead(p) + p.duration))
                .saturating_add(hold);
            self.seg_t0 = 0.0;
        } else {
            self.seg_t0 += p.duration;
        }
    }

    /// The ideal spindle's angle at (virtual) tick `k`, revolutions.
    pub fn ideal_rev(&self, k: f64) -> f64 {
        self.spin_rev + self.spin_rpm / 60.0 * (k - self.spin_k) * self.dt
    }

    /// The ideal spindle at (virtual) tick `k`, counted in direction `dir`
    /// (±1): its angle and the last index pulse it passed, revolutions. Its
    /// index pulses come at whole revolutions; after a reversal the angle
    /// so counted is below 0, where an index taken at 0 would be that many
    /// revolutions ahead.
    pub fn ideal_angle(&self, dir: f64, k: f64) -> (f64, f64) {
        let theta = dir * self.ideal_rev(k);
        (theta, theta.floor())
    }

    /// A spindle command at the current group tick (everything stopped).
    pub fn set_spindle(&mut self, rpm: f64) {
        let k = self.group_k0 as f64;
        self.spin_rev = self.ideal_rev(k);
        self.spin_k = k;
        self.spin_rpm = rpm;
    }

    /// θ₀ of thread block `m`: for a chain's first block, synchronized
    /// from the angle `now` with the index at `index`; otherwise where the
    /// block before ended on the thread line.
    pub fn thread_begin(&mut self, m: &ThreadMove, now: f64, index: f64) -> f64 {
        if m.runin.is_some() {
            self.theta0 = m.sync_angle(now, index);
        }
        self.theta0
    }

    /// After a thread block that is not the last of its chain.
    pub fn thread_next(&mut self, m: &ThreadMove) {
        self.theta0 += m.seg.len / m.seg.pitch;
    }

    /// With the ideal spindle: the tick at which the chain whose last block
    /// is `m` (θ₀ = `self.theta0`) ends at rest, the chain having started at
    /// the group tick.
    pub fn ideal_thread_end(&self, m: &ThreadMove) -> u64 {
        let dir = m.dir();
        let speed = dir * self.spin_rpm / 60.0 * self.dt; // rev per tick
        if speed <= 0.0 {
            return self.group_k0;
        }
        let now = dir * self.ideal_rev(self.group_k0 as f64);
        self.group_k0
            .saturating_add(self.ticks((self.theta0 + m.end_x() - now) / speed * self.dt))
    }

    /// A group (a thread chain) ended at rest at tick `k`; the next starts
    /// after the hold.
    pub fn finish_group_at(&mut self, k: u64) {
        self.group_k0 = k.saturating_add(self.hold);
        self.seg_t0 = 0.0;
    }

    /// Advances past thread block `m`, run with the ideal spindle.
    pub fn finish_thread(&mut self, m: &ThreadMove) {
        let (now, index) = self.ideal_angle(m.dir(), self.group_k0 as f64);
        self.thread_begin(m, now, index);
        if m.decel.is_some() {
            let k = self.ideal_thread_end(m);
            self.finish_group_at(k);
        } else {
            self.thread_next(m);
        }
    }

    /// Advances past a dwell starting at the current group tick.
    pub fn finish_dwell(&mut self, seconds: f64) {
        self.group_k0 = self.group_k0.saturating_add(self.ticks(seconds));
        self.seg_t0 = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_forgive_rounding() {
        let t = Timeline::new(0.001);
        assert_eq!(t.ticks(0.005), 5);
        assert_eq!(t.ticks(0.005 + 1e-15), 5);
        assert_eq!(t.ticks(0.0051), 6);
        assert_eq!(t.ticks(0.0), 0);
    }
}
