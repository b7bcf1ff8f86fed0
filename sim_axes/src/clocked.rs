//! Setpoints applied at a clock instant rather than on arrival, as drives
//! in cyclic synchronous position mode on a distributed clock do: each
//! setpoint, stamped with the instant it is meant for, is applied `delay`
//! after that stamp, on the simulator's own step grid (interpolated
//! between the two setpoints around the step's instant minus the delay).
//! Transport latency below the delay then no longer moves the axes. While
//! a setpoint is late (not there at its instant) the axes go on at the
//! speed of the last two, as drives do over a missed frame, for at most
//! [`MAX_EXTRAPOLATION_NS`], then stop where that took them (never back
//! to the newest setpoint: a jump back of the speed times the time gone
//! on); the late setpoint is applied as soon as it arrives and counted.
//!
//! With a delay of 0 every setpoint is applied on arrival (the newest
//! one), as before clocked application existed.

use std::collections::VecDeque;

/// Setpoints kept waiting at most: at 20 kHz, 3.3 s (a controller whose
/// clock runs ahead fills it; the oldest are dropped).
pub const MAX_QUEUED: usize = 65_536;
/// How long the axes go on at their last speed while setpoints are late,
/// ns: as long as the controller goes on without encoder readings by
/// default (25 cycles of 1 ms). On a VM, setpoints have come 16 ms late
/// in a thread at constant speed; with 10 ms, and a jump back to the
/// newest setpoint after it, the axis then fell 12° of the spindle behind
/// and the controller rightly stopped the thread.
pub const MAX_EXTRAPOLATION_NS: i64 = 25_000_000;

/// Setpoints waiting for their instant.
#[derive(Debug, Clone)]
pub struct SetpointQueue {
    delay_ns: i64,
    queue: VecDeque<(i64, Vec<f64>)>,
    /// the setpoint before the queue's first (for the speed while late)
    prev: Option<(i64, Vec<f64>)>,
    /// what the last step applied (and what a new setpoint's missing
    /// joints keep)
    applied: Vec<f64>,
    /// the instant of the last step, ns
    applied_at: Option<i64>,
    late: u64,
}

impl SetpointQueue {
    /// Joints standing at `initial` (mm), setpoints applied `delay_ns`
    /// after their stamps (0 or less: on arrival).
    pub fn new(initial: Vec<f64>, delay_ns: i64) -> Self {
        SetpointQueue {
            delay_ns: delay_ns.max(0),
            queue: VecDeque::new(),
            prev: None,
            applied: initial,
            applied_at: None,
            late: 0,
        }
    }

    /// The delay, ns.
    pub fn delay_ns(&self) -> i64 {
        self.delay_ns
    }

    /// A new delay from the next step on (0 or less: on arrival).
    pub fn set_delay_ns(&mut self, delay_ns: i64) {
        self.delay_ns = delay_ns.max(0);
    }

    /// Setpoints that arrived after their instant (stamp + delay before
    /// the last step), since the start.
    pub fn late(&self) -> u64 {
        self.late
    }

    /// A setpoint stamped `stamp_ns`: `(joint, mm)` pairs; joints not named
    /// keep the value of the setpoint before it, non-finite values are
    /// ignored.
    pub fn push(&mut self, stamp_ns: i64, joints: impl IntoIterator<Item = (usize, f64)>) {
        // where it goes, in stamp order (normally at the end)
        let at = self.queue.partition_point(|(s, _)| *s <= stamp_ns);
        let mut p = match at.checked_sub(1).and_then(|i| self.queue.get(i)) {
            Some((_, prev)) => prev.clone(),
            None => self.applied.clone(),
        };
        for (j, v) in joints {
            if let (Some(slot), true) = (p.get_mut(j), v.is_finite()) {
                *slot = v;
            }
        }
        if let Some(t) = self.applied_at {
            if self.delay_ns > 0 && stamp_ns.saturating_add(self.delay_ns) < t {
                self.late += 1;
            }
        }
        match self.queue.get_mut(at.wrapping_sub(1)) {
            Some((s, q)) if *s == stamp_ns => *q = p,
            _ => self.queue.insert(at, (stamp_ns, p)),
        }
        while self.queue.len() > MAX_QUEUED {
            self.queue.pop_front();
        }
    }

    /// The setpoints for the step ending at `now_ns`, mm: the setpoint
    /// meant for `now − delay`, interpolated; the newest one when it has
    /// not arrived yet (or on arrival with delay 0); held when none is
    /// due.
    pub fn at(&mut self, now_ns: i64) -> &[f64] {
        self.applied_at = Some(now_ns);
        if self.delay_ns == 0 {
            if let Some((_, p)) = self.queue.drain(..).next_back() {
                self.applied = p;
            }
            return &self.applied;
        }
        let due = now_ns.saturating_sub(self.delay_ns);
        // keep one setpoint at or before `due`
        while self.queue.len() >= 2 && self.queue[1].0 <= due {
            self.prev = self.queue.pop_front();
        }
        match (self.queue.front(), self.queue.get(1)) {
            (Some((s0, p0)), Some((s1, p1))) if *s0 <= due => {
                let f = (due - s0) as f64 / (s1 - s0).max(1) as f64;
                for ((a, x0), x1) in self.applied.iter_mut().zip(p0).zip(p1) {
                    *a = x0 + f * (x1 - x0);
                }
            }
            (Some((s0, p0)), None) if *s0 <= due => {
                // the next one is late: on at the last speed for a while,
                // then stopped there
                match &self.prev {
                    Some((sp, pp)) if sp < s0 => {
                        let f = (due - s0).min(MAX_EXTRAPOLATION_NS) as f64 / (s0 - sp) as f64;
                        for ((a, x0), xp) in self.applied.iter_mut().zip(p0).zip(pp) {
                            *a = x0 + f * (x0 - xp);
                        }
                    }
                    _ => self.applied.clone_from(p0),
                }
            }
            _ => {}
        }
        &self.applied
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    #[test]
    fn setpoints_apply_at_their_stamp_plus_the_delay_interpolated() {
        let mut q = SetpointQueue::new(vec![0.0, 5.0], 3 * MS);
        // a ramp of 1 mm per ms on joint 0, stamped 1 ms apart
        for k in 0..10 {
            q.push(k * MS, [(0, k as f64)]);
        }
        // the step at 3.5 ms applies the setpoint for 0.5 ms
        assert_eq!(q.at(3 * MS + MS / 2), [0.5, 5.0]);
        assert_eq!(q.at(7 * MS + MS / 4), [4.25, 5.0]);
        assert_eq!(q.late(), 0);
        // past the newest: on at the last speed for 25 ms, then stopped
        // there (not back at the newest, 9)
        assert_eq!(q.at(14 * MS), [11.0, 5.0]);
        assert_eq!(q.at(37 * MS), [34.0, 5.0]);
        assert_eq!(q.at(40 * MS), [34.0, 5.0]);
        // what comes after its instant is late: applied at once, and on
        // from it at the last speed again for up to 25 ms
        q.push(10 * MS, [(0, 10.0), (1, f64::NAN)]);
        assert_eq!(q.late(), 1);
        assert_eq!(q.at(41 * MS), [35.0, 5.0]);
        // a longer delay from now on
        q.set_delay_ns(5 * MS);
        for k in 36..44 {
            q.push(k * MS, [(0, k as f64)]);
        }
        assert_eq!(q.at(45 * MS), [40.0, 5.0]);
        assert_eq!(q.late(), 1);
    }

    #[test]
    fn before_the_first_due_setpoint_the_joints_hold_and_zero_delay_is_on_arrival() {
        let mut q = SetpointQueue::new(vec![1.0], 3 * MS);
        q.push(10 * MS, [(0, 2.0)]);
        assert_eq!(q.at(11 * MS), [1.0]);
        assert_eq!(q.at(13 * MS), [2.0]);
        // out of order and repeated stamps are sorted in
        let mut q = SetpointQueue::new(vec![0.0], 2 * MS);
        q.push(2 * MS, [(0, 2.0)]);
        q.push(MS, [(0, 1.0)]);
        q.push(2 * MS, [(0, 4.0)]);
        assert_eq!(q.at(3 * MS + MS / 2), [2.5]);
        let mut q = SetpointQueue::new(vec![0.0], 0);
        q.push(100 * MS, [(0, 7.0)]);
        q.push(101 * MS, [(0, 8.0), (3, 1.0)]);
        assert_eq!(q.at(0), [8.0]);
        assert_eq!(q.late(), 0);
    }
}
