//! G33 threads (`docs/dialects.md` §2.3): the block rules, and each
//! block's run-in, deceleration and runout as [`crate::thread`] fits them
//! to the axes; a thread block is held until the next block says whether
//! the chain goes on.

use super::state::{Held, Interpreter};
use super::words::{slot, Words, AXIS_LETTERS};
use crate::canon::{Canon, Event, RunoutPath, Src, ThreadMove, ThreadSeg, MIN_FEED_MM_MIN};
use crate::diag::{num, Diagnostic};
use crate::geom::Geom;
use crate::geom::V3;
use crate::parse::Word;
use crate::source::ProgramSource;
use crate::thread::{self, FitError};

/// A length for a message, rounded up to the micrometre (a hair over a
/// whole micrometre from rounding is not rounded up).
pub(super) fn round_up(v: f64) -> String {
    num((v * 1000.0 - 1e-6).ceil() / 1000.0)
}

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// G33: a thread block (cnc836). It is held back until the next block
    /// says whether the thread goes on (a chain) or ends here.
    #[inline(never)]
    pub(super) fn exec_thread(&mut self, w: &Words, g33: &Word, src: Src, prev: Option<V3>) {
        let chained = prev.is_some();
        if let Some(m) = w.get(slot::MOTION) {
            self.error(
                Some(&m),
                format!(
                    "G33 (thread) and {} cannot share a block",
                    self.modal.motion.gcode()
                ),
            );
            return;
        }
        if let Some(k) = w.center(2) {
            self.error(
                Some(&k),
                "K is not an address of G33: I is the start angle, J the runout".into(),
            );
            return;
        }
        let rpm = self.modal.spindle_rpm();
        if rpm == 0.0 {
            self.error(
                Some(g33),
                "G33 (thread) needs the spindle turning: M03 or M04 with S greater than 0, in this block or before".into(),
            );
            return;
        }
        if chained {
            if let Some(x) = w.s().or(w.get(slot::SPINDLE)) {
                self.error(
                    Some(&x),
                    "S and M03/M04/M05 may only stand in the first G33 block of a thread: this block continues the thread in phase".into(),
                );
                return;
            }
        }
        let pitch = match w.f() {
            Some(f) if !(f.value > 0.0 && f.value <= 99.99) => {
                self.error(
                    Some(&f),
                    format!(
                        "thread pitch F must be greater than 0 and at most 99.99 mm/rev, found F{}",
                        num(f.value)
                    ),
                );
                return;
            }
            Some(f) => f.value,
            None => match self.thread_pitch {
                Some(p) => p,
                None => {
                    self.error(
                        Some(g33),
                        "G33 (thread) needs the pitch F in mm/rev (0 < F <= 99.99)".into(),
                    );
                    return;
                }
            },
        };
        if pitch * rpm.abs() < MIN_FEED_MM_MIN {
            self.error(
                Some(w.f().as_ref().unwrap_or(g33)),
                format!(
                    "thread pitch F{pitch} mm/rev at S{} leads under the smallest feed, {} mm/min",
                    rpm.abs(),
                    num(MIN_FEED_MM_MIN)
                ),
            );
            return;
        }
        self.thread_pitch = Some(pitch);
        if !w.axes().any(|a| a.is_some()) {
            self.error(
                Some(g33),
                "G33 (thread) needs the thread's end point (an axis word)".into(),
            );
            return;
        }
        let target = self.target_of(w);
        let anchor = w.axes().flatten().next().unwrap_or(*g33);
        let d = target - self.pos;
        // the lead axis has the largest travel; on a tie Z, then Y, then X
        let mut lead = 2;
        for i in [1, 0] {
            if d[i].abs() > d[lead].abs() {
                lead = i;
            }
        }
        let len = d[lead].abs();
        if len == 0.0 {
            self.error(
                Some(&anchor),
                "G33 (thread): the end point is the start point".into(),
            );
            return;
        }
        let lead_name = AXIS_LETTERS[lead] as char;
        let start_rev = match w.center(0) {
            Some(i) if chained => {
                self.error(
                    Some(&i),
                    "I (start angle) belongs to the first G33 block of a thread: this block continues the thread in phase, without a new index wait".into(),
                );
                return;
            }
            Some(i) if !(0.0..360.0).contains(&i.value) => {
                self.error(
                    Some(&i),
                    format!(
                        "start angle I must be at least 0 and less than 360 degrees, found I{}",
                        num(i.value)
                    ),
                );
                return;
            }
            Some(i) => i.value / 360.0,
            None => 0.0,
        };
        let (_, v_lead) = thread::lead_speed(pitch, rpm);
        let mut end = target;
        let mut runout = None;
        if let Some(j) = w.center(1) {
            let Some((ax, tan)) = self.runout else {
                self.error(
                    Some(&j),
                    "runout J needs machine constant 8 (runout angle and axis: mc8 under [constants] in the machine file)".into(),
                );
                return;
            };
            let why = if j.value <= 0.0 || j.value.is_nan() {
                Some(format!(
                    "runout J must be greater than 0 mm, found J{}",
                    num(j.value)
                ))
            } else if !self.present[ax] {
                Some(format!(
                    "machine constant 8 names axis {} for the runout, which this machine does not have",
                    AXIS_LETTERS[ax] as char
                ))
            } else if ax == lead {
                Some(format!(
                    "the runout axis {} (machine constant 8) is this thread's lead axis; the runout must move another axis",
                    AXIS_LETTERS[ax] as char
                ))
            } else if j.value > len {
                Some(format!(
                    "runout J{} is longer than the thread's {lead_name} travel of {} mm",
                    j.value,
                    num(len)
                ))
            } else {
                None
            };
            if let Some(why) = why {
                self.error(Some(&j), why);
                return;
            }
            let (blend, jerk_phase) =
                thread::runout_blend(tan, v_lead, self.th.amax[ax], self.th.jmax[ax]);
            if 0.5 * blend > j.value {
                self.error(
                    Some(&j),
                    format!(
                        "runout J{} is too short to leave the thread at S{}: axis {} needs at least {} mm of {lead_name} travel to pick up speed (or lower S)",
                        j.value,
                        num(rpm.abs()),
                        AXIS_LETTERS[ax] as char,
                        round_up(0.5 * blend)
                    ),
                );
                return;
            }
            end[ax] += j.value * tan;
            runout = Some(RunoutPath {
                axis: ax,
                from: len - j.value,
                tan,
                blend,
                jerk_phase,
            });
        }
        let seg = ThreadSeg {
            start: self.pos,
            prog_end: target,
            end,
            lead,
            len,
            pitch,
            runout,
        };
        let fit = match thread::fit(&seg, rpm, &self.th, chained, prev) {
            Ok(f) => f,
            Err(e) => {
                let text = match e {
                    FitError::TooFast {
                        axis,
                        speed,
                        vmax,
                        s_max,
                    } => format!(
                        "G33 at S{} with pitch F{}: axis {} would move at {} mm/s in the thread with the spindle 5 % over S (as the at-speed check allows), over its {} mm/s; lower S to at most {}",
                        num(rpm.abs()),
                        num(pitch),
                        AXIS_LETTERS[axis] as char,
                        round_up(speed),
                        num(vmax),
                        s_max.floor()
                    ),
                    FitError::RunIn { ramp, room } => format!(
                        "G33: the run-in needs {} mm of {lead_name} travel at S{} (pitch F{}) to reach the thread's speed; the block has {} mm{}: start the thread {} mm earlier or lower S",
                        round_up(ramp),
                        num(rpm.abs()),
                        num(pitch),
                        // (a runout as long as the travel leaves none,
                        // not less than none)
                        num(room.max(0.0)),
                        if runout.is_some() { " before the runout" } else { "" },
                        round_up(ramp - room)
                    ),
                    FitError::Kink { axis, jump } => format!(
                        "chained G33 blocks must continue the thread smoothly: axis {}'s speed would jump by {} mm/s at this block's start, more than the axis can follow in sync (same direction and pitch, or end the thread and start a new one)",
                        AXIS_LETTERS[axis] as char,
                        round_up(jump)
                    ),
                };
                self.error(Some(&anchor), text);
                return;
            }
        };
        let (lo, hi) = (
            seg.start.inf(&seg.prog_end).inf(&seg.end),
            seg.start.sup(&seg.prog_end).sup(&seg.end),
        );
        let line = Geom::Line {
            start: seg.start,
            end: seg.prog_end,
        };
        self.check_travel(&line, (lo, hi), w, Some(&anchor));
        self.grow_bbox(lo, hi);
        self.pos = end;
        let m = ThreadMove {
            seg,
            src,
            rpm,
            runin: (!chained).then_some((start_rev, fit.delta)),
            decel: None,
            accel: fit.accel,
            jerk: fit.jerk,
        };
        self.held = Some(Box::new(Held {
            m,
            accel: fit.accel,
            runin_len: if chained { 0.0 } else { fit.ramp },
            v_end: fit.v_end,
            src,
            col: anchor.col,
            wlen: anchor.len,
            text: String::from_utf8_lossy(&self.buf).into_owned(),
        }));
        if runout.is_some() {
            // a runout ends the thread
            self.release_thread(false);
            self.after_runout = 2;
        }
    }

    /// Queues the held thread block: if `next_is_g33` (and it has no
    /// runout) the thread goes on; otherwise it is the last block and
    /// decelerates into its end. Returns its end velocity if it goes on.
    pub(super) fn release_thread(&mut self, next_is_g33: bool) -> Option<V3> {
        let h = self.held.take()?;
        let mut m = h.m;
        let chained = next_is_g33 && m.seg.runout.is_none();
        if !chained {
            let (delta, ramp) = thread::deceleration(&m, h.accel);
            let room = m.seg.len - h.runin_len;
            if ramp > room + 1e-9 {
                let lead = AXIS_LETTERS[m.seg.lead] as char;
                let msg = format!(
                    "G33: the thread's end needs {} mm of {lead} travel at S{} (pitch F{}) to decelerate from the thread's speed{}; the block has {} mm: make it {} mm longer or lower S",
                    round_up(ramp),
                    num(m.rpm.abs()),
                    num(m.seg.pitch),
                    if h.runin_len > 0.0 {
                        format!(", after {} mm of run-in", round_up(h.runin_len))
                    } else {
                        String::new()
                    },
                    num(m.seg.len),
                    round_up(ramp - room)
                );
                let repeated = !self.reported.insert((h.src.line, h.col)) && self.jumps > 0;
                let mut d = Diagnostic::new(h.src.line, h.col, h.wlen, msg);
                d.source = h.text;
                if !repeated {
                    let keep = self.last;
                    self.last = h.src;
                    self.push_diag(d);
                    self.last = keep;
                }
            }
            m.decel = Some(delta);
        }
        self.emit(Event::Thread(m));
        chained.then_some(h.v_end)
    }

    /// The block rules after a G33 block with runout: an empty block, then
    /// a block that programs every axis.
    #[inline(never)]
    pub(super) fn runout_rules(&mut self, parsed: bool, words: &[Word]) {
        let state = std::mem::take(&mut self.after_runout);
        if !parsed {
            return;
        }
        if state == 2 {
            match words.iter().find(|w| w.letter != b'N') {
                None => self.after_runout = 1,
                Some(o) => self.error(
                    Some(o),
                    "the block after a G33 block with runout J must be an empty block (an N number and a comment are allowed)".into(),
                ),
            }
        } else if state == 1 {
            let all: Vec<char> = (0..3)
                .filter(|&i| self.present[i])
                .map(|i| AXIS_LETTERS[i] as char)
                .collect();
            let missing: Vec<String> = all
                .iter()
                .filter(|&&c| !words.iter().any(|w| w.letter == c as u8))
                .map(|c| c.to_string())
                .collect();
            if !missing.is_empty() {
                let all: Vec<String> = all.iter().map(|c| c.to_string()).collect();
                self.error(
                    words.iter().find(|w| w.letter != b'N').or(words.first()),
                    format!(
                        "after a thread runout (G33 with J) and the empty block, this block must program every axis ({}): {} missing",
                        all.join(" "),
                        missing.join(" ")
                    ),
                );
            }
        }
    }
}
