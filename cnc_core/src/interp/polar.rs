//! Polar coordinates about a pole (`docs/dialects.md` §3): the pole by
//! centre words alone or where the tool stands, polar lines by radius and
//! angle, polar arcs about the pole.

use super::modal::Motion;
use super::state::Interpreter;
use super::words::{slot, Words, CENTER_LETTERS};
use crate::canon::{Canon, Feed, Src};
use crate::diag::num;
use crate::geom::{Arc, Geom};
use crate::source::ProgramSource;

/// cos and sin of an angle in degrees, exact at multiples of 90 degrees
/// (so H+180 lands exactly on its point).
pub(super) fn cos_sin_deg(deg: f64) -> (f64, f64) {
    let d = deg.rem_euclid(360.0);
    if d == 0.0 {
        (1.0, 0.0)
    } else if d == 90.0 {
        (0.0, 1.0)
    } else if d == 180.0 {
        (-1.0, 0.0)
    } else if d == 270.0 {
        (0.0, -1.0)
    } else {
        let r = deg.to_radians();
        (r.cos(), r.sin())
    }
}

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// Blocks that set the pole: I/J (plane-dependent) with no motion, in
    /// a dialect whose centre words alone set it, or G29 (the pole where
    /// the tool stands). False: the block is done.
    #[inline]
    pub(super) fn pole_block(&mut self, w: &Words) -> bool {
        // (nothing to do without G29 in a dialect whose centres do not set
        // the pole)
        if !w.has(slot::POLE_HERE) && !self.rules.centres_set_pole {
            return true;
        }
        self.pole_rules(w)
    }

    /// [`pole_block`](Self::pole_block) with something to do.
    #[inline(never)]
    fn pole_rules(&mut self, w: &Words) -> bool {
        // (in the plane the block itself selects, if it does)
        let plane = if w.has(slot::PLANE) {
            w.plane
        } else {
            self.modal.plane
        };
        let (p, q, n) = plane.axes();
        if w.has(slot::POLE_HERE) {
            self.pole = Some(self.pos);
            return true;
        }
        if !self.rules.centres_set_pole {
            return true;
        }
        let has_center = w.centers().any(|c| c.is_some());
        let explicit_arc =
            w.has(slot::MOTION) && matches!(w.motion, Motion::CwArc | Motion::CcwArc);
        let has_axis = w.axes().any(|a| a.is_some());
        if !has_center || explicit_arc || has_axis {
            return true;
        }
        // a pole block (CC): absolute coordinates of the pole in the plane
        if let Some(c) = w.center(n) {
            self.error(
                Some(&c),
                format!(
                    "{} is no pole coordinate in {}: the pole is {} and {}",
                    c.letter as char,
                    plane.gcode(),
                    CENTER_LETTERS[p] as char,
                    CENTER_LETTERS[q] as char
                ),
            );
        }
        if let Some(m) = w.get(slot::MOTION).filter(|_| w.motion.polar()) {
            self.error(
                Some(&m),
                "a pole block (I, J) does not move: program the polar move in the next block"
                    .into(),
            );
        }
        let mut pole = self.pole.unwrap_or(self.pos);
        for i in [p, q] {
            match w.center(i) {
                Some(c) => {
                    pole[i] = if i == 0 && self.diameter {
                        c.value * 0.5
                    } else {
                        c.value
                    }
                }
                None if self.pole.is_none() => pole[i] = self.pos[i],
                None => {}
            }
        }
        self.pole = Some(pole);
        false
    }

    /// G10/G11 polar lines and G12/G13/G15 polar arcs about the pole.
    #[inline(never)]
    pub(super) fn exec_polar(&mut self, w: &Words, src: Src) {
        let motion = self.modal.motion;
        let (p, q, n) = self.modal.plane.axes();
        let anchor = w.get(slot::MOTION).or(w.get(slot::H)).or(w.get(slot::R));
        if let Some(c) = w.centers().flatten().next() {
            self.error(
                Some(&c),
                "a polar block takes no I, J, K: set the pole in a block of its own".into(),
            );
            return;
        }
        for i in [p, q] {
            if let Some(a) = w.axis(i) {
                self.error(
                    Some(&a),
                    format!(
                        "{} is an axis of the {} plane: a polar block gives its end point by R and H",
                        a.letter as char,
                        self.modal.plane.gcode()
                    ),
                );
                return;
            }
        }
        let (h, r) = (w.get(slot::H), w.get(slot::R));
        if h.is_none() && r.is_none() && w.axis(n).is_none() {
            return; // only the modal G code
        }
        let Some(pole) = self.pole else {
            self.error(
                anchor.as_ref(),
                "a polar block needs a pole: a block with I and J (or G29) before it".into(),
            );
            return;
        };
        let abs = self.modal.absolute;
        // the normal axis, linearly (a helix in an arc block)
        let mut target = self.pos;
        if let Some(a) = w.axis(n) {
            target[n] = self.axis_target(n, &a, abs);
        }
        let (sp, sq) = (self.pos[p] - pole[p], self.pos[q] - pole[q]);
        let feed = match motion {
            Motion::PolarRapid => Some(Feed::Rapid),
            _ => self.feed_for(anchor.as_ref(), w),
        };
        if matches!(motion, Motion::PolarRapid | Motion::PolarLine) {
            if let Some(h) = h.filter(|h| h.value.abs() > 360.0) {
                self.error(
                    Some(&h),
                    format!(
                        "polar angle H{} is outside -360..+360 degrees for a line",
                        num(h.value)
                    ),
                );
                return;
            }
            let last_r = self.polar_r.unwrap_or_else(|| sp.hypot(sq));
            let last_h = self.polar_h.unwrap_or_else(|| sq.atan2(sp).to_degrees());
            let rr = match r {
                Some(r) if abs => r.value,
                Some(r) => last_r + r.value,
                None => last_r,
            };
            let hh = match h {
                Some(h) if abs => h.value,
                Some(h) => last_h + h.value,
                None => last_h,
            };
            if rr <= 0.0 {
                self.error(
                    r.as_ref().or(anchor.as_ref()),
                    format!("polar radius R must be greater than 0, it is {}", num(rr)),
                );
                return;
            }
            self.polar_r = Some(rr);
            self.polar_h = Some(hh);
            let (c, sn) = cos_sin_deg(hh);
            target[p] = pole[p] + rr * c;
            target[q] = pole[q] + rr * sn;
            let start = self.pos;
            self.pos = target;
            self.polar_end = Some((target, pole, self.modal.plane));
            let line = Geom::Line { start, end: target };
            self.add_move(&line, feed, w, anchor.as_ref(), src);
            return;
        }
        // polar arcs
        let ccw = motion == Motion::PolarCcw;
        self.last_ccw = Some(ccw);
        if let Some(r) = r {
            self.error(Some(&r), "a polar arc takes no R: its radius is the distance from the start point to the pole".into());
            return;
        }
        // the radius and start angle: those of the polar move that ended
        // here (exactly as programmed, so that H+90 lands exactly on
        // pole + R), else from the coordinates
        let (radius, start_deg) = match (self.polar_end, self.polar_r, self.polar_h) {
            (Some(e), Some(r), Some(h)) if e == (self.pos, pole, self.modal.plane) => (r, h),
            _ => (sp.hypot(sq), sq.atan2(sp).to_degrees()),
        };
        if radius < 1e-6 {
            self.error(
                anchor.as_ref(),
                "a polar arc cannot start on its pole".into(),
            );
            return;
        }
        let Some(h) = h else {
            self.error(
                anchor.as_ref(),
                format!("{} needs the end angle H", motion.gcode()),
            );
            return;
        };
        if h.value.abs() > 5400.0 {
            self.error(
                Some(&h),
                format!(
                    "polar angle H{} is outside -5400..+5400 degrees for an arc",
                    num(h.value)
                ),
            );
            return;
        }
        // the signed sweep, degrees
        let sweep = if abs {
            let mut d = h.value - start_deg;
            if ccw {
                d = d.rem_euclid(360.0);
                if d < 1e-9 {
                    d = 360.0;
                }
            } else {
                d = -(-d).rem_euclid(360.0);
                if d > -1e-9 {
                    d = -360.0;
                }
            }
            d
        } else {
            if h.value == 0.0 {
                self.error(
                    Some(&h),
                    format!(
                        "incremental H0 turns nothing: {} needs the angle it turns, + for G13, - for G12 (a whole circle is H+360 or H-360)",
                        motion.gcode()
                    ),
                );
                return;
            }
            if (h.value > 0.0) != ccw {
                self.error(
                    Some(&h),
                    format!(
                        "incremental H{} turns {} but {} turns {}: the sign must match the direction (+ for G13, - for G12)",
                        num(h.value),
                        if h.value > 0.0 { "counter-clockwise" } else { "clockwise" },
                        motion.gcode(),
                        if ccw { "counter-clockwise" } else { "clockwise" }
                    ),
                );
                return;
            }
            h.value
        };
        // whole turns end exactly where they started
        let turns_f = sweep.abs() / 360.0;
        let whole = turns_f.fract() == 0.0;
        let end_deg = start_deg + sweep;
        if whole {
            target[p] = self.pos[p];
            target[q] = self.pos[q];
        } else {
            let (c, sn) = cos_sin_deg(end_deg);
            target[p] = pole[p] + radius * c;
            target[q] = pole[q] + radius * sn;
        }
        let extra = if whole {
            turns_f as u32 - 1
        } else {
            turns_f.floor() as u32
        };
        let mut arc = Arc::new(self.pos, target, pole, self.modal.plane, ccw, extra);
        // the pole is the centre and the polar radius the radius: start and
        // end lie on that circle by construction, so the centre is not moved
        // onto their bisector (which, for an end close to the start, moves
        // it by the rounding of their coordinates over their distance)
        arc.center[p] = pole[p];
        arc.center[q] = pole[q];
        arc.radius = radius;
        arc.theta0 = sq.atan2(sp);
        arc.set_sweep(sweep.to_radians());
        self.polar_r = Some(radius);
        self.polar_h = Some(end_deg.rem_euclid(360.0));
        self.pos = target;
        self.polar_end = Some((target, pole, self.modal.plane));
        self.add_move(&Geom::Arc(arc), feed, w, anchor.as_ref(), src);
    }
}
