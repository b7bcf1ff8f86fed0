//! Running the program: a line at a time (or lines parsed elsewhere, for
//! the check's reader), and one block in its order: feed, speed, tool,
//! spindle, modal geometry, dwell or motion, end, jump.

use super::modal::{Motion, SpindleDir};
use super::state::Interpreter;
use super::words::{slot, Words};
use crate::canon::{Canon, Event, Src};
use crate::diag::{num, Diagnostic};
use crate::parse::{block_no, parse_line, Word};
use crate::source::{ProgramSource, SourceError};

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    pub(super) fn step(&mut self) {
        let pos = match self.src.read_line(&mut self.buf) {
            Ok(Some(p)) => p,
            Ok(None) => {
                self.finish();
                return;
            }
            Err(e) => {
                self.read_failed(&e);
                return;
            }
        };
        self.cur_pos = pos;
        let mut block = self.block.take().unwrap_or_default();
        let parsed = parse_line(self.dialect, pos.line, &self.buf, &mut block);
        self.exec_parsed(pos.line, parsed, &block.words);
        self.block = Some(block);
    }

    /// Runs line `line`, held in `self.buf`, which `parse_line` made into
    /// `words` (those before the error, if it failed).
    #[inline]
    pub(super) fn exec_parsed(
        &mut self,
        line: u32,
        parsed: Result<(), Diagnostic>,
        words: &[Word],
    ) {
        self.last = Src {
            line,
            block_no: block_no(words),
        };
        if self.after_runout > 0 {
            self.runout_rules(parsed.is_ok(), words);
        }
        match parsed {
            Err(d) => self.push_diag(d),
            Ok(()) if words.is_empty() => {}
            Ok(()) => {
                if line > self.max_line {
                    self.max_line = line;
                    self.blocks += 1;
                }
                self.executed += 1;
                self.exec_block(words);
            }
        }
    }

    /// Runs a line that was read and parsed elsewhere (by the check's
    /// reading thread); `parse_error` and `words` are what `parse_line` made of
    /// `text`. The same as [`Interpreter::step`] after its read.
    pub(crate) fn exec_line(
        &mut self,
        line: u32,
        text: &[u8],
        parse_error: Option<Box<Diagnostic>>,
        words: &[Word],
    ) {
        // Every error of a line quotes that line (`parse_line` and `error`
        // both take it lossily as UTF-8), so the text is copied only into
        // the errors found, not into `buf` for every line.
        self.buf.clear();
        if self
            .thread_code
            .is_some_and(|c| words.iter().any(|w| w.letter == b'G' && w.value == c))
        {
            // a thread block's errors may be found at the next block
            self.buf.extend_from_slice(text);
        }
        let kept = self.errors.len();
        match parse_error {
            None => self.exec_parsed(line, Ok(()), words),
            Some(d) => self.exec_parsed(line, Err(*d), words),
        }
        if self.errors.len() > kept {
            let source = String::from_utf8_lossy(text).into_owned();
            for d in self.errors[kept..].iter_mut().filter(|d| d.line == line) {
                d.source.clone_from(&source);
            }
        }
    }

    /// The source failed: the error is reported on the line after the last
    /// one read, and the program ends.
    pub(crate) fn read_failed(&mut self, e: &SourceError) {
        self.last = Src {
            line: self.last.line + 1,
            block_no: None,
        };
        self.buf.clear();
        self.error(None, format!("cannot read the program: {}", e.0));
        self.finish();
    }

    /// The source has no more lines.
    pub(crate) fn end_of_text(&mut self) {
        self.finish();
    }

    /// The program has ended (end of text, M02/M30, or a read error): no
    /// line is run after this.
    pub(crate) fn is_finished(&self) -> bool {
        self.finished
    }

    pub(super) fn finish(&mut self) {
        if !self.finished {
            self.release_thread(false);
            self.finished = true;
            self.emit(Event::End { src: self.last });
        }
    }

    pub(super) fn exec_block(&mut self, block: &[Word]) {
        let mut words = Words::new(block);
        self.classify(&mut words);
        let w = &words;
        let src = self.last;
        // a thread block held back learns whether this block goes on with it
        let g33 = w.get(slot::THREAD);
        let chained = self.release_thread(g33.is_some());
        if !self.helix_block(w) {
            return;
        }
        // a pole block sets the pole and moves nothing; its other words
        // (feed, speed, tool, spindle, modal codes, end) still count
        let pole_only = !self.pole_block(w);
        // --- feed, speed, tool -------------------------------------------------
        if w.has(slot::FEED_MODE) {
            self.modal.per_rev = w.per_rev;
        }
        if let Some(f) = w.f().filter(|_| g33.is_none()) {
            if w.dwell().is_none() || !self.rules.dwell_time_in_f {
                if f.value < 0.0 {
                    self.error(
                        Some(&f),
                        format!("feed F must not be negative (F{})", num(f.value)),
                    );
                } else {
                    self.modal.feed = Some(f.value);
                }
            }
        }
        // the spindle command before this block's S and M03/M04/M05: a new S
        // while the spindle turns is a new command too
        let before = self.modal.spindle_rpm();
        if let Some(s) = w.s() {
            if s.value < 0.0 {
                self.error(
                    Some(&s),
                    format!("spindle speed S must not be negative (S{})", num(s.value)),
                );
            } else if let Some(max) = self.max_rpm.filter(|&m| s.value > m) {
                self.error(
                    Some(&s),
                    format!(
                        "spindle speed S{} is over the machine's {} rpm",
                        num(s.value),
                        num(max)
                    ),
                );
            } else if self.max_rpm.is_none() && s.value > 0.0 {
                self.error(Some(&s), "this machine has no spindle".into());
            } else {
                self.modal.speed = s.value;
            }
        }
        if let Some(t) = w.t() {
            match t.as_int().filter(|&n| t.integer && (0..=9999).contains(&n)) {
                Some(_) if self.canon.compensating() => self.error(
                    Some(&t),
                    "a tool change while radius compensation is active: cancel it with G40 first"
                        .into(),
                ),
                Some(n) if !self.select_tool(n as u32, &t) => {}
                Some(n) => {
                    self.modal.tool = n as u32;
                    self.emit(Event::Tool {
                        number: n as u32,
                        src,
                    });
                }
                None => self.error(
                    Some(&t),
                    format!(
                        "tool T must be a whole number 0..9999, found {}",
                        super::words::written(&t)
                    ),
                ),
            }
        }
        // --- spindle ---------------------------------------------------------------
        if let Some(m) = w.get(slot::SPINDLE) {
            let dir = w.spindle;
            if dir != SpindleDir::Off && self.max_rpm.is_none() {
                self.error(Some(&m), "this machine has no spindle".into());
            } else {
                self.modal.spindle = dir;
            }
        }
        if self.modal.spindle_rpm() != before {
            self.emit(Event::Spindle {
                rpm: self.modal.spindle_rpm(),
                src,
            });
        }
        // --- modal geometry state --------------------------------------------
        if w.has(slot::PLANE) {
            if self.canon.compensating() && w.plane != self.modal.plane {
                let pl = w.get(slot::PLANE);
                self.error(
                    pl.as_ref(),
                    "the plane cannot change while radius compensation is active: cancel it with G40 first".into(),
                );
            } else {
                self.modal.plane = w.plane;
            }
        }
        if let Some(g) = w.get(slot::COMP) {
            self.exec_comp(w.comp, &g);
        }
        if w.has(slot::PATH) {
            let mut tolerance = 0.0;
            if w.path == 64 {
                match w.p() {
                    Some(p) if !(0.0..=10.0).contains(&p.value) => self.error(
                        Some(&p),
                        format!("path tolerance P must be 0..10 mm, found P{}", num(p.value)),
                    ),
                    Some(p) => tolerance = p.value,
                    None => tolerance = self.default_tolerance,
                }
            }
            self.canon.set_path_tolerance(tolerance);
        }
        if let (Some(g), true) = (g33, self.canon.compensating()) {
            self.error(
                Some(&g),
                "G33 (thread) with radius compensation active: cancel it with G40 first".into(),
            );
            return;
        }
        if w.has(slot::DISTANCE) {
            self.modal.absolute = w.absolute;
        }
        if !pole_only {
            // --- dwell -------------------------------------------------------------
            if let Some(g4) = w.dwell() {
                self.exec_dwell(w, &g4, src);
            } else {
                if let Some(p) = w.p().filter(|_| !(w.has(slot::PATH) && w.path == 64)) {
                    self.error(
                        Some(&p),
                        "address P is only used with G04 (dwell) and G64 (path tolerance)".into(),
                    );
                }
                if w.has(slot::LAST_DIR) {
                    match self.last_ccw {
                        Some(ccw) => {
                            self.modal.motion = if ccw {
                                Motion::PolarCcw
                            } else {
                                Motion::PolarCw
                            }
                        }
                        None => {
                            let g15 = w.get(slot::LAST_DIR);
                            self.error(
                                g15.as_ref(),
                                "G15 (polar arc, last direction) needs a G12 or G13 before it"
                                    .into(),
                            );
                            return;
                        }
                    }
                } else if w.has(slot::MOTION) {
                    self.modal.motion = w.motion;
                }
                match g33 {
                    Some(g) => self.exec_thread(w, &g, src, chained),
                    None => self.exec_motion(w, src),
                }
            }
        }
        if w.end().is_some() {
            self.finish();
            return;
        }
        if let Some(g73) = w.get(slot::JUMP) {
            self.exec_jump(w, &g73);
        }
    }
}
