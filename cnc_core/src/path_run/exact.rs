//! The stations of one move as programmed (a run under G61, a rapid): the
//! line's or helix's own tangent, curvature and its change.

use crate::geom::{Geom, V3};
use crate::path_speed::Station;

/// The station at `x` of one move as programmed.
pub(super) fn exact_station(geom: &Geom, x: f64, feed: f64) -> Station {
    let a = |v: V3| [v[0], v[1], v[2]];
    match geom {
        Geom::Line { start, end } => Station {
            t: a((end - start) / geom.length()),
            k: [0.0; 3],
            kd: [0.0; 3],
            feed,
        },
        Geom::Arc(arc) => {
            // the helix: angle θ0 + w s, w = sweep / length
            let (p, q, _) = arc.plane.axes();
            let w = arc.sweep / arc.length;
            let (sin, cos) = (arc.theta0 + w * x).sin_cos();
            let r = arc.radius;
            let mut t = [0.0; 3];
            let mut k = [0.0; 3];
            let mut kd = [0.0; 3];
            let n = 3 - p - q;
            t[p] = -r * w * sin;
            t[q] = r * w * cos;
            t[n] = arc.axial / arc.length;
            k[p] = -r * w * w * cos;
            k[q] = -r * w * w * sin;
            kd[p] = r * w * w * w * sin;
            kd[q] = -r * w * w * w * cos;
            Station { t, k, kd, feed }
        }
    }
}
