//! Tool-nose and cutter radius compensation G40/G41/G42
//! (`docs/compensation.md` §4, §5): a stage between the interpreter's moves and the
//! planner. The programmed contour is offset by the tool radius to the
//! G41 (left) or G42 (right) side, seen along the direction of travel in
//! the plane; consecutive offset elements are joined at their intersection
//! (outside corners by extending both, or optionally rounded with an arc
//! about the corner); then every point is moved by R × the lathe tool
//! type's tip vector and by the tool's geometry offset.
//!
//! An element's end is known only when the next element in the plane
//! arrives, so the stage holds one element back, with the events that
//! follow it until then (moves of the normal axis alone, dwells, spindle).
//! Errors (no intersection, an element whose offset reverses, an arc
//! smaller than the tool) are returned as messages naming the blocks.

use crate::canon::{CompMode as Mode, Event, Feed, Src};
use crate::geom::V3;
use crate::geom::{Arc, Geom, Plane};
use std::f64::consts::{PI, TAU};

type P2 = (f64, f64);

fn sub(a: P2, b: P2) -> P2 {
    (a.0 - b.0, a.1 - b.1)
}
fn add(a: P2, b: P2) -> P2 {
    (a.0 + b.0, a.1 + b.1)
}
fn scale(a: P2, k: f64) -> P2 {
    (a.0 * k, a.1 * k)
}
fn dot(a: P2, b: P2) -> f64 {
    a.0 * b.0 + a.1 * b.1
}
fn cross(a: P2, b: P2) -> f64 {
    a.0 * b.1 - a.1 * b.0
}
fn norm(a: P2) -> f64 {
    a.0.hypot(a.1)
}
/// Left normal of a unit direction.
fn left(u: P2) -> P2 {
    (-u.1, u.0)
}
/// An angle difference wrapped into (−π, π].
fn wrap(a: f64) -> f64 {
    let mut d = a.rem_euclid(TAU);
    if d > PI {
        d -= TAU;
    }
    d
}

/// A programmed element in the plane.
#[derive(Clone, Copy, Debug)]
enum Shape {
    Line {
        a: P2,
        b: P2,
        u: P2,
    },
    Arc {
        c: P2,
        r: f64,
        sweep: f64,
        t0: f64,
        t1: f64,
    },
}

impl Shape {
    fn of(geom: &Geom, plane: Plane) -> Option<Shape> {
        let (p, q, _) = plane.axes();
        match geom {
            Geom::Line { start, end } => {
                let a = (start[p], start[q]);
                let b = (end[p], end[q]);
                let d = sub(b, a);
                let l = norm(d);
                (l > 1e-12).then(|| Shape::Line {
                    a,
                    b,
                    u: scale(d, 1.0 / l),
                })
            }
            Geom::Arc(arc) if arc.plane == plane => Some(Shape::Arc {
                c: (arc.center[p], arc.center[q]),
                r: arc.radius,
                sweep: arc.sweep,
                t0: arc.theta0,
                t1: arc.theta0 + arc.sweep,
            }),
            Geom::Arc(_) => None,
        }
    }

    fn start_dir(&self) -> P2 {
        match *self {
            Shape::Line { u, .. } => u,
            Shape::Arc { sweep, t0, .. } => scale((-t0.sin(), t0.cos()), sweep.signum()),
        }
    }

    fn end_dir(&self) -> P2 {
        match *self {
            Shape::Line { u, .. } => u,
            Shape::Arc { sweep, t1, .. } => scale((-t1.sin(), t1.cos()), sweep.signum()),
        }
    }

    fn end(&self) -> P2 {
        match *self {
            Shape::Line { b, .. } => b,
            Shape::Arc { c, r, t1, .. } => add(c, scale((t1.cos(), t1.sin()), r)),
        }
    }

    /// The offset radius of an arc (≤ 0: the tool does not fit in it).
    fn offset_radius(&self, side: f64, rt: f64) -> f64 {
        match *self {
            Shape::Arc { r, sweep, .. } => r - side * sweep.signum() * rt,
            Shape::Line { .. } => f64::INFINITY,
        }
    }

    /// Offset start and end points.
    fn offset_start(&self, side: f64, rt: f64) -> P2 {
        match *self {
            Shape::Line { a, u, .. } => add(a, scale(left(u), side * rt)),
            Shape::Arc { c, t0, .. } => {
                add(c, scale((t0.cos(), t0.sin()), self.offset_radius(side, rt)))
            }
        }
    }

    fn offset_end(&self, side: f64, rt: f64) -> P2 {
        match *self {
            Shape::Line { b, u, .. } => add(b, scale(left(u), side * rt)),
            Shape::Arc { c, t1, .. } => {
                add(c, scale((t1.cos(), t1.sin()), self.offset_radius(side, rt)))
            }
        }
    }
}

/// Intersections of the offset elements `a` and `b` (infinite lines, full
/// circles).
fn intersect(a: &Shape, b: &Shape, side: f64, rt: f64) -> Vec<P2> {
    enum Prim {
        L(P2, P2),
        C(P2, f64),
    }
    let prim = |s: &Shape| match *s {
        Shape::Line { u, .. } => Prim::L(s.offset_start(side, rt), u),
        Shape::Arc { c, .. } => Prim::C(c, s.offset_radius(side, rt)),
    };
    let line_circle = |p: P2, u: P2, c: P2, r: f64| -> Vec<P2> {
        // |p + t u − c|² = r²
        let w = sub(p, c);
        let bq = dot(w, u);
        let cq = dot(w, w) - r * r;
        let disc = bq * bq - cq;
        if disc < -1e-12 * r.max(1.0) * r.max(1.0) {
            return vec![];
        }
        let s = disc.max(0.0).sqrt();
        vec![add(p, scale(u, -bq - s)), add(p, scale(u, -bq + s))]
    };
    match (prim(a), prim(b)) {
        (Prim::L(p1, u1), Prim::L(p2, u2)) => {
            let den = cross(u1, u2);
            if den.abs() < 1e-12 {
                return vec![];
            }
            let t = cross(sub(p2, p1), u2) / den;
            vec![add(p1, scale(u1, t))]
        }
        (Prim::L(p, u), Prim::C(c, r)) | (Prim::C(c, r), Prim::L(p, u)) => line_circle(p, u, c, r),
        (Prim::C(c1, r1), Prim::C(c2, r2)) => {
            let d = sub(c2, c1);
            let dist = norm(d);
            if dist < 1e-12 {
                return vec![];
            }
            let x = (dist * dist + r1 * r1 - r2 * r2) / (2.0 * dist);
            let h2 = r1 * r1 - x * x;
            if h2 < -1e-12 * r1.max(1.0) * r1.max(1.0) {
                return vec![];
            }
            let h = h2.max(0.0).sqrt();
            let e = scale(d, 1.0 / dist);
            let m = add(c1, scale(e, x));
            vec![add(m, scale(left(e), h)), add(m, scale(left(e), -h))]
        }
    }
}

/// An element whose end waits for the next one.
#[derive(Clone, Copy, Debug)]
struct Held {
    geom: Geom,
    shape: Shape,
    feed: Feed,
    src: Src,
    /// the output start point (offset, not yet moved by the tip), plane
    /// coordinates; for the start block: the programmed start
    from: P2,
    /// the start block (G41/G42): it runs from the uncompensated point
    start_block: bool,
}

/// What waits behind the held element.
#[derive(Clone, Copy, Debug)]
enum Queued {
    /// a move of the normal axis only: (feed, src, where to) on that axis
    Axial(Feed, Src, f64),
    Other(Event),
}

/// The compensation stage.
#[derive(Debug)]
pub(crate) struct Comp {
    /// in force for the output
    active: Option<Mode>,
    /// programmed (takes effect at the next move in the plane)
    want: Option<Mode>,
    round_outside: bool,
    /// the tool's geometry offset (subtracted from every output point)
    geo: V3,
    held: Option<Held>,
    queue: Vec<Queued>,
    /// the last output point (machine coordinates, after tip and offset)
    last: V3,
    /// a new geometry offset is in force and no move has taken it up yet:
    /// the next move starts with a line from where the tool stands
    offset_due: bool,
    /// the element before the next was refused (an arc not larger than the
    /// tool): the next joins the one before it without a second error
    after_refused: bool,
}

/// A block's name in messages: its N number, else its line.
pub(crate) fn block_name(src: Src) -> String {
    match src.block_no {
        Some(n) => format!("N{n}"),
        None => format!("line {}", src.line),
    }
}

impl Comp {
    pub(crate) fn new(round_outside: bool, home: V3) -> Self {
        Comp {
            active: None,
            want: None,
            round_outside,
            geo: V3::zeros(),
            held: None,
            queue: Vec::new(),
            last: home,
            offset_due: false,
            after_refused: false,
        }
    }

    /// Nothing to do: no compensation, nothing held, no geometry offset
    /// (in force, or changed and not yet taken up).
    #[inline]
    pub(crate) fn idle(&self) -> bool {
        self.active.is_none()
            && self.want.is_none()
            && self.held.is_none()
            && self.geo == V3::zeros()
            && !self.offset_due
    }

    /// A command that went by while the stage was idle: where the tool
    /// stands after it.
    #[inline]
    pub(crate) fn passed(&mut self, ev: &Event) {
        match ev {
            Event::Move { geom, .. } => self.last = geom.end(),
            Event::Thread(m) => self.last = m.seg.end,
            _ => {}
        }
    }

    pub(crate) fn active(&self) -> bool {
        self.active.is_some() || self.want.is_some()
    }

    /// G40 (None), G41/G42 (Some), from the next move in the plane on.
    pub(crate) fn set_mode(&mut self, m: Option<Mode>) {
        self.want = m;
    }

    /// The selected tool's geometry offset, taken up by the next move
    /// (`docs/compensation.md` §6): that move starts with a line, at its
    /// own feed, from where the tool stands to its start with the new
    /// offset, so the setpoints never jump.
    pub(crate) fn set_geometry_offset(&mut self, g: V3) {
        if g != self.geo {
            self.offset_due = true;
        }
        self.geo = g;
    }

    fn shift(&self) -> V3 {
        self.active.map_or(V3::zeros(), |m| m.tip) - self.geo
    }

    /// Machine point from plane coordinates `p2` and the other coordinates
    /// of `base`, moved by `shift`.
    fn point(plane: Plane, p2: P2, base: V3, shift: V3) -> V3 {
        let (p, q, _) = plane.axes();
        let mut v = base;
        v[p] = p2.0;
        v[q] = p2.1;
        v + shift
    }

    fn out_move(
        &mut self,
        geom: Geom,
        feed: Feed,
        src: Src,
        out: &mut std::collections::VecDeque<Event>,
    ) {
        if self.offset_due {
            // a new geometry offset: from where the tool stands
            self.offset_due = false;
            let start = geom.start();
            if start != self.last {
                out.push_back(Event::Move {
                    geom: Geom::Line {
                        start: self.last,
                        end: start,
                    },
                    feed,
                    src,
                });
                self.last = start;
            }
        }
        if geom.length() > 0.0 {
            self.last = geom.end();
            out.push_back(Event::Move { geom, feed, src });
        }
    }

    /// Takes one event; compensated events go to `out`, errors to `errs`.
    pub(crate) fn push(
        &mut self,
        ev: Event,
        out: &mut std::collections::VecDeque<Event>,
        errs: &mut Vec<String>,
    ) {
        let Event::Move { geom, feed, src } = ev else {
            if let Event::End { .. } = ev {
                self.release_nominal(out, errs);
            }
            let mut ev = ev;
            if let Event::Thread(m) = &mut ev {
                // a thread is cut where the tool's offset puts it; it starts
                // where the move before it ended
                if self.offset_due {
                    self.offset_due = false;
                    errs.push(format!(
                        "the G33 block {} follows a tool change that changes the geometry offset: program a positioning move (G00/G01) to the thread's start before it",
                        block_name(m.src)
                    ));
                }
                for p in [&mut m.seg.start, &mut m.seg.prog_end, &mut m.seg.end] {
                    *p -= self.geo;
                }
                self.last = m.seg.end;
            }
            if self.held.is_some() {
                self.queue.push(Queued::Other(ev));
            } else {
                out.push_back(ev);
            }
            return;
        };
        let plane = self.want.or(self.active).map(|m| m.plane);
        let shape = plane.and_then(|pl| Shape::of(&geom, pl));
        let Some(shape) = shape else {
            // no motion in the plane (or compensation off): at the current
            // offset point
            self.axial(geom, feed, src, out);
            return;
        };
        let plane = plane.unwrap_or(Plane::XY);
        match (self.active, self.want) {
            (None, Some(m)) => {
                // the start block: from the uncompensated point
                if !matches!(shape, Shape::Line { .. }) {
                    errs.push(format!(
                        "radius compensation (G41/G42) must start on a line (G00/G01), but block {} is an arc",
                        block_name(src)
                    ));
                }
                let (p, q, _) = plane.axes();
                self.active = Some(m);
                self.held = Some(Held {
                    geom,
                    shape,
                    feed,
                    src,
                    from: (geom.start()[p], geom.start()[q]),
                    start_block: true,
                });
            }
            (Some(_), None) => {
                // the end block: from the last compensated point to the
                // programmed end
                if !matches!(shape, Shape::Line { .. }) {
                    errs.push(format!(
                        "radius compensation is cancelled (G40) on a line (G00/G01), but block {} is an arc",
                        block_name(src)
                    ));
                }
                self.release_nominal(out, errs);
                self.active = None;
                let end = geom.end() - self.geo;
                let g = Geom::Line {
                    start: self.last,
                    end,
                };
                self.out_move(g, feed, src, out);
            }
            (Some(m), Some(w)) if m != w => {
                errs.push(format!(
                    "radius compensation changes side, tool or plane in block {} while it is active: cancel it with G40 first",
                    block_name(src)
                ));
                self.want = self.active;
                self.next_element(m, geom, shape, feed, src, out, errs);
            }
            (Some(m), Some(_)) => self.next_element(m, geom, shape, feed, src, out, errs),
            (None, None) => {
                // geometry offset only
                let g = translate(&geom, -self.geo);
                self.out_move(g, feed, src, out);
            }
        }
    }

    /// A move without motion in the plane.
    fn axial(
        &mut self,
        geom: Geom,
        feed: Feed,
        src: Src,
        out: &mut std::collections::VecDeque<Event>,
    ) {
        if self.held.is_some() {
            let n = self.active.or(self.want).map_or(2, |m| m.plane.axes().2);
            self.queue.push(Queued::Axial(feed, src, geom.end()[n]));
            return;
        }
        if self.active.is_some() {
            let (p, q, _) = self.active.map_or(Plane::XY, |m| m.plane).axes();
            let mut end = geom.end() - self.geo + self.shift();
            end[p] = self.last[p];
            end[q] = self.last[q];
            let g = Geom::Line {
                start: self.last,
                end,
            };
            self.out_move(g, feed, src, out);
        } else {
            let g = translate(&geom, -self.geo);
            self.out_move(g, feed, src, out);
        }
    }

    /// The held element ends at its own offset end point (no next element:
    /// G40 or the end of the program).
    fn release_nominal(
        &mut self,
        out: &mut std::collections::VecDeque<Event>,
        errs: &mut Vec<String>,
    ) {
        let Some(h) = self.held.take() else {
            return;
        };
        let Some(m) = self.active else {
            return;
        };
        let to = h.shape.offset_end(m.side, m.radius);
        self.emit_held(&h, m, to, out, errs);
        self.flush_queue(m, out);
    }

    #[allow(clippy::too_many_arguments)]
    fn next_element(
        &mut self,
        m: Mode,
        geom: Geom,
        shape: Shape,
        feed: Feed,
        src: Src,
        out: &mut std::collections::VecDeque<Event>,
        errs: &mut Vec<String>,
    ) {
        let (side, rt) = (m.side, m.radius);
        if shape.offset_radius(side, rt) <= 1e-9 {
            if let Shape::Arc { r, .. } = shape {
                errs.push(format!(
                    "radius compensation: the arc of block {} (radius {}) is not larger than the tool radius {}: the tool would cut into the contour",
                    block_name(src),
                    crate::diag::num(r),
                    crate::diag::num(rt)
                ));
                self.after_refused = true;
                return;
            }
        }
        let after_refused = std::mem::take(&mut self.after_refused);
        let Some(h) = self.held.take() else {
            // (compensation already on and nothing held: after a G40-less
            // program end) start from where the tool is
            let (p, q, _) = m.plane.axes();
            let at = self.last - self.shift();
            self.hold(geom, shape, feed, src, (at[p], at[q]));
            return;
        };
        let pb = shape.offset_start(side, rt);
        let mut next_from = pb;
        if h.start_block {
            // the start block ends perpendicular to the next element's
            // first direction
            self.emit_held(&h, m, pb, out, errs);
        } else {
            let pa = h.shape.offset_end(side, rt);
            let corner = h.shape.end();
            if norm(sub(pa, pb)) <= 1e-9 {
                self.emit_held(&h, m, pa, out, errs);
            } else {
                let turn = cross(h.shape.end_dir(), shape.start_dir());
                let outside = side * turn < 0.0;
                if outside && self.round_outside {
                    self.emit_held(&h, m, pa, out, errs);
                    self.flush_queue(m, out);
                    // an arc of the tool radius about the corner point
                    let base = geom.start();
                    let start = Self::point(m.plane, pa, base, self.shift());
                    let end = Self::point(m.plane, pb, base, self.shift());
                    let center = Self::point(m.plane, corner, base, self.shift());
                    let mut arc = Arc::new(start, end, center, m.plane, turn > 0.0, 0);
                    let sweep = wrap(
                        (pb.1 - corner.1).atan2(pb.0 - corner.0)
                            - (pa.1 - corner.1).atan2(pa.0 - corner.0),
                    );
                    arc.set_sweep(sweep);
                    self.out_move(Geom::Arc(arc), feed, src, out);
                    self.hold(geom, shape, feed, src, pb);
                    return;
                }
                let cands = intersect(&h.shape, &shape, side, rt);
                let best = cands
                    .into_iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .min_by(|x, y| {
                        norm(sub(*x, corner))
                            .partial_cmp(&norm(sub(*y, corner)))
                            .unwrap_or(std::cmp::Ordering::Equal)
                    });
                match best {
                    Some(j) if norm(sub(j, corner)) <= 1000.0 * rt.max(1e-3) => {
                        self.emit_held(&h, m, j, out, errs);
                        next_from = j;
                    }
                    // (across a refused element the two were never meant
                    // to meet: that element's error says what is wrong)
                    _ if after_refused => {
                        self.emit_held(&h, m, pa, out, errs);
                        next_from = pb;
                    }
                    _ => {
                        errs.push(format!(
                            "radius compensation: the offset paths of blocks {} and {} do not intersect (tool radius {}): program a transition radius or a chamfer of at least 0.01 mm between them",
                            block_name(h.src),
                            block_name(src),
                            crate::diag::num(rt)
                        ));
                        self.emit_held(&h, m, pa, out, errs);
                        next_from = pb;
                    }
                }
            }
        }
        self.flush_queue(m, out);
        self.hold(geom, shape, feed, src, next_from);
    }

    fn hold(&mut self, geom: Geom, shape: Shape, feed: Feed, src: Src, from: P2) {
        self.held = Some(Held {
            geom,
            shape,
            feed,
            src,
            from,
            start_block: false,
        });
    }

    /// Emits the held element from its start to `to` (plane coordinates of
    /// the offset path), checking that its offset does not reverse.
    fn emit_held(
        &mut self,
        h: &Held,
        m: Mode,
        to: P2,
        out: &mut std::collections::VecDeque<Event>,
        errs: &mut Vec<String>,
    ) {
        let shift = self.shift();
        let plane = m.plane;
        if h.start_block {
            let start = h.geom.start() - self.geo;
            let end = Self::point(plane, to, h.geom.end(), shift);
            self.out_move(Geom::Line { start, end }, h.feed, h.src, out);
            return;
        }
        let start = Self::point(plane, h.from, h.geom.start(), shift);
        let end = Self::point(plane, to, h.geom.end(), shift);
        match h.shape {
            Shape::Line { u, .. } => {
                let d = sub(to, h.from);
                if dot(d, u) < -1e-9 {
                    errs.push(reversed(h.src, m.radius));
                    return;
                }
                self.out_move(Geom::Line { start, end }, h.feed, h.src, out);
            }
            Shape::Arc {
                c, sweep, t0, t1, ..
            } => {
                let a0 = (h.from.1 - c.1).atan2(h.from.0 - c.0);
                let a1 = (to.1 - c.1).atan2(to.0 - c.0);
                let s = sweep + wrap(a1 - t1) - wrap(a0 - t0);
                if s * sweep < 0.0 && s.abs() > 1e-9 {
                    errs.push(reversed(h.src, m.radius));
                    return;
                }
                let center = Self::point(plane, c, h.geom.start(), shift);
                let turns = ((s.abs() - 1e-9) / TAU).floor().max(0.0) as u32;
                let mut arc = Arc::new(start, end, center, plane, sweep > 0.0, turns);
                arc.set_sweep(s);
                self.out_move(Geom::Arc(arc), h.feed, h.src, out);
            }
        }
    }

    fn flush_queue(&mut self, m: Mode, out: &mut std::collections::VecDeque<Event>) {
        let n = m.plane.axes().2;
        for q in std::mem::take(&mut self.queue) {
            match q {
                Queued::Axial(feed, src, to) => {
                    let mut end = self.last;
                    end[n] = to - self.geo[n] + self.shift()[n];
                    let g = Geom::Line {
                        start: self.last,
                        end,
                    };
                    self.out_move(g, feed, src, out);
                }
                Queued::Other(ev) => out.push_back(ev),
            }
        }
    }
}

fn reversed(src: Src, r: f64) -> String {
    format!(
        "radius compensation: block {} is too short for the tool radius {}: its offset path would run backwards and the tool would cut into the contour",
        block_name(src),
        crate::diag::num(r)
    )
}

/// `g` moved by `d`.
fn translate(g: &Geom, d: V3) -> Geom {
    match g {
        Geom::Line { start, end } => Geom::Line {
            start: start + d,
            end: end + d,
        },
        Geom::Arc(a) => {
            let mut a = *a;
            a.start += d;
            a.end += d;
            a.center += d;
            Geom::Arc(a)
        }
    }
}
