//! Moves as programmed: lines and arcs (the radius check), dwells, the
//! feed, targets from axis words (lathe X as diameter), and the travel
//! limits and bounding box of the path as programmed.

use super::modal::Motion;
use super::state::Interpreter;
use super::words::{slot, Words, CENTER_LETTERS};
use crate::canon::{Canon, Event, Feed, Src, MIN_FEED_MM_MIN};
use crate::diag::num;
use crate::geom::V3;
use crate::geom::{Arc, Geom};
use crate::parse::Word;
use crate::source::ProgramSource;
use crate::travel::{self};

/// Largest radius difference between an arc's start and end, mm.
pub const ARC_TOLERANCE_MM: f64 = 0.002;

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    #[inline(never)]
    pub(super) fn exec_dwell(&mut self, w: &Words, g4: &Word, src: Src) {
        let mut time: Option<Word> = w.p();
        if self.rules.dwell_time_in_f && time.is_none() {
            time = w.f();
        }
        if time.is_none() {
            time = w.axis(0);
        }
        let first_other = w
            .axes()
            .skip(if w.p().is_none() { 1 } else { 0 })
            .flatten()
            .next();
        if let Some(o) = first_other.filter(|o| Some(*o) != time) {
            self.error(
                Some(&o),
                "G04 (dwell) cannot move an axis; the dwell time is P (seconds)".into(),
            );
        }
        if let Some(m) = w.get(slot::MOTION) {
            self.error(
                Some(&m),
                "G04 (dwell) and a motion G code cannot share a block".into(),
            );
        }
        match time {
            Some(t) if t.value >= 0.0 && t.value <= 100_000.0 => {
                if t.value > 0.0 {
                    self.emit(Event::Dwell {
                        seconds: t.value,
                        src,
                    });
                }
            }
            Some(t) => self.error(
                Some(&t),
                format!("dwell time must be 0..100000 s, found {}", num(t.value)),
            ),
            None => self.error(Some(g4), "G04 needs a dwell time: P<seconds>".into()),
        }
    }

    pub(super) fn exec_motion(&mut self, w: &Words, src: Src) {
        if self.modal.motion.polar() {
            self.exec_polar(w, src);
            return;
        }
        for s in [slot::R, slot::H] {
            if let Some(x) = w.get(s) {
                self.error(
                    Some(&x),
                    format!(
                        "{} is a polar coordinate: it needs G10, G11, G12, G13 or G15",
                        x.letter as char
                    ),
                );
            }
        }
        let has_axis = w.axes().any(|a| a.is_some());
        let has_center = w.centers().any(|c| c.is_some());
        let motion = self.modal.motion;
        let arc = matches!(motion, Motion::CwArc | Motion::CcwArc);
        if has_center && !arc {
            let c = w.centers().flatten().next();
            self.error(
                c.as_ref(),
                format!(
                    "centre offsets I/J/K need G02 or G03, but {} is active",
                    motion.gcode()
                ),
            );
        }
        if !(has_axis || arc && has_center) {
            return;
        }
        // target position
        let mut target = self.target_of(w);
        let anchor = w.get(slot::MOTION).or_else(|| w.axes().flatten().next());
        // feed
        let feed = match motion {
            Motion::Rapid => Some(Feed::Rapid),
            _ => self.feed_for(anchor.as_ref(), w),
        };
        // geometry (built in place and passed on by reference: moving the
        // large `Geom` values around cost more than computing them)
        let start = self.pos;
        if arc {
            let mut arc = self.arc_geom(w, target, motion == Motion::CcwArc, anchor.as_ref());
            let mut feed = feed;
            if let Some(a) = arc.as_mut() {
                feed = self.drag_helix(
                    a,
                    &mut target,
                    motion == Motion::CcwArc,
                    feed,
                    anchor.as_ref(),
                );
            }
            self.pos = target;
            if let Some(arc) = arc {
                self.add_move(&Geom::Arc(arc), feed, w, anchor.as_ref(), src);
            }
        } else {
            self.pos = target;
            let line = Geom::Line { start, end: target };
            self.add_move(&line, feed, w, anchor.as_ref(), src);
        }
    }

    /// Checks a move's travel, adds it to the bounding box and queues it
    /// (if it has a feed).
    pub(super) fn add_move(
        &mut self,
        geom: &Geom,
        feed: Option<Feed>,
        w: &Words,
        anchor: Option<&Word>,
        src: Src,
    ) {
        if geom.length() == 0.0 {
            return;
        }
        // (with radius compensation the commanded path is checked as it
        // leaves the compensation, in `emit`)
        if self.canon.passes_through() && !self.changes_nothing(geom) {
            let (lo, hi) = geom.bbox();
            self.check_travel(geom, (lo, hi), w, anchor);
            self.grow_bbox(lo, hi);
        }
        if let Some(feed) = feed {
            self.emit(Event::Move {
                geom: *geom,
                feed,
                src,
            });
        }
    }

    pub(super) fn feed_for(&mut self, anchor: Option<&Word>, w: &Words) -> Option<Feed> {
        // (where a feed error points: the F word, else the motion's word)
        let at = w.f().or(anchor.copied());
        let f = match self.modal.feed {
            Some(f) if f > 0.0 => f,
            _ => {
                let unit = if self.modal.per_rev {
                    "mm/rev"
                } else {
                    "mm/min"
                };
                self.error(at.as_ref(), format!(
                    "missing feed: {} needs a feed F ({unit}) greater than 0, programmed in this block or before",
                    self.modal.motion.gcode()
                ));
                return None;
            }
        };
        if self.modal.per_rev {
            let rpm = self.modal.spindle_rpm();
            if rpm == 0.0 {
                self.error(anchor, "G95 feed per revolution needs the spindle turning (M03/M04 with S greater than 0)".into());
                return None;
            }
            if f * rpm.abs() < MIN_FEED_MM_MIN {
                self.error(
                    at.as_ref(),
                    format!(
                        "feed F{f} mm/rev at S{} is under the smallest feed, {} mm/min",
                        rpm.abs(),
                        num(MIN_FEED_MM_MIN)
                    ),
                );
                return None;
            }
            Some(Feed::PerRev { mm_per_rev: f, rpm })
        } else if f < MIN_FEED_MM_MIN {
            self.error(
                at.as_ref(),
                format!(
                    "feed F{f} mm/min is under the smallest feed, {} mm/min",
                    num(MIN_FEED_MM_MIN)
                ),
            );
            None
        } else {
            Some(Feed::PerMin(f))
        }
    }

    pub(super) fn arc_geom(
        &mut self,
        w: &Words,
        target: V3,
        ccw: bool,
        anchor: Option<&Word>,
    ) -> Option<Arc> {
        let plane = self.modal.plane;
        let (p, q, n) = plane.axes();
        if let Some(c) = w.center(n) {
            self.error(
                Some(&c),
                format!(
                    "centre offset {} does not belong to the {} plane (use {} and {})",
                    c.letter as char,
                    plane.gcode(),
                    CENTER_LETTERS[p] as char,
                    CENTER_LETTERS[q] as char
                ),
            );
        }
        if w.center(p).is_none() && w.center(q).is_none() {
            self.error(
                anchor,
                format!(
                    "arc needs its centre: {} and/or {} (offsets from the start point) in {}",
                    CENTER_LETTERS[p] as char,
                    CENTER_LETTERS[q] as char,
                    plane.gcode()
                ),
            );
            return None;
        }
        let mut center = self.pos;
        for i in [p, q] {
            if let Some(c) = w.center(i) {
                center[i] += c.value;
            }
        }
        let start = self.pos;
        let r0 = ((start[p] - center[p]).powi(2) + (start[q] - center[q]).powi(2)).sqrt();
        let r1 = ((target[p] - center[p]).powi(2) + (target[q] - center[q]).powi(2)).sqrt();
        let at = w.center(p).or(w.center(q));
        if r0 < 1e-6 {
            self.error(
                at.as_ref(),
                "arc radius is zero: the centre is the start point".into(),
            );
            return None;
        }
        if (r0 - r1).abs() > ARC_TOLERANCE_MM {
            self.error(anchor.or(at.as_ref()), format!(
                "arc radius mismatch: start radius {} mm, end radius {} mm (difference {} mm, at most {} mm)",
                num(r0), num(r1), num((r0 - r1).abs()), ARC_TOLERANCE_MM
            ));
            return None;
        }
        Some(Arc::new(start, target, center, plane, ccw, 0))
    }

    /// True for an arc whose whole circle (and end points) lies strictly
    /// inside the bounding box so far and within the travel limits: its
    /// exact box (four divisions) then changes neither the bounding box nor
    /// the errors, so the caller may skip it. Every value `Geom::bbox` can
    /// return is one of start, end and centre ± radius, exactly as computed
    /// here, so the exact box lies within this one; and `min`/`max` against
    /// a strictly smaller/larger value return that value unchanged.
    #[inline]
    pub(super) fn changes_nothing(&self, geom: &Geom) -> bool {
        let (Geom::Arc(a), Some((box_lo, box_hi))) = (geom, self.bbox) else {
            return false;
        };
        let (p, q, _) = a.plane.axes();
        let mut lo = a.start.inf(&a.end);
        let mut hi = a.start.sup(&a.end);
        for i in [p, q] {
            lo[i] = lo[i].min(a.center[i] - a.radius);
            hi[i] = hi[i].max(a.center[i] + a.radius);
        }
        (0..3)
            .all(|i| lo[i] > box_lo[i] && hi[i] < box_hi[i] && self.travel.within(i, lo[i], hi[i]))
    }

    /// Reports the first point of `geom` (bounding box `lo`, `hi`) outside
    /// each axis's travel.
    pub(super) fn check_travel(
        &mut self,
        geom: &Geom,
        (lo, hi): (V3, V3),
        w: &Words,
        anchor: Option<&Word>,
    ) {
        let is_arc = matches!(geom, Geom::Arc(_));
        for i in 0..3 {
            if let Some((v, text)) = self.travel.exceeded(i, geom.start()[i], lo[i], hi[i]) {
                let at = w.axis(i).or(anchor.copied());
                let how = if is_arc && v != geom.end()[i] {
                    "the arc reaches"
                } else {
                    "the move ends at"
                };
                self.error(at.as_ref(), format!("travel limit: {how} {text}"));
            }
        }
    }

    /// Adds a move's extent to the bounding box.
    pub(super) fn grow_bbox(&mut self, lo: V3, hi: V3) {
        travel::grow(&mut self.bbox, lo, hi);
    }

    /// Axis `i`'s word `a` in machine coordinates (lathe X: the radius),
    /// absolute or from the current position.
    pub(super) fn axis_target(&self, i: usize, a: &Word, absolute: bool) -> f64 {
        let v = if i == 0 && self.diameter {
            a.value * 0.5
        } else {
            a.value
        };
        if absolute {
            v
        } else {
            self.pos[i] + v
        }
    }

    /// The block's end point from its axis words (the others stay).
    pub(super) fn target_of(&self, w: &Words) -> V3 {
        let mut target = self.pos;
        for i in 0..3 {
            if let Some(a) = w.axis(i) {
                target[i] = self.axis_target(i, &a, self.modal.absolute);
            }
        }
        target
    }
}
