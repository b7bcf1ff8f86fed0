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
//! Before blending, a run of feed lines whose inner points all lie within
//! half the tolerance of the line from the run's start to its end, in
//! order along it, is replaced by that one line (as LinuxCNC's G64 Q
//! "naive CAM detector" does with its own tolerance): a CAM polyline whose
//! vertices were rounded to a micrometre turns by a noisy angle at every
//! vertex, and arcs blended into those angles would have radii from
//! a third to many times the curve's; merged, the turns between the
//! longer lines follow the curve, and so do the blends. A blended corner
//! then keeps within the tolerance less the larger deviation of its two
//! merged lines, so the path stays within the tolerance of the programmed
//! one. Lines are merged only where they would be blended (a feed and a
//! tolerance), with the same feed, at most [`MAX_RUN`] at a time.
//!
//! The stage holds the run and the last line back until the next event
//! says whether its end is a corner to blend.

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
    /// the largest distance of the programmed points it replaces from it
    /// (a merged run), mm; 0 for a line as programmed
    dev: f64,
}

/// A blend also takes the rest of its first line when that rest is
/// shorter than this share of what it takes.
const REMNANT: f64 = 0.01;

/// Largest number of programmed lines merged into one.
const MAX_RUN: usize = 64;

/// A run of lines being merged: the run's start, the programmed points
/// after it (the last is the run's end; none: no run), the largest
/// distance of the inner points from the line start → end, the first
/// line's feed and source, and the blending tolerance in force (the run
/// merges within half of it).
#[derive(Debug)]
struct Run {
    start: V3,
    points: Vec<V3>,
    dev: f64,
    feed: Feed,
    src: Src,
    tol: f64,
}

impl Default for Run {
    fn default() -> Self {
        Run {
            start: V3::zeros(),
            points: Vec::new(),
            dev: 0.0,
            feed: Feed::Rapid,
            src: Src::default(),
            tol: 0.0,
        }
    }
}

impl Run {
    /// Whether the run extended to `end` keeps every inner point (the
    /// present points, all of which become inner) within half of
    /// `self.tol` of the line start → end and in order along it; the new
    /// deviation if so.
    fn extended(&self, end: V3) -> Option<f64> {
        let d = end - self.start;
        let len = d.norm();
        if len.is_nan() || len <= 0.0 || self.points.len() >= MAX_RUN {
            return None;
        }
        let u = d / len;
        let mut last = 0.0;
        let mut dev: f64 = 0.0;
        for p in &self.points {
            let w = p - self.start;
            let t = w.dot(&u);
            if t < last || t > len {
                return None;
            }
            last = t;
            dev = dev.max((w - u * t).norm());
            if dev > 0.5 * self.tol {
                return None;
            }
        }
        Some(dev)
    }
}

#[derive(Debug, Default)]
pub(crate) struct Blender {
    /// the lines being merged (empty: none)
    run: Run,
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
        Blender {
            run: Run::default(),
            held: None,
            shrink,
        }
    }

    /// A line is held back.
    #[inline]
    pub(crate) fn holds(&self) -> bool {
        self.held.is_some() || !self.run.points.is_empty()
    }

    /// Passes `ev` on to `out`, blending the corner between the held line
    /// and `ev` within `tol` (mm).
    pub(crate) fn push(&mut self, ev: Event, tol: f64, out: &mut VecDeque<Event>) {
        let tol = tol - self.shrink;
        // merging: a feed line continuing the run at the same feed and
        // tolerance extends it if it can; anything else ends the run
        if let Event::Move {
            geom: Geom::Line { start, end },
            feed,
            src,
        } = ev
        {
            if tol > 0.0 && !matches!(feed, Feed::Rapid) && start != end {
                let r = &self.run;
                let continues = r.feed == feed && r.tol == tol && r.points.last() == Some(&start);
                if continues {
                    if let Some(dev) = r.extended(end) {
                        self.run.points.push(end);
                        self.run.dev = dev;
                        return;
                    }
                }
                self.end_run(out);
                let r = &mut self.run;
                r.points.push(end);
                (r.start, r.dev, r.feed, r.src, r.tol) = (start, 0.0, feed, src, tol);
                return;
            }
        }
        self.end_run(out);
        self.blend(ev, tol, 0.0, out);
    }

    /// Passes the run (if any) on to blending as one line, at the
    /// tolerance its lines came with.
    fn end_run(&mut self, out: &mut VecDeque<Event>) {
        let Some(&end) = self.run.points.last() else {
            return;
        };
        self.run.points.clear();
        let Run {
            start,
            feed,
            src,
            dev,
            tol,
            ..
        } = self.run;
        let ev = Event::Move {
            geom: Geom::Line { start, end },
            feed,
            src,
        };
        self.blend(ev, tol, dev, out);
    }

    /// Blends the corner between the held line and `ev` (a line whose
    /// points are `dev` from those it replaces) within `tol` less the
    /// larger deviation of the two.
    fn blend(&mut self, ev: Event, tol: f64, dev: f64, out: &mut VecDeque<Event>) {
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
                dev,
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
        match corner(&h, &next, tol - h.dev.max(next.dev)) {
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

    /// Passes the held line on unchanged (after the run, if any, merged,
    /// its corner with the held line unblended).
    pub(crate) fn flush(&mut self, out: &mut VecDeque<Event>) {
        self.end_run(out);
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
    // all that is left of the first line (within rounding): it vanishes;
    // also a rest of it under REMNANT of the blend's share, when the arc
    // then keeps within the tolerance and the second line (a polyline of
    // nearly equal lines, CAM-rounded: the blends meet with no sliver of
    // line between them, which would be a step of the curvature)
    let takes_all =
        l >= w1 * (1.0 - 1e-12) || (w1 - l <= REMNANT * l && w1 < w2 && w1 / half.tan() <= r_tol);
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
        // (at 0.02 no two lines merge: a chord over two of them is
        // R(1 − cos 3°) = 13.7 µm off the middle vertex, over 0.01)
        for k in 0..20 {
            b.push(mv(pt(k), pt(k + 1)), 0.02, &mut out);
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
            assert!(apex_dev <= 0.02, "{apex_dev}");
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

    /// The moves `b` makes of the polyline through `pts` at `tol`.
    fn blended(pts: &[V3], tol: f64) -> Vec<Geom> {
        let mut b = Blender::default();
        let mut out = VecDeque::new();
        for w in pts.windows(2) {
            b.push(mv(w[0], w[1]), tol, &mut out);
        }
        b.flush(&mut out);
        out.iter()
            .map(|ev| match ev {
                Event::Move { geom, .. } => *geom,
                _ => panic!("a move"),
            })
            .collect()
    }

    /// Largest distance of `p` from the polyline through `pts`.
    fn dist_to_polyline(p: V3, pts: &[V3]) -> f64 {
        pts.windows(2)
            .map(|w| {
                let d = w[1] - w[0];
                let t = ((p - w[0]).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
                (p - (w[0] + d * t)).norm()
            })
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn a_cam_polyline_rounded_to_a_micrometre_is_merged_and_stays_within_the_tolerance() {
        // an R20 arc of 0.1 mm lines, every vertex rounded to 1 µm: the
        // turn per vertex is 0.29° on the curve but 0–1.28° as rounded, so
        // blends into the programmed angles would have radii from 4.5 mm
        // up (a tenth of them under 7.2 mm)
        let (r0, step) = (20.0, 0.005);
        let pts: Vec<V3> = (0..=400)
            .map(|k| {
                let a = step * k as f64;
                let round = |x: f64| (x * 1000.0).round() / 1000.0;
                V3::new(round(r0 * a.cos()), round(r0 * a.sin()), 0.0)
            })
            .collect();
        let tol = 0.01;
        let geoms = blended(&pts, tol);
        // merged: lines of about √(8·R·tol/2) = 0.9 mm, 9 programmed lines
        // each, and an arc between each two of them
        let lines = geoms
            .iter()
            .filter(|g| matches!(g, Geom::Line { .. }))
            .count();
        let arcs: Vec<&Arc> = geoms
            .iter()
            .filter_map(|g| match g {
                Geom::Arc(a) => Some(a),
                _ => None,
            })
            .collect();
        assert!(lines < 400 / 6, "{lines} lines");
        assert!(arcs.len() > 30, "{} arcs", arcs.len());
        // the blends follow the curve, not the rounding: radii within 10 %
        // of R, but the last, next to the short rest of the polyline
        // (18.3–20.9 mm and 11.8 mm)
        for a in &arcs[..arcs.len() - 1] {
            assert!((a.radius - r0).abs() < 0.1 * r0, "{}", a.radius);
        }
        // continuous, from the first point to the last
        assert_eq!(geoms[0].start(), pts[0]);
        assert_eq!(geoms.last().map(|g| g.end()), Some(pts[400]));
        for w in geoms.windows(2) {
            assert!((w[0].end() - w[1].start()).norm() < 1e-12);
        }
        // every point of the new path within the tolerance of the
        // programmed polyline (lines at 50 points, arcs at 50 angles)
        let mut worst: f64 = 0.0;
        for g in &geoms {
            for k in 0..=50 {
                let f = k as f64 / 50.0;
                let p = match g {
                    Geom::Line { start, end } => start + (end - start) * f,
                    Geom::Arc(a) => {
                        let t = a.theta0 + a.sweep * f;
                        a.center + V3::new(a.radius * t.cos(), a.radius * t.sin(), 0.0)
                    }
                };
                worst = worst.max(dist_to_polyline(p, &pts));
            }
        }
        assert!(worst <= tol && worst > 0.5 * tol, "{worst}");
    }

    #[test]
    fn lines_that_turn_back_or_leave_half_the_tolerance_are_not_merged() {
        let tol = 0.01;
        // a zigzag of 4 µm amplitude turning back along X: within the
        // tolerance of a line, but not in order along it
        let back = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.5, 0.004, 0.0),
            V3::new(2.0, 0.0, 0.0),
        ];
        let g = blended(&back, tol);
        assert!(
            g.iter().filter(|g| matches!(g, Geom::Line { .. })).count() >= 2,
            "{g:?}"
        );
        assert_eq!(g.last().map(|g| g.end()), Some(back[3]));
        // a vertex 6 µm off the line through its neighbours: over half of
        // 0.01, so the corner is blended, not merged; at 4 µm it merges
        for (off, merged) in [(0.006, false), (0.004, true)] {
            let pts = [
                V3::new(0.0, 0.0, 0.0),
                V3::new(1.0, off, 0.0),
                V3::new(2.0, 0.0, 0.0),
            ];
            let g = blended(&pts, tol);
            assert_eq!(g.len() == 1, merged, "{off}: {g:?}");
            if merged {
                assert_eq!(
                    g[0],
                    Geom::Line {
                        start: pts[0],
                        end: pts[2]
                    }
                );
            }
        }
        // a feed change ends the run: two lines at different feeds stay two
        let mut b = Blender::default();
        let mut out = VecDeque::new();
        let (p0, p1, p2) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(2.0, 0.0, 0.0),
        );
        b.push(mv(p0, p1), tol, &mut out);
        b.push(
            Event::Move {
                geom: Geom::Line { start: p1, end: p2 },
                feed: Feed::PerMin(500.0),
                src: Src::default(),
            },
            tol,
            &mut out,
        );
        b.flush(&mut out);
        assert_eq!(out.len(), 2, "{out:?}");
    }
}
