//! A feed hold within a run: from the last sample handed out, the
//! braking rule to rest (a state the planner decided was viable, so the
//! braking keeps every limit and stops before the run's end), then rest
//! until the run resumes from there.

use super::{Planner, Point};

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
