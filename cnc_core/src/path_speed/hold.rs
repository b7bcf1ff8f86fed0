//! A feed hold within a run: from the last sample handed out, the
//! braking rule to rest (a state the planner decided was viable, so the
//! braking keeps every limit and stops before the run's end), then rest
//! until the run resumes from there.

use super::{Planner, Point, State};
use std::collections::VecDeque;

impl Planner {
    /// Holds the run: the samples decided but not handed out are dropped,
    /// and the planner brakes from the last one handed out. `point`: the
    /// path's points, for the samples' own check. Near the run's end (its
    /// last braking decided) the run goes on to its end.
    pub fn hold(&mut self, point: Option<Point>) {
        if self.d.arrived || self.d.halting {
            return;
        }
        self.d.halting = true;
        self.d.x = self.d.handed[2];
        self.d.out.clear();
        self.d.states.clear();
        self.d.need = 0;
        self.d.last = 0.0;
        if let (Some(pt), Some(_)) = (point, self.sampled) {
            self.d.sampled = Some(self.d.handed.map(|x| pt(x.s)));
        }
    }

    /// Ends a hold: the run goes on from where it stands.
    pub fn resume(&mut self) {
        self.d.halting = false;
    }

    /// Whether a hold is on.
    pub fn held(&self) -> bool {
        self.d.halting
    }
}

/// What a planner has decided and handed out at one sample: restored
/// (`Planner::restore`), the planner goes on exactly as it went on from
/// there, as long as the stations it needs are kept (`keep_from`). A
/// planner working ahead of its samples' consumer keeps one per sample
/// not yet consumed, to take a feed hold or its end at the sample where
/// the consumer asked for it.
#[derive(Clone, Debug)]
pub struct Snapshot {
    /// Where the run is, the last sample's jerk, and whether it is over.
    pub(super) x: State,
    pub(super) last: f64,
    pub(super) arrived: bool,
    /// Samples held back (for the end's smooth step), oldest first, and
    /// their states.
    pub(super) out: VecDeque<f64>,
    pub(super) states: VecDeque<State>,
    /// The last three samples handed out, oldest first, and whether a feed
    /// hold brakes the run.
    pub(super) handed: [State; 3],
    pub(super) halting: bool,
    /// How many stations the last sample tried needed (no sample is
    /// tried again before they have come).
    pub(super) need: usize,
    /// For the samples' own check (`check_samples`): the last three
    /// positions decided (once the first is known).
    pub(super) sampled: Option<[[f64; 3]; 3]>,
    /// The feed override the last state was decided under, or a higher
    /// one it is still over the caps of a lower one from (`Planner::commit`).
    pub(super) ceiling: f64,
}

impl Snapshot {
    /// Whether no feed hold or its end changes the run from here on: it
    /// has its last braking decided and no hold is on.
    pub fn settled(&self) -> bool {
        self.arrived && !self.halting
    }

    /// Where the stations a `restore` to this needs start: the first of
    /// the last three samples handed out.
    pub fn needs_from(&self) -> f64 {
        self.handed[0].s
    }
}

impl Planner {
    /// The planner's state after the last sample handed out.
    pub fn snapshot(&self) -> Snapshot {
        self.d.clone()
    }

    /// Goes back to `snap`, taken of this planner (its stations from the
    /// first handed state on must still be kept: `keep_from`).
    pub fn restore(&mut self, snap: &Snapshot) {
        self.d.clone_from(snap);
    }

    /// The feed override from the next decision on: the programmed feed's
    /// share in every station's cap (the axes' and the curvature's caps
    /// stay). The samples decided stay; a state over the new caps comes
    /// down onto them by the approach (`approach.rs`), its brakings
    /// checked under the feed it was decided under until it is under them.
    pub fn set_scale(&mut self, scale: f64) {
        if scale == self.scale || !(scale > 0.0 && scale.is_finite()) {
            return;
        }
        self.scale = scale;
        self.recap();
    }

    /// Keeps the stations from path position `s` on (beside those behind
    /// the samples handed out), for a `restore` there; `None`: only those.
    pub fn keep_from(&mut self, s: Option<f64>) {
        self.keep = s;
    }
}
