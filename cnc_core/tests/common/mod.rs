//! The distance oracle of the compensation tests: distances from a point
//! to the *programmed* contour's lines and arcs, computed here, not by the
//! offset code.
#![allow(dead_code)]

use cnc_core::exec::Sample;
use cnc_core::Machine;
use std::borrow::Borrow;

/// `m` without its jerk limits: tests that measure the interpolated or
/// compensated path itself to 1e-6 mm or better run without the jerk
/// filter, which moves it by up to `Machine::smoothing_error_mm` (bounded
/// for every path in props.rs).
pub fn exact(m: &Machine) -> Machine {
    let mut m = m.clone();
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = None;
    }
    m
}

/// How far the XYZ jerk filter (M samples) may pull sample `i` of `s`
/// inside a circle of radius `r`: v²(M²−1)dt²/(24 r), with v the fastest
/// path speed among the samples it averages (1 % and 1 nm in hand). The
/// path filter keeps the setpoint on the circle.
pub fn filter_shrink<T: Borrow<Sample>>(m: &Machine, s: &[T], i: usize, r: f64) -> f64 {
    let mm = m.jerk_budget().m_f;
    let v = s[i + 1 - mm..(i + mm).min(s.len())]
        .iter()
        .map(|x| x.borrow().path_speed)
        .fold(0.0, f64::max);
    v * v * ((mm * mm - 1) as f64) * m.dt() * m.dt() / (24.0 * r) * 1.01 + 1e-9
}

/// A contour element in the plane's (p, q) coordinates.
#[derive(Clone, Copy, Debug)]
pub enum El {
    Line((f64, f64), (f64, f64)),
    /// centre, radius, start angle, signed sweep (rad)
    Arc((f64, f64), f64, f64, f64),
}

/// Distance from `pt` to the element, and the side: > 0 left of the
/// direction of travel, < 0 right.
pub fn dist(el: &El, pt: (f64, f64)) -> (f64, f64) {
    let (d, side, _) = dist_inner(el, pt);
    (d, side)
}

/// Distance to the contour, and the side of the nearest element.
pub fn to_contour(contour: &[El], pt: (f64, f64)) -> (f64, f64) {
    contour
        .iter()
        .map(|e| dist(e, pt))
        .fold((f64::MAX, 0.0), |b, x| if x.0 < b.0 { x } else { b })
}

/// As [`dist`], and whether the nearest point is inside the element (not
/// one of its end points, where the side is not defined).
pub fn dist_inner(el: &El, pt: (f64, f64)) -> (f64, f64, bool) {
    match *el {
        El::Line(a, b) => {
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let l2 = dx * dx + dy * dy;
            let t = ((pt.0 - a.0) * dx + (pt.1 - a.1) * dy) / l2;
            let inner = t > 1e-9 && t < 1.0 - 1e-9;
            let t = t.clamp(0.0, 1.0);
            let (cx, cy) = (a.0 + t * dx, a.1 + t * dy);
            let d = ((pt.0 - cx).powi(2) + (pt.1 - cy).powi(2)).sqrt();
            let side = dx * (pt.1 - a.1) - dy * (pt.0 - a.0);
            (d, side, inner)
        }
        El::Arc(c, r, a0, sw) => {
            let ang = (pt.1 - c.1).atan2(pt.0 - c.0);
            // is the angle within the swept range?
            let rel = if sw > 0.0 {
                (ang - a0).rem_euclid(std::f64::consts::TAU)
            } else {
                (a0 - ang).rem_euclid(std::f64::consts::TAU)
            };
            let rc = ((pt.0 - c.0).powi(2) + (pt.1 - c.1).powi(2)).sqrt();
            let inside_span = rel <= sw.abs() + 1e-12;
            let d = if inside_span {
                (rc - r).abs()
            } else {
                let e = |t: f64| {
                    let (x, y) = (c.0 + r * t.cos(), c.1 + r * t.sin());
                    ((pt.0 - x).powi(2) + (pt.1 - y).powi(2)).sqrt()
                };
                e(a0).min(e(a0 + sw))
            };
            // left of a counter-clockwise arc is inside the circle
            let side = if sw > 0.0 { r - rc } else { rc - r };
            (d, side, rel > 1e-9 && rel < sw.abs() - 1e-9)
        }
    }
}

/// Samples by which a setpoint trails the block its sample names: the path
/// filter's and the XYZ filter's windows.
pub fn filter_lag(m: &Machine) -> usize {
    let b = m.jerk_budget();
    b.m_s + b.m_f - 1
}
