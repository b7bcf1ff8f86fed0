//! What the planner may spend on a move and a junction: the axis limits
//! shared out ([`crate::shares`]) and, under a jerk limit, the caps of
//! [`crate::jerk`].

use crate::canon::Feed;
use crate::geom::{Geom, V3};
use crate::jerk::{curvature, JerkBudget};
use crate::machine::Machine;
use crate::shares::{ARC_NORMAL_MAX, KINK_SHARE, SMOOTH_SHARE};

/// Speed cap, path acceleration and geometric speed limit of a move
/// planned with one acceleration share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MoveLimits {
    /// speed cap at the programmed feed
    pub vcap: f64,
    /// path acceleration
    pub a: f64,
    /// speed cap at any feed, with acceleration `a` ([`Profile::vlim`])
    pub vlim: f64,
}

/// Length of the vector of the finite components of `v` (the axes a
/// machine has).
fn finite_norm(v: &V3) -> f64 {
    v.iter()
        .filter(|x| x.is_finite())
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
}

/// Planner settings derived from the machine file.
#[derive(Clone, Copy, Debug)]
pub struct PlanLimits {
    pub vmax: V3,
    pub amax: V3,
    pub dt: f64,
    pub exact_stop_cos: f64,
    pub lookahead: usize,
    /// the jerk budget: filters and caps ([`crate::jerk`])
    pub jerk: JerkBudget,
    /// the fastest path speed, every axis at its limit, mm/s
    pub top: f64,
    /// per axis, the largest change of the unit tangent at a junction
    /// that counts as smooth ([`SMOOTH_SHARE`] at the fastest speed)
    pub smooth_turn: V3,
}

impl PlanLimits {
    pub fn from_machine(m: &Machine) -> Self {
        let (vmax, amax, dt) = (m.vmax(), m.amax(), m.dt());
        // the fastest path speed: every axis at its limit
        let top = finite_norm(&vmax);
        PlanLimits {
            vmax,
            amax,
            dt,
            exact_stop_cos: m.planner.exact_stop_angle_deg.to_radians().cos(),
            lookahead: m.planner.lookahead_blocks,
            jerk: m.jerk_budget(),
            top,
            smooth_turn: amax.map(|a| SMOOTH_SHARE * a * dt / top),
        }
    }

    /// The largest path acceleration any move may have: every axis at its
    /// limit, mm/s².
    pub fn max_path_acceleration(&self) -> f64 {
        finite_norm(&self.amax)
    }

    /// The limits of a move of length `len` that may use `share` of every
    /// axis's acceleration. On an arc the centripetal part takes what the
    /// feed needs, up to [`ARC_NORMAL_MAX`]·share, and the tangential part
    /// the rest, so their vector sum stays under the share on every axis.
    #[inline]
    pub(crate) fn move_limits(&self, geom: &Geom, len: f64, feed: &Feed, share: f64) -> MoveLimits {
        let f = feed.speed_mm_s();
        match geom {
            Geom::Line { start, end } => {
                let mut vlim = f64::INFINITY;
                let mut a = f64::INFINITY;
                for i in 0..3 {
                    let u = (end[i] - start[i]).abs() / len;
                    if u > 0.0 {
                        vlim = vlim.min(self.vmax[i] / u);
                        a = a.min(share * self.amax[i] / u);
                    }
                }
                MoveLimits {
                    vcap: f.min(vlim),
                    a,
                    vlim,
                }
            }
            Geom::Arc(arc) => {
                let (p, q, n) = arc.plane.axes();
                let c = arc.plane_fraction();
                let h = if arc.length > 0.0 {
                    arc.axial.abs() / arc.length
                } else {
                    0.0
                };
                let apq = self.amax[p].min(self.amax[q]);
                let mut vgeo = self.vmax[p].min(self.vmax[q]) / c;
                if h > 0.0 {
                    vgeo = vgeo.min(self.vmax[n] / h);
                }
                // centripetal share the feed needs, and what is left
                let normal_max = ARC_NORMAL_MAX * share;
                let vc = f.min(vgeo) * c;
                let normal = (vc * vc / (apq * arc.radius)).min(normal_max);
                let centripetal = |k: f64| (k * apq * arc.radius).sqrt() / c;
                let mut a = (share * share - normal * normal).max(0.0).sqrt() * apq / c;
                if h > 0.0 {
                    a = a.min(share * self.amax[n] / h);
                }
                // with the tangential acceleration taken, the centripetal
                // share left for speeds over the feed
                let tangential = a * c / apq;
                let normal_left = (share * share - tangential * tangential)
                    .max(0.0)
                    .sqrt()
                    .min(normal_max)
                    .max(normal);
                // jerk: the normal acceleration and the turn of the
                // tangential one within their budgets
                let (vj, aj) = self.jerk.arc_caps(curvature(geom));
                MoveLimits {
                    vcap: f.min(vgeo).min(centripetal(normal)).min(vj),
                    a: a.min(aj),
                    vlim: vgeo.min(centripetal(normal_left)).min(vj),
                }
            }
        }
    }

    /// The junction from unit tangent `t1` into `t2`: its own speed limit
    /// (0: an exact stop; ∞: smooth) and whether it is a kink, a velocity
    /// jump that needs [`KINK_SHARE`] in both moves.
    #[inline]
    pub(crate) fn junction(&self, t1: &V3, t2: &V3) -> (f64, bool) {
        if t1.dot(t2) < self.exact_stop_cos {
            return (0.0, false);
        }
        let mut v = f64::INFINITY;
        let mut kink = false;
        for i in 0..3 {
            let d = (t2[i] - t1[i]).abs();
            if d > self.smooth_turn[i] {
                kink = true;
                v = v
                    .min(KINK_SHARE * self.amax[i] * self.dt / d)
                    .min(self.jerk.kink_cap(d));
            }
        }
        (v, kink)
    }
}
