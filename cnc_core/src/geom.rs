//! Path geometry: lines and arcs (with an optional linear motion of the
//! plane's normal axis, i.e. helices). Positions are evaluated from the
//! geometry at a path parameter, never accumulated, and `eval(length)`
//! returns the programmed end point exactly.

use std::f64::consts::TAU;

/// A position or direction in machine coordinates (X, Y, Z), millimetres.
/// On a lathe X is the radius (the cross-slide position), never the diameter.
pub type V3 = nalgebra::Vector3<f64>;

/// The working plane: G17 XY, G18 ZX, G19 YZ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    XY,
    ZX,
    YZ,
}

impl Plane {
    /// (first axis, second axis, normal axis) indices; angles run from the
    /// first towards the second axis, counter-clockwise seen from +normal.
    #[inline]
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::XY => (0, 1, 2),
            Plane::ZX => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        }
    }
    pub fn gcode(self) -> &'static str {
        match self {
            Plane::XY => "G17",
            Plane::ZX => "G18",
            Plane::YZ => "G19",
        }
    }
}

/// A circular arc in a plane, optionally with a linear motion along the
/// plane normal (helix).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    pub start: V3,
    pub end: V3,
    /// centre (its normal-axis coordinate is meaningless)
    pub center: V3,
    pub plane: Plane,
    pub radius: f64,
    /// start angle, rad
    pub theta0: f64,
    /// signed sweep, rad (positive = counter-clockwise = G03)
    pub sweep: f64,
    /// travel along the normal axis over the whole arc
    pub axial: f64,
    /// path length (helix length)
    pub length: f64,
}

impl Arc {
    /// Builds an arc from start, end and centre. The centre is moved onto
    /// the perpendicular bisector of start and end so that both lie on one
    /// circle (the caller has checked the radius difference). `turns` adds
    /// whole extra revolutions. Start == end (in the plane) is a full circle.
    pub fn new(start: V3, end: V3, center: V3, plane: Plane, ccw: bool, turns: u32) -> Arc {
        let (p, q, n) = plane.axes();
        let (sx, sy) = (start[p], start[q]);
        let (ex, ey) = (end[p], end[q]);
        let (mut cx, mut cy) = (center[p], center[q]);
        let full = sx == ex && sy == ey;
        if !full {
            // project the centre onto the perpendicular bisector
            let (mx, my) = ((sx + ex) * 0.5, (sy + ey) * 0.5);
            let (dx, dy) = (ex - sx, ey - sy);
            let d2 = dx * dx + dy * dy;
            let t = ((cx - mx) * dx + (cy - my) * dy) / d2;
            cx -= t * dx;
            cy -= t * dy;
        }
        let radius = ((sx - cx).powi(2) + (sy - cy).powi(2)).sqrt();
        let theta0 = (sy - cy).atan2(sx - cx);
        let mut sweep = if full {
            TAU
        } else {
            let theta1 = (ey - cy).atan2(ex - cx);
            let d = theta1 - theta0;
            // Both directions are worked out and one is picked, and the
            // first turn of each loop is a select: programs mix G02 and G03
            // at random, so branches on them mispredict. The operations are
            // the same as in plain loops.
            let mut up = if d <= 0.0 { d + TAU } else { d };
            while up <= 0.0 {
                up += TAU;
            }
            while up > TAU {
                up -= TAU;
            }
            let mut down = if d >= 0.0 { d - TAU } else { d };
            while down >= 0.0 {
                down -= TAU;
            }
            while down < -TAU {
                down += TAU;
            }
            if ccw {
                up
            } else {
                -down
            }
        };
        sweep += TAU * turns as f64;
        sweep = if ccw { sweep } else { -sweep };
        let axial = end[n] - start[n];
        let plane_len = radius * sweep.abs();
        let length = (plane_len * plane_len + axial * axial).sqrt();
        let mut c = V3::zeros();
        c[p] = cx;
        c[q] = cy;
        c[n] = start[n];
        Arc {
            start,
            end,
            center: c,
            plane,
            radius,
            theta0,
            sweep,
            axial,
            length,
        }
    }

    /// Sets the signed sweep (rad) the caller knows (polar arcs), instead
    /// of the one inferred from the start and end angles; the length follows.
    pub fn set_sweep(&mut self, sweep: f64) {
        self.sweep = sweep;
        let plane_len = self.radius * sweep.abs();
        self.length = (plane_len * plane_len + self.axial * self.axial).sqrt();
    }

    /// Fraction of the in-plane speed in the path speed (1 for a flat arc).
    #[inline]
    pub fn plane_fraction(&self) -> f64 {
        if self.length == 0.0 {
            1.0
        } else {
            self.radius * self.sweep.abs() / self.length
        }
    }

    fn point(&self, frac: f64) -> V3 {
        let (p, q, n) = self.plane.axes();
        let th = self.theta0 + self.sweep * frac;
        let mut v = self.start;
        v[p] = self.center[p] + self.radius * th.cos();
        v[q] = self.center[q] + self.radius * th.sin();
        v[n] = self.start[n] + self.axial * frac;
        v
    }

    /// The unit tangent at `at`, a point on the arc (its start or end):
    /// the radius vector turned by a quarter in the sweep's sense, with the
    /// axial travel (no trigonometry: the point gives sin and cos).
    #[inline]
    fn tangent_at(&self, at: &V3) -> V3 {
        let (p, q, n) = self.plane.axes();
        let mut v = V3::zeros();
        v[p] = -self.sweep * (at[q] - self.center[q]);
        v[q] = self.sweep * (at[p] - self.center[p]);
        v[n] = self.axial;
        let l = v.norm();
        if l > 0.0 {
            v / l
        } else {
            v
        }
    }
}

/// One motion element.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Geom {
    Line { start: V3, end: V3 },
    Arc(Arc),
}

impl Geom {
    #[inline]
    pub fn start(&self) -> V3 {
        match self {
            Geom::Line { start, .. } => *start,
            Geom::Arc(a) => a.start,
        }
    }
    #[inline]
    pub fn end(&self) -> V3 {
        match self {
            Geom::Line { end, .. } => *end,
            Geom::Arc(a) => a.end,
        }
    }
    #[inline]
    pub fn length(&self) -> f64 {
        match self {
            Geom::Line { start, end } => (end - start).norm(),
            Geom::Arc(a) => a.length,
        }
    }

    /// The point at path length `s`; exactly the start at `s <= 0` and
    /// exactly the programmed end at `s >= length`.
    pub fn eval(&self, s: f64) -> V3 {
        let len = self.length();
        if s <= 0.0 {
            return self.start();
        }
        if s >= len {
            return self.end();
        }
        let f = s / len;
        match self {
            Geom::Line { start, end } => start + (end - start) * f,
            Geom::Arc(a) => a.point(f),
        }
    }

    /// The part from path length `d0` to `d1` (0 ≤ d0 < d1 ≤ length): the
    /// same line or circle, from `eval(d0)` to `eval(d1)`.
    pub fn piece(&self, d0: f64, d1: f64) -> Geom {
        let (start, end) = (self.eval(d0), self.eval(d1));
        match self {
            Geom::Line { .. } => Geom::Line { start, end },
            Geom::Arc(a) => {
                let (f0, f1) = if a.length > 0.0 {
                    (d0 / a.length, d1 / a.length)
                } else {
                    (0.0, 1.0)
                };
                Geom::Arc(Arc {
                    start,
                    end,
                    theta0: a.theta0 + a.sweep * f0,
                    sweep: a.sweep * (f1 - f0),
                    axial: a.axial * (f1 - f0),
                    length: a.length * (f1 - f0),
                    ..*a
                })
            }
        }
    }

    /// Unit tangent at the start.
    #[inline]
    pub fn start_tangent(&self) -> V3 {
        match self {
            Geom::Line { start, end } => (end - start).normalize(),
            Geom::Arc(a) => a.tangent_at(&a.start),
        }
    }

    /// Unit tangent at the end.
    #[inline]
    pub fn end_tangent(&self) -> V3 {
        match self {
            Geom::Line { start, end } => (end - start).normalize(),
            Geom::Arc(a) => a.tangent_at(&a.end),
        }
    }

    /// Axis-aligned bounding box (arc extremes included).
    pub fn bbox(&self) -> (V3, V3) {
        let (s, e) = (self.start(), self.end());
        let mut lo = s.inf(&e);
        let mut hi = s.sup(&e);
        if let Geom::Arc(a) = self {
            let (p, q, _) = a.plane.axes();
            // the arc reaches the extreme of axis p at angles 0 and pi, of q at pi/2, 3pi/2
            let (t0, t1) = if a.sweep >= 0.0 {
                (a.theta0, a.theta0 + a.sweep)
            } else {
                (a.theta0 + a.sweep, a.theta0)
            };
            for k in 0..4 {
                let ang = k as f64 * std::f64::consts::FRAC_PI_2;
                // the first multiple ang + m*2pi at or above t0
                let m = ceil((t0 - ang) / TAU);
                let first = ang + m * TAU;
                if first <= t1 {
                    let (axis, val) = match k {
                        0 => (p, a.center[p] + a.radius),
                        1 => (q, a.center[q] + a.radius),
                        2 => (p, a.center[p] - a.radius),
                        _ => (q, a.center[q] - a.radius),
                    };
                    lo[axis] = lo[axis].min(val);
                    hi[axis] = hi[axis].max(val);
                }
            }
        }
        (lo, hi)
    }
}

/// `x.ceil()` up to the sign of a zero result, without the library call
/// that `f64::ceil` becomes on baseline x86-64. Below 2^52 in magnitude the
/// cast to `i64` truncates exactly, and truncation plus one where it went
/// down is the ceiling; from 2^52 on every `f64` is whole already. Where
/// `ceil` gives -0.0 this gives +0.0: equal, and the callers only compare
/// it or add it (`ang + m * TAU` is the same for either zero; the tick
/// count is 0 for either).
#[inline]
pub(crate) fn ceil(x: f64) -> f64 {
    const WHOLE: f64 = 4_503_599_627_370_496.0; // 2^52
    if x.abs() < WHOLE {
        let t = x as i64 as f64;
        if t < x {
            t + 1.0
        } else {
            t
        }
    } else {
        x // whole, infinite or NaN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> V3 {
        V3::new(x, y, z)
    }

    #[test]
    fn quarter_arcs_in_all_planes() {
        // G17 CCW quarter from (10,0) to (0,10) about the origin
        let a = Arc::new(
            v(10., 0., 0.),
            v(0., 10., 0.),
            V3::zeros(),
            Plane::XY,
            true,
            0,
        );
        assert!((a.sweep - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((a.length - 5.0 * std::f64::consts::PI).abs() < 1e-12);
        // CW the long way round
        let b = Arc::new(
            v(10., 0., 0.),
            v(0., 10., 0.),
            V3::zeros(),
            Plane::XY,
            false,
            0,
        );
        assert!((b.sweep + 1.5 * std::f64::consts::PI).abs() < 1e-15);
        // G18: angle from Z towards X; CCW from (z=10) to (x=10)
        let c = Arc::new(
            v(0., 0., 10.),
            v(10., 0., 0.),
            V3::zeros(),
            Plane::ZX,
            true,
            0,
        );
        assert!((c.sweep - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let g = Geom::Arc(c);
        let mid = g.eval(g.length() / 2.0);
        assert!((mid - v(10. / 2f64.sqrt(), 0., 10. / 2f64.sqrt())).norm() < 1e-12);
        // G19: from Y towards Z
        let d = Arc::new(
            v(0., 10., 0.),
            v(0., 0., 10.),
            V3::zeros(),
            Plane::YZ,
            true,
            0,
        );
        assert!((d.sweep - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }

    /// The ends' tangents (from the radius vectors, no trigonometry) are
    /// the direction of travel: the chord to a point 10⁻⁷ of the length
    /// inside either end, in every plane, both senses, on a helix and a
    /// full circle with extra turns.
    #[test]
    fn end_tangents_are_the_direction_of_travel() {
        let cases = [
            (
                v(10., 0., 0.),
                v(0., 10., 0.),
                V3::zeros(),
                Plane::XY,
                true,
                0,
            ),
            (
                v(10., 0., 0.),
                v(0., 10., 0.),
                V3::zeros(),
                Plane::XY,
                false,
                0,
            ),
            (
                v(3., 4., -1.),
                v(-4., 3., 2.),
                V3::zeros(),
                Plane::XY,
                true,
                1,
            ),
            (
                v(0., 5., 10.),
                v(10., 5., 0.),
                v(0., 0., 0.),
                Plane::ZX,
                true,
                0,
            ),
            (
                v(0., 10., 0.),
                v(3., 0., 10.),
                V3::zeros(),
                Plane::YZ,
                false,
                0,
            ),
            (
                v(7., 2., 0.),
                v(7., 2., -3.),
                v(5., 2., 0.),
                Plane::XY,
                false,
                2,
            ),
        ];
        for (s, e, c, plane, ccw, turns) in cases {
            let g = Geom::Arc(Arc::new(s, e, c, plane, ccw, turns));
            let h = 1e-7 * g.length();
            let t0 = (g.eval(h) - g.start()).normalize();
            let t1 = (g.end() - g.eval(g.length() - h)).normalize();
            assert!((g.start_tangent() - t0).norm() < 1e-5, "{s} {e} {ccw}");
            assert!((g.end_tangent() - t1).norm() < 1e-5, "{s} {e} {ccw}");
            assert!((g.start_tangent().norm() - 1.0).abs() < 1e-15);
            assert!((g.end_tangent().norm() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn end_point_exact_and_full_circle() {
        let a = Arc::new(
            v(0., 0., 0.),
            v(0., 0., 1.05),
            v(100., 0., 0.),
            Plane::XY,
            false,
            0,
        );
        assert!((a.sweep + TAU).abs() < 1e-15);
        let g = Geom::Arc(a);
        assert_eq!(g.eval(g.length()), v(0., 0., 1.05));
        assert_eq!(g.eval(1e300), v(0., 0., 1.05));
        let half = g.eval(g.length() / 2.0);
        assert!((half - v(200., 0., 0.525)).norm() < 1e-9, "{half}");
    }

    #[test]
    fn bbox_includes_extremes() {
        // CW half circle from (0,0) to (200,0) about (100,0) passes (100,100)
        let g = Geom::Arc(Arc::new(
            v(0., 0., 0.),
            v(200., 0., 0.),
            v(100., 0., 0.),
            Plane::XY,
            false,
            0,
        ));
        let (lo, hi) = g.bbox();
        assert!((hi[1] - 100.0).abs() < 1e-12 && lo[1] == 0.0, "{lo} {hi}");
        let g = Geom::Arc(Arc::new(
            v(0., 0., 0.),
            v(200., 0., 0.),
            v(100., 0., 0.),
            Plane::XY,
            true,
            0,
        ));
        let (lo, _) = g.bbox();
        assert!((lo[1] + 100.0).abs() < 1e-12);
    }

    #[test]
    fn fast_ceil_equals_ceil() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.0 - f64::EPSILON,
            -1.0 + f64::EPSILON,
            2.5,
            -2.5,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for k in -2000..2000 {
            xs.push(k as f64 * 0.137);
            xs.push(k as f64 / TAU);
        }
        for x in xs {
            assert_eq!(ceil(x), x.ceil(), "{x}");
        }
        assert!(ceil(f64::NAN).is_nan());
    }

    #[test]
    fn centre_is_moved_onto_the_bisector() {
        // end radius 10.001 vs start radius 10: both must lie on the used circle
        let a = Arc::new(
            v(10., 0., 0.),
            v(0., 10.001, 0.),
            V3::zeros(),
            Plane::XY,
            true,
            0,
        );
        let (s, e) = (a.start - a.center, a.end - a.center);
        assert!((s.norm() - a.radius).abs() < 1e-12 && (e.norm() - a.radius).abs() < 1e-12);
    }
}
