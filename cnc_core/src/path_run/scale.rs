//! The feed override under the path planner. An override asked after
//! step n takes effect at step n + `LATENCY` (0.1 s at 1 kHz): from there
//! each station's cap is the programmed feed times the override (the
//! axes' and the curvature's caps stay), and a state over the new caps
//! brakes by the braking rule until it can go on under them
//! (`Planner::set_scale`). The delay is what makes the samples the same
//! whether the runner works on the loop's thread or ahead of it on its own
//! (`Ahead`, at most `LATENCY` steps ahead): the step where it applies is
//! never worked out before the worker hears of it, so nothing is undone.
//! A feed hold, which must act at once, goes back instead; the override
//! given as a hold ends applies at once (the run stands: nothing to undo).

use super::Runner;
use std::collections::VecDeque;

/// Steps between an override asked and the step it applies at.
pub const LATENCY: u64 = 100;

/// The override in force, the changes to come, and those made (for a
/// rewind).
#[derive(Debug)]
pub(super) struct Override {
    pub scale: f64,
    /// the last asked (`set_scale`)
    asked: f64,
    /// steps handed out
    pub steps: u64,
    /// (step, scale): to come, oldest first; made, with the scale before
    pending: VecDeque<(u64, f64)>,
    made: Vec<(u64, f64, f64)>,
}

impl Default for Override {
    fn default() -> Self {
        Override {
            scale: 1.0,
            asked: 1.0,
            steps: 0,
            pending: VecDeque::new(),
            made: Vec::new(),
        }
    }
}

impl Runner {
    /// The feed override `scale` (a share of the programmed feed, over 0),
    /// asked now: from `LATENCY` steps on, for the run in progress and all
    /// that follow.
    pub fn set_scale(&mut self, scale: f64) {
        if scale != self.over.asked {
            self.over.asked = scale;
            self.scale_at(self.over.steps + LATENCY, scale);
        }
    }

    /// The feed override `scale` from step `at` on (`at` not yet handed
    /// out). Not positive or not finite: ignored.
    pub fn scale_at(&mut self, at: u64, scale: f64) {
        if scale > 0.0 && scale.is_finite() {
            self.over
                .pending
                .push_back((at.max(self.over.steps), scale));
        }
    }

    /// The end of a feed hold with the override `scale`: a run held in
    /// progress goes on from the next step at `scale` at once (it stands:
    /// nothing to undo); otherwise the hold's end as `hold(false)` and
    /// the override as `set_scale`.
    pub fn resume(&mut self, scale: f64) {
        let held = self.run.as_ref().is_some_and(|r| r.speed.held());
        self.hold(false);
        if held {
            self.scale_now(scale);
        } else {
            self.set_scale(scale);
        }
    }

    /// The override `scale` from the next step on (a run that stands).
    pub(super) fn scale_now(&mut self, scale: f64) {
        if !(scale > 0.0 && scale.is_finite()) {
            return;
        }
        self.over.asked = scale;
        self.over.pending.clear();
        let before = self.over.scale;
        self.over.made.push((self.over.steps, scale, before));
        self.set_runs_scale(scale);
    }

    /// Applies the overrides due at the next step.
    pub(super) fn apply_scale(&mut self) {
        while let Some(&(at, scale)) = self.over.pending.front() {
            if at > self.over.steps {
                break;
            }
            self.over.pending.pop_front();
            self.over.made.push((at, scale, self.over.scale));
            self.set_runs_scale(scale);
        }
    }

    fn set_runs_scale(&mut self, scale: f64) {
        self.over.scale = scale;
        for run in [self.run.as_mut(), self.next.as_mut()]
            .into_iter()
            .flatten()
        {
            run.speed.set_scale(scale);
        }
    }

    /// After going back to step `seq`: the overrides made after it are to
    /// come again, the one in force at step `seq + 1` is the runs'.
    pub(super) fn rewind_scale(&mut self, seq: u64) {
        self.over.steps = seq + 1;
        while let Some(&(at, scale, before)) = self.over.made.last() {
            if at <= self.over.steps {
                break;
            }
            self.over.made.pop();
            self.over.pending.push_front((at, scale));
            self.over.scale = before;
        }
        let scale = self.over.scale;
        self.set_runs_scale(scale);
    }
}
