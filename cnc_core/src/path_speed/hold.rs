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
        if self.arrived || self.halting {
            return;
        }
        self.halting = true;
        self.x = self.handed[2];
        self.out.clear();
        self.states.clear();
        self.need = 0;
        self.last = 0.0;
        let handed = self.handed;
        if let (Some(pt), Some((_, h))) = (point, self.sampled.as_mut()) {
            *h = Some(handed.map(|x| pt(x.s)));
        }
    }

    /// Ends a hold: the run goes on from where it stands.
    pub fn resume(&mut self) {
        self.halting = false;
    }

    /// Whether a hold is on.
    pub fn held(&self) -> bool {
        self.halting
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
    x: State,
    last: f64,
    arrived: bool,
    out: VecDeque<f64>,
    states: VecDeque<State>,
    handed: [State; 3],
    halting: bool,
    need: usize,
    sampled: Option<[[f64; 3]; 3]>,
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
        Snapshot {
            x: self.x,
            last: self.last,
            arrived: self.arrived,
            out: self.out.clone(),
            states: self.states.clone(),
            handed: self.handed,
            halting: self.halting,
            need: self.need,
            sampled: self.sampled.as_ref().and_then(|(_, h)| *h),
        }
    }

    /// Goes back to `snap`, taken of this planner (its stations from the
    /// first handed state on must still be kept: `keep_from`).
    pub fn restore(&mut self, snap: &Snapshot) {
        self.x = snap.x;
        self.last = snap.last;
        self.arrived = snap.arrived;
        self.out.clone_from(&snap.out);
        self.states.clone_from(&snap.states);
        self.handed = snap.handed;
        self.halting = snap.halting;
        self.need = snap.need;
        if let Some((_, h)) = self.sampled.as_mut() {
            *h = snap.sampled;
        }
    }

    /// The feed override from the next decision on: the programmed feed's
    /// share in every station's cap (the axes' and the curvature's caps
    /// stay). The samples decided stay; a state over the new caps brakes
    /// (the braking rule, as a hold) until it can go on under them.
    pub fn set_scale(&mut self, scale: f64) {
        if scale == self.scale || !(scale > 0.0 && scale.is_finite()) {
            return;
        }
        self.scale = scale;
        // every kept station's cap again, and its straight stretches
        let (base, n) = (self.path.base, self.path.count());
        self.open = None;
        for i in base..n {
            let st = *self.path.station(i);
            let c = self.v_cap(&st);
            self.caps[i - base] = c;
            self.clear[i - base] = (0.0, 0.0);
            self.group(i, &st, c);
        }
        if self.path.len().is_some() {
            if let Some((f, _)) = self.open.take() {
                self.close(f, n);
            }
        }
        self.need = 0;
    }

    /// Keeps the stations from path position `s` on (beside those behind
    /// the samples handed out), for a `restore` there; `None`: only those.
    pub fn keep_from(&mut self, s: Option<f64>) {
        self.keep = s;
    }
}
