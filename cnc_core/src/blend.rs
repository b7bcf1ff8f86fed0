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
//! Under a jerk limit a blend is not always the faster way round a
//! corner: a sharp corner's arc is small, its speed cap low, and the path
//! filter holds that cap over a stretch of the lines on either side
//! ([`crate::jerk`]); an exact stop there costs the filters' hold instead.
//! A corner whose blend [`StopCost`] reckons slower than a stop is left
//! unblended, which keeps its path exact.
//!
//! The stage holds the run and the last line back until the next event
//! says whether its end is a corner to blend.

use crate::canon::{Event, Feed, Src};
use crate::geom::V3;
use crate::geom::{Arc, Geom, Plane};
use crate::jerk::{curvature, least_piece, ArcPart, JerkBudget};
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
    /// whether a blend pays against a stop (None: every blend does)
    stops: Option<StopCost>,
}

/// What a corner costs blended and what it costs as an exact stop, under
/// a jerk limit, in time lost against passing at the lines' speed `v`
/// (mm/s):
///
/// - **stop**: v/a for slowing down to rest and speeding up again, and
///   the hold while both filters settle;
/// - **blend**: (v − v_b)²/(a·v) for slowing down to the arc's speed cap
///   v_b and back, and the stretch held at v_b: the arc, and on either
///   side the path filter's reach of the cap, lag·v_b, which the
///   planner's pieces of the lines (halving towards the corner, each
///   capped whole) stretch to up to twice that.
///
/// A blend pays when it loses less. With no jerk caps (no limit, or the
/// single moving average) there is no hold beyond the filter and no
/// stretch held: every blend pays.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StopCost {
    pub(crate) jerk: JerkBudget,
    /// the least acceleration limit of the axes, mm/s²
    pub(crate) accel: f64,
    /// the least speed limit of the axes, mm/s
    pub(crate) vmax: f64,
}

impl StopCost {
    /// Whether `arc` loses less time than a stop, where it joins a line
    /// of `len[0]` mm (what is left of it) at feed `feed[0]` mm/s and one
    /// of `len[1]` mm at `feed[1]`.
    pub(crate) fn blend_pays(&self, arc: &Arc, len: [f64; 2], feed: [f64; 2]) -> bool {
        let jb = &self.jerk;
        if !(jb.limited() && self.accel > 0.0 && self.accel.is_finite()) {
            return true;
        }
        let a = self.accel;
        let vb = jb
            .arc_caps(curvature(&Geom::Arc(*arc)), ArcPart::End)
            .0
            .min(feed[0].min(feed[1]))
            .min(self.vmax);
        if vb.is_nan() || vb <= 0.0 {
            return false;
        }
        // (against passing the corner at the lines' speeds: half the arc
        // at either)
        let (mut blend, mut stop) = (arc.length / vb, 0.0);
        for (l, f) in len.into_iter().zip(feed) {
            // the speed on the line: at most what it leaves room to reach
            let v = f.min(self.vmax).min((vb * vb + a * l).sqrt()).max(vb);
            stop += 0.5 * v / a;
            blend -= 0.5 * arc.length / v;
            // (the planner cuts a line's ends into pieces that halve
            // towards the corner and caps a piece whole: the cap holds
            // over up to twice its reach, and at least the shortest piece)
            let held = (2.0 * jb.lag_distance(vb))
                .max(least_piece(jb.lag_distance(v)))
                .min(l);
            blend += 0.5 * (v - vb) * (v - vb) / (a * v) + held * (1.0 / vb - 1.0 / v);
        }
        blend < stop + jb.hold_ticks() as f64 * jb.dt
    }
}

/// The principal plane holding both directions, if any.
fn plane_of(u1: &V3, u2: &V3) -> Option<Plane> {
    [Plane::XY, Plane::ZX, Plane::YZ].into_iter().find(|pl| {
        let n = pl.axes().2;
        u1[n] == 0.0 && u2[n] == 0.0
    })
}

impl Blender {
    pub(crate) fn new(shrink: f64, stops: Option<StopCost>) -> Self {
        Blender {
            run: Run::default(),
            held: None,
            shrink,
            stops,
        }
    }

    /// After an [`Event::Tolerance`] has passed (nothing is held): blends
    /// shrink by the XYZ filter's error under the new tolerance, and
    /// reckon stops with its budget.
    pub(crate) fn follow_tolerance(&mut self, mm: f64) {
        if let Some(s) = self.stops.as_mut() {
            s.jerk = s.jerk.for_tolerance(mm);
            self.shrink = s.jerk.error_mm();
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
        let blend = corner(&h, &next, tol - h.dev.max(next.dev)).filter(|(t1, arc, t2)| {
            self.stops.is_none_or(|c| {
                let len = [(t1 - h.start).norm(), (next.end - t2).norm()];
                c.blend_pays(arc, len, [h.feed.speed_mm_s(), next.feed.speed_mm_s()])
            })
        });
        match blend {
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
mod tests;
