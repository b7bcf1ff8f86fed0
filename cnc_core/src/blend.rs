//! Corner blending within a path tolerance (`G64 P<mm>`): the last stage
//! before the planner. A corner between two feed lines in one plane
//! (G17/G18/G19) is replaced by the arc tangent to both whose deviation
//! from the corner point is at most the tolerance, and which takes at most
//! half of either line. The planner then passes line, arc and line at
//! speed (the junctions are tangent), within the arc's centripetal limit,
//! instead of stopping or crawling through the corner. Tolerance 0 (G61,
//! the default) leaves the path exact. Corners between lines that climb
//! out of a principal plane at the same slope (polyline helices, sloped
//! zigzags) are blended with a helix over the in-plane arc. Rapids, arcs,
//! other corners out of a principal plane and reversals are not blended.
//!
//! The stage holds the last line back until the next event says whether
//! its end is a corner to blend.

use crate::canon::{Event, Feed, Src};
use crate::geom::V3;
use crate::geom::{Arc, Geom, Plane};
use std::collections::VecDeque;

/// A held line: its (possibly trimmed) start, its end, feed and source,
/// and where it started before a blend trimmed it.
#[derive(Clone, Copy, Debug)]
struct Held {
    start: V3,
    end: V3,
    feed: Feed,
    src: Src,
    /// the programmed start: each of the line's two blends may take up to
    /// half of the programmed line, so that on a polyline of equal short
    /// lines (a CAM curve) each blend gets half of both its lines and the
    /// lines between vanish, rather than every blend getting a third
    origin: V3,
}

#[derive(Debug, Default)]
pub(crate) struct Blender {
    held: Option<Held>,
    /// what the XYZ jerk filter may add to a blend's deviation, mm
    /// ([`crate::Machine::smoothing_error_mm`]): blends keep within the
    /// tolerance less this
    shrink: f64,
}

/// The principal plane holding both directions, if any.
fn plane_of(u1: &V3, u2: &V3) -> Option<Plane> {
    [Plane::XY, Plane::ZX, Plane::YZ].into_iter().find(|pl| {
        let n = pl.axes().2;
        u1[n] == 0.0 && u2[n] == 0.0
    })
}

impl Blender {
    pub(crate) fn new(shrink: f64) -> Self {
        Blender { held: None, shrink }
    }

    /// A line is held back.
    #[inline]
    pub(crate) fn holds(&self) -> bool {
        self.held.is_some()
    }

    /// Passes `ev` on to `out`, blending the corner between the held line
    /// and `ev` within `tol` (mm).
    pub(crate) fn push(&mut self, ev: Event, tol: f64, out: &mut VecDeque<Event>) {
        let tol = tol - self.shrink;
        let line = match ev {
            Event::Move {
                geom: Geom::Line { start, end },
                feed,
                src,
            } if tol > 0.0 && !matches!(feed, Feed::Rapid) => Some(Held {
                start,
                end,
                feed,
                src,
                origin: start,
            }),
            _ => None,
        };
        let Some(next) = line else {
            self.flush(out);
            out.push_back(ev);
            return;
        };
        let Some(h) = self.held.take() else {
            self.held = Some(next);
            return;
        };
        match corner(&h, &next, tol) {
            Some((t1, arc, t2)) => {
                if t1 != h.start {
                    out.push_back(Event::Move {
                        geom: Geom::Line {
                            start: h.start,
                            end: t1,
                        },
                        feed: h.feed,
                        src: h.src,
                    });
                }
                out.push_back(Event::Move {
                    geom: Geom::Arc(arc),
                    feed: next.feed,
                    src: next.src,
                });
                self.held = Some(Held { start: t2, ..next });
            }
            None => {
                out.push_back(line_event(&h));
                self.held = Some(next);
            }
        }
    }

    /// Passes the held line on unchanged.
    pub(crate) fn flush(&mut self, out: &mut VecDeque<Event>) {
        if let Some(h) = self.held.take() {
            out.push_back(line_event(&h));
        }
    }
}

fn line_event(h: &Held) -> Event {
    Event::Move {
        geom: Geom::Line {
            start: h.start,
            end: h.end,
        },
        feed: h.feed,
        src: h.src,
    }
}

/// The principal plane in which both directions climb (nearly) equally
/// along the plane's normal per unit of in-plane travel (a polyline helix,
/// a sloped zigzag, also with coordinates rounded in the program), and
/// the difference of the two slopes; `None` if there is none.
fn helix_plane_of(u1: &V3, u2: &V3) -> Option<(Plane, f64)> {
    [Plane::XY, Plane::ZX, Plane::YZ]
        .into_iter()
        .find_map(|pl| {
            let (p, q, n) = pl.axes();
            let (w1, w2) = (u1[p].hypot(u1[q]), u2[p].hypot(u2[q]));
            if w1 < 1e-6 || w2 < 1e-6 {
                return None;
            }
            let ds = (u1[n] / w1 - u2[n] / w2).abs();
            (ds <= MAX_SLOPE_DIFF).then_some((pl, ds))
        })
}

/// Largest difference of the two slopes a helical blend joins (the
/// junctions then turn by about this, in radians, at most).
const MAX_SLOPE_DIFF: f64 = 1e-2;

/// Share of the tolerance a helical blend uses in its plane: the rest
/// covers its small climb mismatch against the lines.
const HELIX_TOL: f64 = 0.9;

/// The blend of the corner at `a.end` (= `b.start`): (where the first
/// line now ends, the arc, where the second now starts). In a principal
/// plane the arc is tangent to both lines. It takes at most half of
/// either line as programmed (and no more of `a` than the previous blend
/// left: when it takes all of that, the first line ends where it starts
/// now, exactly, and vanishes). Where both lines climb out of
/// such a plane at the same slope, the blend is the in-plane arc lifted
/// into a helix over the same climb; its slope is 2·tan(φ/2)/φ times the
/// lines' (φ the turn), a junction so nearly tangent that the planner
/// passes it like the others (or stops, if it is not).
fn corner(a: &Held, b: &Held, tol: f64) -> Option<(V3, Arc, V3)> {
    let c = a.end;
    if b.start != c {
        return None;
    }
    let d1 = c - a.start;
    let d2 = b.end - c;
    let (l1, l2) = (d1.norm(), d2.norm());
    if !(l1 > 0.0 && l2 > 0.0) {
        return None;
    }
    let (u1, u2) = (d1 / l1, d2 / l2);
    let full_tol = tol;
    let (plane, tol, ds) = match plane_of(&u1, &u2) {
        Some(pl) => (pl, tol, 0.0),
        None => {
            let (pl, ds) = helix_plane_of(&u1, &u2)?;
            (pl, tol * HELIX_TOL, ds)
        }
    };
    let (p, q, _) = plane.axes();
    // the corner in the plane: in-plane lengths and unit directions
    let (w1, w2) = (d1[p].hypot(d1[q]), d2[p].hypot(d2[q]));
    let (e1, e2) = ((d1[p] / w1, d1[q] / w1), (d2[p] / w2, d2[q] / w2));
    let cos = (e1.0 * e2.0 + e1.1 * e2.1).clamp(-1.0, 1.0);
    let phi = cos.acos();
    // tangent already, or turning back (no arc fits)
    if phi < 1e-7 || phi > 179f64.to_radians() {
        return None;
    }
    let half = 0.5 * phi;
    let w1_programmed = (c - a.origin)[p].hypot((c - a.origin)[q]);
    let r_tol = tol / (1.0 / half.cos() - 1.0);
    let r_len = 0.5 * w1_programmed.max(w1).min(w2) / half.tan();
    let mut r = r_tol.min(r_len);
    let mut l = r * half.tan();
    // all that is left of the first line (within rounding): it vanishes
    let takes_all = l >= w1 * (1.0 - 1e-12);
    if takes_all {
        l = w1;
        r = l / half.tan();
    }
    // the helix climbs at the mean slope: at most ds·l/2 off each line
    if !(l > 1e-9 && r.is_finite()) || 0.5 * ds * l > (1.0 - HELIX_TOL) * full_tol {
        return None;
    }
    // back and on along the lines by in-plane distance l
    let t1 = if takes_all {
        a.start
    } else {
        c - d1 * (l / w1)
    };
    let t2 = c + d2 * (l / w2);
    let nl = ((e2.0 - e1.0 * cos), (e2.1 - e1.1 * cos));
    let nn = nl.0.hypot(nl.1);
    let mut centre = t1;
    centre[p] += nl.0 / nn * r;
    centre[q] += nl.1 / nn * r;
    let ccw = e1.0 * e2.1 - e1.1 * e2.0 > 0.0;
    let arc = Arc::new(t1, t2, centre, plane, ccw, 0);
    Some((t1, arc, t2))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mv(a: V3, b: V3) -> Event {
        Event::Move {
            geom: Geom::Line { start: a, end: b },
            feed: Feed::PerMin(1000.0),
            src: Src::default(),
        }
    }

    #[test]
    fn a_right_angle_is_rounded_within_the_tolerance() {
        let mut b = Blender::default();
        let mut out = VecDeque::new();
        let o = V3::zeros();
        let c = V3::new(10.0, 0.0, 0.0);
        let e = V3::new(10.0, 10.0, 0.0);
        b.push(mv(o, c), 0.1, &mut out);
        b.push(mv(c, e), 0.1, &mut out);
        b.flush(&mut out);
        assert_eq!(out.len(), 3);
        let Event::Move {
            geom: Geom::Arc(arc),
            ..
        } = out[1]
        else {
            panic!("an arc")
        };
        // r (√2 − 1) = 0.1
        let r = 0.1 / (2f64.sqrt() - 1.0);
        assert!((arc.radius - r).abs() < 1e-12);
        let mid = arc.start + (arc.end - arc.start) * 0.5;
        let apex = arc.center + (mid - arc.center).normalize() * arc.radius;
        assert!(((apex - c).norm() - 0.1).abs() < 1e-12);
        // the lines are tangent to it and keep their outer ends
        let Event::Move { geom: g0, .. } = out[0] else {
            panic!()
        };
        let Event::Move { geom: g2, .. } = out[2] else {
            panic!()
        };
        assert_eq!(g0.start(), o);
        assert_eq!(g2.end(), e);
        let ga = Geom::Arc(arc);
        assert!((g0.end_tangent() - ga.start_tangent()).norm() < 1e-12);
        assert!((ga.end_tangent() - g2.start_tangent()).norm() < 1e-12);
    }

    #[test]
    fn a_polyline_of_equal_lines_is_blended_into_arcs_of_its_circle() {
        // 3° per line around R10 (a CAM circle): every blend takes half of
        // both its lines, so its radius is R·cos(1.5°) and no line is left
        // between two blends (each blend taking half of what the last one
        // left would give arcs of 2/3 of that radius)
        let (r0, step) = (10.0, 3f64.to_radians());
        let pt = |k: usize| {
            let a = step * k as f64;
            V3::new(r0 * a.cos(), r0 * a.sin(), 0.0)
        };
        let mut b = Blender::default();
        let mut out = VecDeque::new();
        for k in 0..20 {
            b.push(mv(pt(k), pt(k + 1)), 0.05, &mut out);
        }
        b.flush(&mut out);
        let geoms: Vec<Geom> = out
            .iter()
            .map(|ev| match ev {
                Event::Move { geom, .. } => *geom,
                _ => panic!("a move"),
            })
            .collect();
        // line, then the 19 blends without lines between, then the rest of
        // the last line
        assert_eq!(geoms.len(), 21, "{geoms:?}");
        assert!(matches!(geoms[0], Geom::Line { .. }));
        assert!(matches!(geoms[20], Geom::Line { .. }));
        let want = r0 * (0.5 * step).cos();
        for (k, g) in geoms[1..20].iter().enumerate() {
            let Geom::Arc(arc) = g else {
                panic!("blend {k} is not an arc: {g:?}")
            };
            assert!((arc.radius - want).abs() < 1e-9, "{k}: {}", arc.radius);
            // its deviation from the corner stays within the tolerance
            let apex_dev = arc.radius * (1.0 / (0.5 * step).cos() - 1.0);
            assert!(apex_dev <= 0.05, "{apex_dev}");
        }
        // the path is continuous: each piece starts where the last ended
        for w in geoms.windows(2) {
            assert!((w[0].end() - w[1].start()).norm() < 1e-12);
        }
        assert_eq!(geoms[0].start(), pt(0));
        assert_eq!(geoms[20].end(), pt(20));
    }

    /// The arc of a blended corner between `a→c` and `c→e` at `tol`.
    fn blend_of(a: V3, c: V3, e: V3, tol: f64) -> Option<Arc> {
        let mut b = Blender::default();
        let mut out = VecDeque::new();
        b.push(mv(a, c), tol, &mut out);
        b.push(mv(c, e), tol, &mut out);
        b.flush(&mut out);
        out.iter().find_map(|ev| match ev {
            Event::Move {
                geom: Geom::Arc(arc),
                ..
            } => Some(*arc),
            _ => None,
        })
    }

    #[test]
    fn a_corner_climbing_at_one_slope_is_blended_with_a_helix() {
        // a 90° turn in XY, both lines falling 1 mm per 10 mm in the plane
        let (a, c, e) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(10.0, 0.0, -1.0),
            V3::new(10.0, 10.0, -2.0),
        );
        let arc = blend_of(a, c, e, 0.1).expect("a helical blend");
        assert_eq!(arc.plane, Plane::XY);
        // 90 % of the tolerance in the plane: r (√2 − 1) = 0.09
        let r = 0.09 / (2f64.sqrt() - 1.0);
        assert!((arc.radius - r).abs() < 1e-12, "{}", arc.radius);
        // it climbs from line to line: the trims are r in the plane, so
        // 0.1·r of Z on each side
        assert!(
            (arc.start.z - (-1.0 + 0.1 * r)).abs() < 1e-12,
            "{}",
            arc.start.z
        );
        assert!(
            (arc.end.z - (-1.0 - 0.1 * r)).abs() < 1e-12,
            "{}",
            arc.end.z
        );
        assert!((arc.axial + 0.2 * r).abs() < 1e-12);
        // the junctions turn by about slope·(2·tan(φ/2)/φ − 1): 1.6° here
        let ga = Geom::Arc(arc);
        let g0 = Geom::Line { start: a, end: c };
        let turn = g0
            .end_tangent()
            .dot(&ga.start_tangent())
            .acos()
            .to_degrees();
        assert!(turn > 1.5 && turn < 1.7, "{turn}");
        // CAM-rounded: slopes 0.1 and 0.1001 still blend; 0.1 and 0.2 do not
        assert!(blend_of(a, c, V3::new(10.0, 10.0, -2.001), 0.1).is_some());
        assert!(blend_of(a, c, V3::new(10.0, 10.0, -3.0), 0.1).is_none());
    }
}
