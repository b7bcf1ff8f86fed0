//! The samples' own check: each sample's second and third differences on
//! the path's points, within the machine's limits (the planner keeps a
//! margin under them, and its stations are the path's derivatives at
//! grid points, linear between).

use super::{AxisLimits, Planner, Point, State, Verdict, SAMPLED_TRIES};

impl Planner {
    /// Checks every sample (`next_sample_on`) on the points themselves:
    /// the second and third differences of each axis's positions within
    /// `lim` (the machine's own limits; the planner keeps a margin under
    /// them). Where the jerk the planner chose does not keep them (the
    /// stations are the path's derivatives at grid points, linear between:
    /// a narrow blend's curvature may peak between two samples), the
    /// largest of a few lower ones down to the braking rule's that keeps
    /// them and stays viable is taken instead; none does: the planner's.
    pub fn check_samples(&mut self, lim: AxisLimits) {
        self.sampled = Some(lim);
        self.d.sampled = None;
    }

    /// The jerk for the next sample under the samples' own check (see
    /// `check_samples`): `sig` the planner's, `safe` the braking rule's.
    pub(super) fn sampled_choice(&self, x: State, sig: f64, safe: f64, pt: Point) -> f64 {
        let (Some(lim), Some(h)) = (self.sampled, self.d.sampled) else {
            return sig;
        };
        let dt = self.dt;
        let fits = |sg: f64| {
            let p1 = pt(x.step(sg, dt).s);
            (0..3).all(|i| {
                let a = (p1[i] - 2.0 * h[2][i] + h[1][i]) / (dt * dt);
                let j = (p1[i] - 3.0 * h[2][i] + 3.0 * h[1][i] - h[0][i]) / (dt * dt * dt);
                a.abs() <= lim.a[i] && j.abs() <= lim.j[i]
            })
        };
        if fits(sig) {
            return sig;
        }
        for f in SAMPLED_TRIES {
            let c = sig + (safe - sig) * f;
            if fits(c) && self.viable(x.s, x.step(c, dt), c) == Verdict::Yes {
                return c;
            }
        }
        sig
    }
}
