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
//! unblended, which keeps its path exact. A stop costs less where the
//! corner before it stops too: the line between two stops runs from rest
//! to rest with a path filter of its own, whose hold is shorter than the
//! machine filters'. So the corners of a chain of lines are decided
//! together ([`Blender::decide`]): the choices whose times, added over
//! the chain ([`StopCost`]), are least, where a corner may be blended only
//! if its blend pays against a stop on its own
//! ([`StopCost::blend_pays`]).
//!
//! The stage holds the run and the chain of lines back until an event
//! that is no line to blend ends the chain (or it is [`MAX_CHAIN`] lines
//! long).

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
    /// the lines held back, each with the tolerance it came with: a chain
    /// whose corners are decided together ([`Blender::decide`])
    chain: Vec<(Held, f64)>,
    /// whether the chain's first line starts from an exact stop: after a
    /// dwell, an exact stop of the tolerance, a turn past the exact-stop
    /// angle, or a corner of the chain before it left unblended
    from_stop: bool,
    /// how the last event passed on ended
    before: Before,
    /// the choices per corner ([`Blender::decide`]), reused
    best: Vec<[Choice; 2]>,
    /// what the XYZ jerk filter may add to a blend's deviation, mm
    /// ([`crate::Machine::smoothing_error_mm`]): blends keep within the
    /// tolerance less this
    shrink: f64,
    /// whether a blend pays against a stop (None: every blend does)
    stops: Option<StopCost>,
}

/// How long the lines of a chain take with a corner blended or left as
/// an exact stop, under a jerk limit ([`Blender::decide`] adds them up):
///
/// - each line runs a trapezoid of its own acceleration and speed limits
///   (along its direction) between the speeds at its ends: 0 at a stop,
///   a blend's speed cap v_b at a blend, which the path filter holds over
///   its reach into the line, lag·v_b;
/// - a blend adds its arc at v_b;
/// - a stop adds its hold while the filters settle: the machine filters'
///   hold, or, where the line before it also starts from an exact stop,
///   the shorter hold of that line's own path filter (a line from rest to
///   rest runs with that filter alone, `limits.rs`).
///
/// With no jerk caps (no limit, or the single moving average) there is no
/// hold beyond the filter and no stretch held: every blend pays.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StopCost {
    pub(crate) jerk: JerkBudget,
    /// the least acceleration limit of the axes, mm/s²
    pub(crate) accel: f64,
    /// the least speed limit of the axes, mm/s
    pub(crate) vmax: f64,
    /// each axis's acceleration and speed limits, mm/s² and mm/s (a
    /// line's, and its own path filter)
    pub(crate) amax: V3,
    pub(crate) vmax_axes: V3,
    /// the cosine of the machine's exact-stop angle: a corner that turns
    /// more is a stop when it is not blended
    pub(crate) exact_stop_cos: f64,
}

impl StopCost {
    /// Whether the blend and the stop are reckoned at all (else every
    /// blend pays).
    fn reckons(&self) -> bool {
        self.jerk.limited() && self.accel > 0.0 && self.accel.is_finite()
    }

    /// The speed cap of the blend `arc` between lines at `feed` mm/s
    /// (None: it cannot be passed).
    fn blend_speed(&self, arc: &Arc, feed: [f64; 2]) -> Option<f64> {
        let vb = self
            .jerk
            .arc_caps(curvature(&Geom::Arc(*arc)), ArcPart::End)
            .0
            .min(feed[0].min(feed[1]))
            .min(self.vmax);
        (vb > 0.0).then_some(vb)
    }

    /// Whether `arc` loses less time than a stop with the machine filters'
    /// hold, corner by corner, where it joins a line of `len[0]` mm (what
    /// is left of it) at feed `feed[0]` mm/s and one of `len[1]` mm at
    /// `feed[1]`, each reckoned against passing the corner at the lines'
    /// speed v (mm/s):
    ///
    /// - **stop**: v/a for slowing down to rest and speeding up again, and
    ///   the hold while both filters settle;
    /// - **blend**: (v − v_b)²/(a·v) for slowing down to the arc's speed
    ///   cap v_b and back, and the stretch held at v_b: the arc, and on
    ///   either side the path filter's reach of the cap, lag·v_b, which
    ///   the planner's pieces of the lines (halving towards the corner,
    ///   each capped whole) stretch to up to twice that.
    ///
    /// Only a corner whose blend pays may be blended ([`Blender::decide`]
    /// may still leave it a stop).
    pub(crate) fn blend_pays(&self, arc: &Arc, len: [f64; 2], feed: [f64; 2]) -> bool {
        let jb = &self.jerk;
        let a = self.accel;
        let Some(vb) = self.blend_speed(arc, feed) else {
            return false;
        };
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

    /// A line's acceleration and top speed along `u` (|component| per
    /// axis), mm/s² and mm/s.
    fn line_limits(&self, u: &V3) -> (f64, f64) {
        let (mut a, mut v) = (f64::INFINITY, f64::INFINITY);
        for i in 0..3 {
            if u[i] > 0.0 {
                a = a.min(self.amax[i] / u[i]);
                v = v.min(self.vmax_axes[i] / u[i]);
            }
        }
        if a.is_finite() {
            (a, v)
        } else {
            (self.accel, self.vmax)
        }
    }

    /// How long (s) a line of `len` mm takes at up to `f` mm/s, with
    /// acceleration `a`, from the speed `v0` at its start to `v1` at its
    /// end (0: a stop; else a blend's cap, which the path filter holds
    /// over its reach into the line, lag·v): held at either end, and
    /// between them a trapezoid (or a triangle) of `a`.
    fn line_time(&self, len: f64, a: f64, f: f64, v0: f64, v1: f64) -> f64 {
        let lag = self.jerk.lag_s();
        let (mut h0, mut h1) = (lag * v0, lag * v1);
        if h0 + h1 > len {
            let s = len / (h0 + h1);
            (h0, h1) = (h0 * s, h1 * s);
        }
        let held = |h: f64, v: f64| if h > 0.0 { h / v } else { 0.0 };
        let mut t = held(h0, v0) + held(h1, v1);
        let l = (len - h0 - h1).max(0.0);
        let f = f.max(v0).max(v1);
        let peak2 = (2.0 * a * l + v0 * v0 + v1 * v1) / 2.0;
        if peak2 >= f * f {
            t += (2.0 * f - v0 - v1) / a + (l - (2.0 * f * f - v0 * v0 - v1 * v1) / (2.0 * a)) / f;
        } else if peak2 >= v0.max(v1).powi(2) {
            let peak = peak2.sqrt();
            t += (2.0 * peak - v0 - v1) / a;
        } else if v0 + v1 > 0.0 {
            // (too short to change speed that much: at their mean)
            t += 2.0 * l / (v0 + v1);
        }
        t
    }

    /// The hold (s) after a stop at the end of a line of directions `u`
    /// (|component| per axis): the machine filters' (both settle), or,
    /// with `rest` (the line also starts from a stop), the line's own
    /// path filter's ([`JerkBudget::own_filter_samples`], as the planner
    /// sizes it).
    fn hold(&self, u: &V3, rest: bool) -> f64 {
        let jb = &self.jerk;
        let own = if rest {
            jb.own_filter_samples(u, self.line_limits(u).0)
        } else {
            0
        };
        match own {
            0 => jb.hold_ticks() as f64 * jb.dt,
            // (the hold, and the tick the line waits at its start)
            m => f64::from(m + 1) * jb.dt,
        }
    }
}

/// Longest chain of lines whose corners are decided together; a longer
/// one is decided in parts (its last line starts the next).
const MAX_CHAIN: usize = 32;

/// How the last event the stage passed on ended: at rest (the program's
/// start, a dwell, an exact stop of the tolerance), moving along a
/// direction, or not known here (the planner decides).
#[derive(Clone, Copy, Debug, Default)]
enum Before {
    #[default]
    Rest,
    Moving(V3),
    Unknown,
}

/// One choice at a corner of a chain, on the best way to it: the time
/// up to the corner, s (the chain's lines before it, the blends and the
/// stops' holds), the choice at the corner before (0: unblended, 1:
/// blended), the blend (if blended), the speed the corner is passed at
/// (0: a stop) and where the line after it starts.
#[derive(Clone, Copy, Debug)]
struct Choice {
    time: f64,
    before: usize,
    blend: Option<(V3, Arc, V3)>,
    speed: f64,
    start: V3,
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
            chain: Vec::new(),
            from_stop: false,
            before: Before::Rest,
            best: Vec::new(),
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
        !self.chain.is_empty() || !self.run.points.is_empty()
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

    /// Adds `ev` to the chain if it is a line to blend (whose points are
    /// `dev` from those it replaces) within `tol`, else decides the chain
    /// and passes `ev` on.
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
            self.before = match ev {
                Event::Move { geom, .. } => Before::Moving(geom.end_tangent()),
                Event::Dwell { .. } | Event::Tolerance { .. } => Before::Rest,
                _ => Before::Unknown,
            };
            out.push_back(ev);
            return;
        };
        if self.chain.is_empty() {
            self.from_stop = match (self.before, &self.stops) {
                (Before::Rest, _) => true,
                (Before::Moving(t), Some(c)) => {
                    t.dot(&(next.end - next.start).normalize()) < c.exact_stop_cos
                }
                _ => false,
            };
        }
        self.chain.push((next, tol));
        if self.chain.len() > MAX_CHAIN {
            self.decide(true, out);
        }
    }

    /// Decides the chain's corners and passes its lines and blends on
    /// (with `keep_last`, all but the last line, which then starts the
    /// chain). A corner between lines k − 1 and k is blended within the
    /// tolerance line k came with, less the larger deviation of the two,
    /// or left as it is; its blend depends on what the corner before left
    /// of line k − 1, and it is a choice only where it pays on its own
    /// ([`StopCost::blend_pays`]: the reckoning of whole lines below turns
    /// blends into stops, never stops into blends). The time of line k − 1
    /// up to the corner, and of the blend or the stop's hold
    /// ([`StopCost`]), is added along the chain,
    /// and the least total (with the last line's time) is taken: dynamic
    /// programming over the two choices per corner, each keeping its best
    /// way there (and the blend that way gives). Without jerk caps every
    /// corner that can be is blended.
    fn decide(&mut self, keep_last: bool, out: &mut VecDeque<Event>) {
        let n = self.chain.len();
        if n == 0 {
            return;
        }
        let mut lines = std::mem::take(&mut self.chain);
        let first = Choice {
            time: 0.0,
            before: 0,
            blend: None,
            speed: 0.0,
            start: lines[0].0.start,
        };
        let none = Choice {
            time: f64::INFINITY,
            ..first
        };
        let stops = self.stops.filter(StopCost::reckons);
        // whether each line's unblended end is an exact stop
        let dir = |h: &Held| (h.end - h.origin).normalize();
        let stop_at = |k: usize| match (&stops, k) {
            (Some(c), 1..) if k < n => {
                dir(&lines[k - 1].0).dot(&dir(&lines[k].0)) < c.exact_stop_cos
            }
            _ => false,
        };
        // the time a line takes from a corner passed at `v0` (its start
        // `start`) to its end `end` passed at `v1`
        let line_time = |c: &StopCost, h: &Held, start: V3, end: V3, v0: f64, v1: f64| {
            let (a, vmax) = c.line_limits(&dir(h).abs());
            c.line_time(
                (end - start).norm(),
                a,
                h.feed.speed_mm_s().min(vmax),
                v0,
                v1,
            )
        };
        let mut best = std::mem::take(&mut self.best);
        best.clear();
        best.push([first, none]);
        for k in 1..n {
            let (b, tol) = &lines[k];
            let mut here = [none; 2];
            for (before, prev) in best[k - 1].into_iter().enumerate() {
                if !prev.time.is_finite() {
                    continue;
                }
                let a = Held {
                    start: prev.start,
                    ..lines[k - 1].0
                };
                let cand = corner(&a, b, tol - a.dev.max(b.dev));
                let options = match &stops {
                    // without reckoning: blend where it can
                    None => [
                        (1.0, 0.0),
                        (if cand.is_some() { 0.0 } else { f64::INFINITY }, 0.0),
                    ],
                    Some(c) => {
                        // line k − 1 from rest to rest: its start an exact
                        // stop left unblended, and its end
                        let rest = before == 0
                            && stop_at(k)
                            && (if k == 1 {
                                self.from_stop
                            } else {
                                stop_at(k - 1)
                            });
                        let stop = line_time(c, &a, a.start, a.end, prev.speed, 0.0)
                            + c.hold(&dir(&a).abs(), rest);
                        let feed = [a.feed.speed_mm_s(), b.feed.speed_mm_s()];
                        let blend = cand.and_then(|(t1, arc, t2)| {
                            let len = [(t1 - a.start).norm(), (b.end - t2).norm()];
                            if !c.blend_pays(&arc, len, feed) {
                                return None;
                            }
                            let vb = c.blend_speed(&arc, feed)?;
                            Some((
                                line_time(c, &a, a.start, t1, prev.speed, vb) + arc.length / vb,
                                vb,
                            ))
                        });
                        [(stop, 0.0), blend.unwrap_or((f64::INFINITY, 0.0))]
                    }
                };
                let starts = [b.start, cand.map_or(b.start, |c| c.2)];
                for (choice, (time, speed)) in options.into_iter().enumerate() {
                    let total = prev.time + time;
                    if total < here[choice].time {
                        here[choice] = Choice {
                            time: total,
                            before,
                            blend: if choice == 1 { cand } else { None },
                            speed,
                            start: starts[choice],
                        };
                    }
                }
            }
            if stops.is_none() {
                // (the greedy choice: one way on)
                let blended = here[1].time.is_finite();
                here[usize::from(!blended)] = none;
            }
            best.push(here);
        }
        // the choices on the best way, back from the last corner
        let mut choice = vec![0usize; n];
        // (and the last line's time after the last corner, to a stop)
        let end_time = |c: usize| {
            let ch = &best[n - 1][c];
            let last = &lines[n - 1].0;
            ch.time
                + stops.as_ref().map_or(0.0, |s| {
                    line_time(s, last, ch.start, last.end, ch.speed, 0.0)
                })
        };
        let mut c = usize::from(end_time(1) < end_time(0));
        for k in (1..n).rev() {
            choice[k] = c;
            c = best[k][c].before;
        }
        let last = if keep_last { n - 1 } else { n };
        for (k, (line, _)) in lines.iter().enumerate().take(last) {
            let start = best[k][choice[k]].start;
            let next = (k + 1 < n)
                .then(|| best[k + 1][choice[k + 1]].blend)
                .flatten();
            match next {
                Some((t1, arc, _)) => {
                    if t1 != start {
                        out.push_back(line_event(&Held {
                            start,
                            end: t1,
                            ..*line
                        }));
                    }
                    let after = &lines[k + 1].0;
                    out.push_back(Event::Move {
                        geom: Geom::Arc(arc),
                        feed: after.feed,
                        src: after.src,
                    });
                }
                None => out.push_back(line_event(&Held { start, ..*line })),
            }
        }
        // (after all of the chain, the event that ended it sets `before`)
        let k = n - 1;
        self.from_stop = keep_last && choice[k] == 0 && stop_at(k);
        let (line, tol) = lines[k];
        lines.clear();
        self.chain = lines;
        if keep_last {
            self.chain.push((
                Held {
                    start: best[k][choice[k]].start,
                    ..line
                },
                tol,
            ));
        }
        self.best = best;
    }

    /// Passes the run (if any, merged) and the chain on, the chain's last
    /// line unblended at its end.
    pub(crate) fn flush(&mut self, out: &mut VecDeque<Event>) {
        self.end_run(out);
        self.decide(false, out);
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
