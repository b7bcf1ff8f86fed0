//! The interpreter's state and its outputs: the modal state and position,
//! each concern's state, the errors, and the canonical commands handed to
//! its [`Canon`]. The concerns' files add the methods that change it.

use super::modal::{Modal, Motion, SpindleDir};
use crate::canon::{Canon, Event, Src, ThreadMove};
use crate::diag::Diagnostic;
use crate::dialect::{Dialect, Meaning, Rules};
use crate::geom::Plane;
use crate::geom::V3;
use crate::machine::Machine;
use crate::machine::ToolConfig;
use crate::parse::{Block, Word};
use crate::source::{ProgramSource, SourcePos};
use crate::thread::ThreadLimits;
use crate::travel::Travel;
use std::collections::VecDeque;

/// Interprets a program into [`Event`]s. Iterate it; afterwards read the
/// errors, block count and bounding box.
pub struct Interpreter<S, C> {
    pub(super) src: S,
    pub(super) dialect: Dialect,
    /// the dialect's vocabulary, and its thread G code (whose blocks'
    /// text is kept for errors found at the next block)
    pub(super) rules: &'static Rules,
    pub(super) thread_code: Option<f64>,
    pub(super) present: [bool; 3],
    /// the axes' ranges
    pub(super) travel: Travel,
    pub(super) diameter: bool,
    pub(super) max_rpm: Option<f64>,
    pub(super) max_errors: usize,
    pub modal: Modal,
    pub(super) pos: V3,
    pub(super) buf: Vec<u8>,
    /// the block being executed (boxed: it is taken out while executing,
    /// and moving the pointer is cheaper than moving 1 KiB of words)
    pub(super) block: Option<Box<Block>>,
    pub(super) errors: Vec<Diagnostic>,
    pub(super) error_count: usize,
    pub(super) blocks: u64,
    pub(super) last: Src,
    pub(super) finished: bool,
    pub(super) bbox: Option<(V3, V3)>,
    /// where the current line starts (for jumps)
    pub(super) cur_pos: SourcePos,
    /// the last line number run for the first time (blocks count once)
    pub(super) max_line: u32,
    /// cnc836 helix: the dragged axis and its pitch (mm per turn), from G10
    pub(super) pitch: Option<(usize, f64)>,
    /// G09 is in force: (dragged axis value when it started, turns since)
    pub(super) helix: Option<(f64, f64)>,
    /// G73 loops repeating now: (line of the G73 block, jumps left,
    /// blocks executed when it last jumped), innermost last
    pub(super) loops: Vec<(u32, u32, Option<u64>)>,
    /// blocks executed so far, repetitions included
    pub(super) executed: u64,
    /// the machine's `limits.max_executed_blocks`
    pub(super) max_executed: u64,
    /// jump targets found, by the line of their G73 block
    pub(super) targets: std::collections::HashMap<u32, SourcePos>,
    /// jumps taken so far
    pub(super) jumps: u64,
    /// the loops' total is added up at the first jump (the check's runs)
    pub(super) loop_scan: LoopScan,
    /// (line, column) of the errors reported, so a loop reports each once
    pub(super) reported: std::collections::HashSet<(u32, u32)>,
    /// a jump was needed but the source cannot seek (the check's pipeline)
    pub(super) needs_seek: bool,
    /// heidenhain: the pole (its plane coordinates count)
    pub(super) pole: Option<V3>,
    /// heidenhain: the last polar radius and angle (deg)
    pub(super) polar_r: Option<f64>,
    pub(super) polar_h: Option<f64>,
    /// heidenhain: where the last polar move ended, about which pole, in
    /// which plane: a polar arc starting there takes its radius and start
    /// angle from `polar_r`/`polar_h` exactly instead of from coordinates
    pub(super) polar_end: Option<(V3, V3, Plane)>,
    /// heidenhain: the direction of the last G12/G13 (true: counter-clockwise)
    pub(super) last_ccw: Option<bool>,
    /// G33: what the axes and the spindle allow
    pub(super) th: ThreadLimits,
    /// machine constant 8: the runout's (axis, tan of the angle)
    pub(super) runout: Option<(usize, f64)>,
    /// G33: the last pitch programmed, mm/rev
    pub(super) thread_pitch: Option<f64>,
    /// G33: the last thread block, held until the next block says whether
    /// the chain goes on
    pub(super) held: Option<Box<Held>>,
    /// after a G33 block with runout: 2 = the next block must be empty,
    /// 1 = the next must program every axis
    pub(super) after_runout: u8,
    /// the stages the commands go to (compensation, blending), and the
    /// errors they report
    pub(super) canon: C,
    pub(super) canon_errors: Vec<String>,
    /// the tool table and the entry selected by T (None: no offset)
    pub(super) tools: std::sync::Arc<[ToolConfig]>,
    pub(super) lathe: bool,
    pub(super) tool_cfg: Option<ToolConfig>,
    /// the machine's default tolerance (for a G64 without P)
    pub(super) default_tolerance: f64,
}

/// Whether the loops' total is added up before the first jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LoopScan {
    Off,
    Wanted,
    Done,
}

/// A thread block waiting for the next block.
#[derive(Debug)]
pub(super) struct Held {
    pub(super) m: ThreadMove,
    /// lead acceleration of its run-in and deceleration, mm/s²
    pub(super) accel: f64,
    /// lead travel taken by its run-in (0: chained), mm
    pub(super) runin_len: f64,
    /// axis velocities at the programmed speed at its end, mm/s
    pub(super) v_end: V3,
    /// where to report: the block, the word's column and length, its text
    pub(super) src: Src,
    pub(super) col: u32,
    pub(super) wlen: u32,
    pub(super) text: String,
}

impl<S: ProgramSource, C: Canon> Iterator for Interpreter<S, C> {
    type Item = Event;
    fn next(&mut self) -> Option<Event> {
        loop {
            if let Some(e) = self.canon.pop() {
                return Some(e);
            }
            if self.finished {
                return None;
            }
            self.step();
        }
    }
}

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// An interpreter handing its commands to `canon`.
    pub fn with_canon(src: S, dialect: Dialect, machine: &Machine, canon: C) -> Self {
        let present = [0, 1, 2].map(|i| machine.axis(i).is_some());
        let lathe = machine.kind == crate::machine::MachineKind::Lathe;
        let rules = dialect.rules();
        Interpreter {
            src,
            dialect,
            rules,
            thread_code: rules.code_of(Meaning::Thread).map(|c| c as f64),
            present,
            travel: Travel::new(machine),
            diameter: machine.diameter_mode(),
            max_rpm: machine.spindle.as_ref().map(|s| s.max_rpm),
            max_errors: machine.limits.max_errors,
            modal: Modal {
                motion: Motion::Rapid,
                plane: if lathe { Plane::ZX } else { Plane::XY },
                absolute: true,
                per_rev: false,
                feed: None,
                speed: 0.0,
                spindle: SpindleDir::Off,
                tool: 0,
            },
            pos: machine.home(),
            buf: Vec::with_capacity(256),
            block: Some(Box::default()),
            errors: Vec::new(),
            error_count: 0,
            blocks: 0,
            last: Src::default(),
            finished: false,
            bbox: None,
            cur_pos: SourcePos { offset: 0, line: 1 },
            max_line: 0,
            pitch: None,
            helix: None,
            loops: Vec::new(),
            executed: 0,
            max_executed: machine.limits.max_executed_blocks,
            targets: std::collections::HashMap::new(),
            jumps: 0,
            loop_scan: LoopScan::Off,
            reported: std::collections::HashSet::new(),
            needs_seek: false,
            pole: None,
            polar_r: None,
            polar_h: None,
            polar_end: None,
            last_ccw: None,
            th: ThreadLimits {
                vmax: machine.vmax(),
                amax: machine.amax(),
                jmax: machine.jmax(),
                dt: machine.dt(),
                present,
                cpr: machine
                    .spindle
                    .as_ref()
                    .map_or(0.0, |s| f64::from(s.encoder_counts_per_rev)),
            },
            runout: machine
                .runout()
                .map(|r| (r.axis, r.angle_deg.to_radians().tan())),
            thread_pitch: None,
            held: None,
            after_runout: 0,
            canon,
            canon_errors: Vec::new(),
            tools: machine.tools.clone().into(),
            lathe,
            tool_cfg: None,
            default_tolerance: machine.planner.path_tolerance_mm,
        }
    }

    /// Adds up, at the first jump, how many blocks the program's loops
    /// would run, and refuses it then when that is over
    /// the machine's `limits.max_executed_blocks` (the check; an executor
    /// runs checked programs).
    pub(crate) fn with_loop_scan(mut self) -> Self {
        self.loop_scan = LoopScan::Wanted;
        self
    }

    /// A jump was needed that this source could not make (see
    /// [`ProgramSource::can_seek`]); the run stopped there.
    pub(crate) fn needs_seek(&self) -> bool {
        self.needs_seek
    }

    /// Errors found so far (at most the machine's `max_errors`).
    pub fn errors(&self) -> &[Diagnostic] {
        &self.errors
    }

    /// All errors found so far, including those not kept.
    pub fn error_count(&self) -> usize {
        self.error_count
    }

    /// Blocks (lines with words) read so far.
    pub fn blocks(&self) -> u64 {
        self.blocks
    }

    /// Bounding box of all moves so far (machine coordinates).
    pub fn bbox(&self) -> Option<(V3, V3)> {
        self.bbox
    }

    /// Current programmed position (machine coordinates).
    pub fn position(&self) -> V3 {
        self.pos
    }

    /// The stages behind the interpreter.
    pub fn canon(&self) -> &C {
        &self.canon
    }

    /// Line and block of the last block read.
    pub fn last_src(&self) -> Src {
        self.last
    }

    /// Interprets lines until at least `min` events wait or the program
    /// has ended, then swaps the waiting events into `batch` (emptied
    /// first). Returns false once the program has ended: no event follows.
    pub(crate) fn fill(&mut self, batch: &mut VecDeque<Event>, min: usize) -> bool {
        while self.canon.ready() < min && !self.finished {
            self.step();
        }
        self.canon.take(batch);
        !self.finished
    }

    #[cold]
    pub(super) fn error(&mut self, w: Option<&Word>, msg: String) {
        let col = w.map_or(1, |w| w.col);
        // a block run again by a loop reports its error once
        if self.reported.len() < 100_000
            && !self.reported.insert((self.last.line, col))
            && self.jumps > 0
        {
            return;
        }
        self.error_count += 1;
        if self.errors.len() >= self.max_errors {
            return;
        }
        let (col, len) = w.map_or((1, 1), |w| (w.col, w.len));
        let mut d = Diagnostic::new(self.last.line, col, len, msg);
        d.block_no = self.last.block_no;
        d.source = String::from_utf8_lossy(&self.buf).into_owned();
        self.errors.push(d);
    }

    #[cold]
    pub(super) fn push_diag(&mut self, mut d: Diagnostic) {
        self.error_count += 1;
        if self.errors.len() < self.max_errors {
            d.block_no = self.last.block_no;
            self.errors.push(d);
        }
    }

    /// Moves the events waiting into `batch` (emptied first).
    pub(crate) fn take_events(&mut self, batch: &mut VecDeque<Event>) {
        self.canon.take(batch);
    }

    /// The same interpreter, reading from `src` from now on; returns the
    /// old source (the check hands the source to its reading thread).
    pub(crate) fn replace_source<T>(self, src: T) -> (S, Interpreter<T, C>) {
        let Interpreter {
            src: old,
            dialect,
            rules,
            thread_code,
            present,
            travel,
            diameter,
            max_rpm,
            max_errors,
            modal,
            pos,
            buf,
            block,
            errors,
            error_count,
            blocks,
            last,
            finished,
            bbox,
            cur_pos,
            max_line,
            pitch,
            helix,
            loops,
            executed,
            max_executed,
            targets,
            jumps,
            loop_scan,
            reported,
            needs_seek,
            pole,
            polar_r,
            polar_h,
            polar_end,
            last_ccw,
            th,
            runout,
            thread_pitch,
            held,
            after_runout,
            canon,
            canon_errors,
            tools,
            lathe,
            tool_cfg,
            default_tolerance,
        } = self;
        let new = Interpreter {
            src,
            dialect,
            rules,
            thread_code,
            present,
            travel,
            diameter,
            max_rpm,
            max_errors,
            modal,
            pos,
            buf,
            block,
            errors,
            error_count,
            blocks,
            last,
            finished,
            bbox,
            cur_pos,
            max_line,
            pitch,
            helix,
            loops,
            executed,
            max_executed,
            targets,
            jumps,
            loop_scan,
            reported,
            needs_seek,
            pole,
            polar_r,
            polar_h,
            polar_end,
            last_ccw,
            th,
            runout,
            thread_pitch,
            held,
            after_runout,
            canon,
            canon_errors,
            tools,
            lathe,
            tool_cfg,
            default_tolerance,
        };
        (old, new)
    }

    /// Hands a canonical command on to the stages behind the interpreter
    /// (compensation, blending), reporting what they find at this block.
    #[inline]
    pub(super) fn emit(&mut self, ev: Event) {
        self.canon.command(ev, &mut self.canon_errors);
        if !self.canon_errors.is_empty() {
            for e in std::mem::take(&mut self.canon_errors) {
                self.error(None, e);
            }
        }
    }
}
