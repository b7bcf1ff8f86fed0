//! The shares of the acceleration the moves around a kink keep: the
//! queue's tail raised to its whole share once its exit is known to be
//! smooth, and, without setpoint filters, a kink's reserve in every move a
//! sample around the kink takes in. (A file of its own: plan.rs would be
//! over 800 lines.)
//!
//! A sample's acceleration (the second difference of the positions)
//! takes in the path within v·dt on either side of it, and a kink's
//! velocity jump fits in its reserve ([`KINK_SHARE`](crate::shares::KINK_SHARE), or
//! [`FINE_KINK_SHARE`](crate::shares::FINE_KINK_SHARE) at a fine kink) only where every move
//! in there keeps that reserve. The two moves that meet at the kink do;
//! where one of them is shorter than a sample's path, the move beyond it
//! must too. So the moves that start within 2·v·dt after a kink keep its
//! share, and the queued moves before a kink that still keep it must
//! cover 2·v·dt, or the kink's speed is capped so that they do. With a
//! setpoint filter the filter spreads a kink's jump over its window and
//! the planner's jerk caps keep it small: nothing here applies.

use super::Lookahead;
use crate::limits::Turn;

impl<K: Copy> Lookahead<K> {
    /// The queue's tail takes its whole acceleration (its exit junction is
    /// smooth or a stop), if its entry allows; its entry limits rise.
    pub(super) fn upgrade_tail(&mut self) {
        let n = self.queue.len();
        let Some(t) = self.queue.back_mut() else {
            return;
        };
        let Some((full, stop)) = t.full.take() else {
            return;
        };
        t.lim = full;
        t.stop = stop;
        t.level = t.full_level;
        t.j = t.j_max;
        if self.lim.jerk.limited() {
            // (both callers walk the queue again right after, `recompute`,
            // from a tail at least as far on: that walk reaches this move
            // and takes its new limits back as far as they change anything)
            return;
        }
        t.entry_b = t.entry_to_stop();
        // (the tail's own entry_b; the pass takes it from here)
        self.backward_pass(n - 1);
    }

    /// The speed cap `j` of a junction that turns as `turn`, lowered so
    /// that the queued moves before it that keep its reserve cover twice
    /// a sample's path at that speed.
    pub(super) fn reach_cap(&self, turn: Turn, j: f64) -> f64 {
        if turn == Turn::Smooth || self.lim.jerk.filtered() {
            return j;
        }
        let reach = self.kink_reach(j);
        let mut cover = 0.0;
        for s in self.queue.iter().rev() {
            // (a move raised over the kink's share ends the walk)
            if s.level < turn {
                break;
            }
            cover += s.length;
            if cover >= reach {
                return j;
            }
        }
        j.min(cover / (2.0 * self.lim.dt))
    }

    /// How far a kink passed at up to `j` mm/s reaches on either side: the
    /// path of two samples.
    fn kink_reach(&self, j: f64) -> f64 {
        2.0 * j.min(self.lim.top) * self.lim.dt
    }

    /// The share a move starting here may be raised to at most: that of a
    /// kink whose reach it starts in, else `turn`'s.
    pub(super) fn start_level(&self, turn: Turn) -> Turn {
        let within = if self.reach[0] > 0.0 {
            Turn::Kink
        } else if self.reach[1] > 0.0 {
            Turn::Fine
        } else {
            Turn::Smooth
        };
        turn.max(within)
    }

    /// Notes a junction that turns as `turn` at speed cap `j` before a
    /// move of `length` mm: the path since the last kink ([`Lookahead::since_turn`])
    /// and how far past this move each kink's reach still goes.
    pub(super) fn pass_junction(&mut self, turn: Turn, j: f64, length: f64) {
        self.since_turn = match turn {
            Turn::Smooth => self.since_turn + length,
            _ => length,
        };
        if self.lim.jerk.filtered() {
            return;
        }
        let reach = self.kink_reach(j);
        match turn {
            Turn::Kink => self.reach[0] = self.reach[0].max(reach),
            Turn::Fine => self.reach[1] = self.reach[1].max(reach),
            Turn::Smooth => {}
        }
        for r in &mut self.reach {
            *r = (*r - length).max(0.0);
        }
    }
}
