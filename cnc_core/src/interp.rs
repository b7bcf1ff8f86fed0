//! The interpreter: blocks in, canonical events out (LinuxCNC's seam between
//! interpreter and motion). It keeps the modal state, validates every word,
//! records every error (and keeps going, so one check reports them all), and
//! holds only the current block: memory does not grow with the program.

use crate::canon::{Canon, CompMode, Event, Feed, RunoutPath, Src, ThreadMove, ThreadSeg};
use crate::diag::{num, Diagnostic};
use crate::dialect::{Dialect, Meaning, Rules};
use crate::geom::V3;
use crate::geom::{Arc, Geom, Plane};
use crate::machine::Machine;
use crate::machine::{tip_vector, ToolConfig};
use crate::parse::{block_no, parse_line, Block, Word};
use crate::shares::{KINK_SHARE, SPEED_MARGIN, THREAD_SHARE};
use crate::source::{ProgramSource, SourceError, SourcePos};
use crate::travel::{self, Travel};
use std::collections::VecDeque;

/// Largest radius difference between an arc's start and end, mm.
pub const ARC_TOLERANCE_MM: f64 = 0.002;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    Rapid,
    Linear,
    CwArc,
    CcwArc,
    /// heidenhain G10: polar line at rapid
    PolarRapid,
    /// heidenhain G11: polar line at feed
    PolarLine,
    /// heidenhain G12: polar arc clockwise about the pole
    PolarCw,
    /// heidenhain G13: polar arc counter-clockwise about the pole
    PolarCcw,
}

impl Motion {
    pub fn gcode(self) -> &'static str {
        match self {
            Motion::Rapid => "G00",
            Motion::Linear => "G01",
            Motion::CwArc => "G02",
            Motion::CcwArc => "G03",
            Motion::PolarRapid => "G10",
            Motion::PolarLine => "G11",
            Motion::PolarCw => "G12",
            Motion::PolarCcw => "G13",
        }
    }

    fn polar(self) -> bool {
        matches!(
            self,
            Motion::PolarRapid | Motion::PolarLine | Motion::PolarCw | Motion::PolarCcw
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpindleDir {
    Off,
    Cw,
    Ccw,
}

/// The modal state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    pub motion: Motion,
    pub plane: Plane,
    pub absolute: bool,
    pub per_rev: bool,
    /// F as programmed (mm/min or mm/rev)
    pub feed: Option<f64>,
    /// S, rpm
    pub speed: f64,
    pub spindle: SpindleDir,
    pub tool: u32,
}

impl Modal {
    /// The active modal G codes, e.g. `["G01", "G17", "G90", "G94"]`.
    pub fn gcodes(&self) -> [&'static str; 4] {
        [
            self.motion.gcode(),
            self.plane.gcode(),
            if self.absolute { "G90" } else { "G91" },
            if self.per_rev { "G95" } else { "G94" },
        ]
    }
    /// Signed commanded spindle speed, rpm.
    pub fn spindle_rpm(&self) -> f64 {
        match self.spindle {
            SpindleDir::Off => 0.0,
            SpindleDir::Cw => self.speed,
            SpindleDir::Ccw => -self.speed,
        }
    }
}

const AXIS_LETTERS: [u8; 3] = [b'X', b'Y', b'Z'];
/// G00..G03
const MOTIONS: [Motion; 4] = [Motion::Rapid, Motion::Linear, Motion::CwArc, Motion::CcwArc];
/// A length for a message, rounded up to the micrometre (a hair over a
/// whole micrometre from rounding is not rounded up).
fn round_up(v: f64) -> String {
    num((v * 1000.0 - 1e-6).ceil() / 1000.0)
}

/// cos and sin of an angle in degrees, exact at multiples of 90 degrees
/// (so H+180 lands exactly on its point).
fn cos_sin_deg(deg: f64) -> (f64, f64) {
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

const POLAR: [Motion; 4] = [
    Motion::PolarRapid,
    Motion::PolarLine,
    Motion::PolarCw,
    Motion::PolarCcw,
];
const CENTER_LETTERS: [u8; 3] = [b'I', b'J', b'K'];

/// Slots of [`Words`], one per meaning.
mod slot {
    pub const MOTION: usize = 0;
    pub const PLANE: usize = 1;
    pub const DISTANCE: usize = 2;
    pub const FEED_MODE: usize = 3;
    pub const DWELL: usize = 4;
    pub const AXIS: usize = 5; // X, Y, Z
    pub const CENTER: usize = 8; // I, J, K
    pub const F: usize = 11;
    pub const S: usize = 12;
    pub const T: usize = 13;
    pub const P: usize = 14;
    pub const SPINDLE: usize = 15;
    pub const END: usize = 16;
    // cnc836
    pub const HELIX_ON: usize = 17; // G09
    pub const PITCH: usize = 18; // G10
    pub const JUMP: usize = 19; // G73
    pub const HELIX_OFF: usize = 20; // G98
    pub const L: usize = 21;
    pub const Q: usize = 22;
    // heidenhain
    pub const POLE_HERE: usize = 23; // G29
    pub const R: usize = 24;
    pub const H: usize = 25;
    /// G15: a polar arc in the last direction (sets MOTION too)
    pub const LAST_DIR: usize = 26;
    /// cnc836 G33: thread cutting (this block only)
    pub const THREAD: usize = 27;
    /// G40/G41/G42: radius compensation
    pub const COMP: usize = 28;
    /// G61/G64: exact path / path tolerance
    pub const PATH: usize = 29;
    pub const COUNT: usize = 30;

    /// The slot of a word with a dialect's meaning.
    pub fn of(m: super::Meaning) -> usize {
        use super::Meaning as M;
        match m {
            M::HelixOn => HELIX_ON,
            M::HelixPitch => PITCH,
            M::HelixOff => HELIX_OFF,
            M::Jump => JUMP,
            M::Thread => THREAD,
            M::Polar(_) => MOTION,
            M::PolarLastDirection => LAST_DIR,
            M::PoleHere => POLE_HERE,
            M::JumpTarget => L,
            M::JumpCount => Q,
            M::PolarRadius => R,
            M::PolarAngle => H,
        }
    }
}

/// The words of one block, sorted by meaning, each with its column. Each
/// slot holds which of the block's words has that meaning (1 + its index,
/// 0 for none), so sorting copies no words.
struct Words<'b> {
    all: &'b [Word],
    at: [u8; slot::COUNT],
    /// what the G/M code in the MOTION, PLANE, DISTANCE, FEED_MODE and
    /// SPINDLE slots selects (kept apart from the word: tuples of an enum
    /// and a word made slow copies)
    motion: Motion,
    plane: Plane,
    absolute: bool,
    per_rev: bool,
    spindle: SpindleDir,
    /// 40, 41 or 42
    comp: u8,
    /// 61 or 64
    path: u8,
}

impl<'b> Words<'b> {
    #[inline]
    fn new(all: &'b [Word]) -> Self {
        Words {
            all,
            at: [0; slot::COUNT],
            motion: Motion::Rapid,
            plane: Plane::XY,
            absolute: true,
            per_rev: false,
            spindle: SpindleDir::Off,
            comp: 40,
            path: 61,
        }
    }
    #[inline]
    fn get(&self, slot: usize) -> Option<Word> {
        match self.at[slot] {
            0 => None,
            k => Some(self.all[k as usize - 1]),
        }
    }
    #[inline]
    fn has(&self, slot: usize) -> bool {
        self.at[slot] != 0
    }
    #[inline]
    fn dwell(&self) -> Option<Word> {
        self.get(slot::DWELL)
    }
    #[inline]
    fn axis(&self, i: usize) -> Option<Word> {
        self.get(slot::AXIS + i)
    }
    #[inline]
    fn center(&self, i: usize) -> Option<Word> {
        self.get(slot::CENTER + i)
    }
    /// X, Y, Z in order
    #[inline]
    fn axes(&self) -> impl Iterator<Item = Option<Word>> + '_ {
        (0..3).map(|i| self.axis(i))
    }
    /// I, J, K in order
    #[inline]
    fn centers(&self) -> impl Iterator<Item = Option<Word>> + '_ {
        (0..3).map(|i| self.center(i))
    }
    #[inline]
    fn f(&self) -> Option<Word> {
        self.get(slot::F)
    }
    #[inline]
    fn s(&self) -> Option<Word> {
        self.get(slot::S)
    }
    #[inline]
    fn t(&self) -> Option<Word> {
        self.get(slot::T)
    }
    #[inline]
    fn p(&self) -> Option<Word> {
        self.get(slot::P)
    }
    #[inline]
    fn end(&self) -> Option<Word> {
        self.get(slot::END)
    }
}

/// Interprets a program into [`Event`]s. Iterate it; afterwards read the
/// errors, block count and bounding box.
pub struct Interpreter<S, C> {
    src: S,
    dialect: Dialect,
    /// the dialect's vocabulary, and its thread G code (whose blocks'
    /// text is kept for errors found at the next block)
    rules: &'static Rules,
    thread_code: Option<f64>,
    present: [bool; 3],
    /// the axes' ranges
    travel: Travel,
    diameter: bool,
    max_rpm: Option<f64>,
    max_errors: usize,
    pub modal: Modal,
    pos: V3,
    buf: Vec<u8>,
    /// the block being executed (boxed: it is taken out while executing,
    /// and moving the pointer is cheaper than moving 1 KiB of words)
    block: Option<Box<Block>>,
    errors: Vec<Diagnostic>,
    error_count: usize,
    blocks: u64,
    last: Src,
    finished: bool,
    bbox: Option<(V3, V3)>,
    /// where the current line starts (for jumps)
    cur_pos: SourcePos,
    /// the last line number run for the first time (blocks count once)
    max_line: u32,
    /// cnc836 helix: the dragged axis and its pitch (mm per turn), from G10
    pitch: Option<(usize, f64)>,
    /// G09 is in force: (dragged axis value when it started, turns since)
    helix: Option<(f64, f64)>,
    /// G73 loops repeating now: (line of the G73 block, jumps left,
    /// blocks executed when it last jumped), innermost last
    loops: Vec<(u32, u32, Option<u64>)>,
    /// blocks executed so far, repetitions included
    executed: u64,
    /// the machine's `limits.max_executed_blocks`
    max_executed: u64,
    /// jump targets found, by the line of their G73 block
    targets: std::collections::HashMap<u32, SourcePos>,
    /// jumps taken so far
    jumps: u64,
    /// the loops' total is added up at the first jump (the check's runs)
    loop_scan: LoopScan,
    /// (line, column) of the errors reported, so a loop reports each once
    reported: std::collections::HashSet<(u32, u32)>,
    /// a jump was needed but the source cannot seek (the check's pipeline)
    needs_seek: bool,
    /// heidenhain: the pole (its plane coordinates count)
    pole: Option<V3>,
    /// heidenhain: the last polar radius and angle (deg)
    polar_r: Option<f64>,
    polar_h: Option<f64>,
    /// heidenhain: where the last polar move ended, about which pole, in
    /// which plane: a polar arc starting there takes its radius and start
    /// angle from `polar_r`/`polar_h` exactly instead of from coordinates
    polar_end: Option<(V3, V3, Plane)>,
    /// heidenhain: the direction of the last G12/G13 (true: counter-clockwise)
    last_ccw: Option<bool>,
    /// G33: what the axes and the spindle allow
    th: ThreadLimits,
    /// G33: the last pitch programmed, mm/rev
    thread_pitch: Option<f64>,
    /// G33: the last thread block, held until the next block says whether
    /// the chain goes on
    held: Option<Box<Held>>,
    /// after a G33 block with runout: 2 = the next block must be empty,
    /// 1 = the next must program every axis
    after_runout: u8,
    /// the stages the commands go to (compensation, blending), and the
    /// errors they report
    canon: C,
    canon_errors: Vec<String>,
    /// the tool table and the entry selected by T (None: no offset)
    tools: std::sync::Arc<[ToolConfig]>,
    lathe: bool,
    tool_cfg: Option<ToolConfig>,
    /// the machine's default tolerance (for a G64 without P)
    default_tolerance: f64,
}

/// G73's L: the block number to jump back to, if it is one.
fn jump_target(l: &Word) -> Option<i64> {
    l.as_int().filter(|&n| l.integer && n >= 0)
}

/// G73's Q: the repeat count, a whole number 0..=9999, if it is one.
fn jump_count(q: &Word) -> Option<i64> {
    q.as_int().filter(|&c| q.integer && (0..=9999).contains(&c))
}

/// Whether the loops' total is added up before the first jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LoopScan {
    Off,
    Wanted,
    Done,
}

/// What G33 needs of the machine.
#[derive(Clone, Copy, Debug)]
struct ThreadLimits {
    vmax: V3,
    amax: V3,
    dt: f64,
    /// machine constant 8: (axis, tan of the angle)
    runout: Option<(usize, f64)>,
}

/// A thread block waiting for the next block.
#[derive(Debug)]
struct Held {
    m: ThreadMove,
    /// lead acceleration of its run-in and deceleration, mm/s²
    accel: f64,
    /// lead travel taken by its run-in (0: chained), mm
    runin_len: f64,
    /// axis velocities at the programmed speed at its end, mm/s
    v_end: V3,
    /// where to report: the block, the word's column and length, its text
    src: Src,
    col: u32,
    wlen: u32,
    text: String,
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
                dt: machine.dt(),
                runout: machine
                    .runout()
                    .map(|r| (r.axis, r.angle_deg.to_radians().tan())),
            },
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

    fn error(&mut self, w: Option<&Word>, msg: String) {
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

    fn push_diag(&mut self, mut d: Diagnostic) {
        self.error_count += 1;
        if self.errors.len() < self.max_errors {
            d.block_no = self.last.block_no;
            self.errors.push(d);
        }
    }

    fn step(&mut self) {
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
    fn exec_parsed(&mut self, line: u32, parsed: Result<(), Diagnostic>, words: &[Word]) {
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

    fn finish(&mut self) {
        if !self.finished {
            self.release_thread(false);
            self.finished = true;
            self.emit(Event::End { src: self.last });
        }
    }

    /// Sorts the words of a block, reporting unknown and duplicate words.
    fn classify(&mut self, w: &mut Words) {
        let mut n_seen = false;
        for (k, word) in w.all.iter().enumerate() {
            // claims `$slot` for this word (running `$set`), or reports a
            // second word of that meaning
            macro_rules! once {
                ($slot:expr, $what:expr) => {
                    once!($slot, (), $what)
                };
                ($slot:expr, $set:expr, $what:expr) => {{
                    if w.at[$slot] != 0 {
                        self.error(
                            Some(word),
                            format!("{} programmed twice in one block", $what),
                        );
                    } else {
                        w.at[$slot] = k as u8 + 1;
                        $set;
                    }
                }};
            }
            match word.letter {
                b'N' => {
                    if n_seen {
                        self.error(Some(word), "block number N programmed twice".into());
                    } else if word.as_int().is_none_or(|n| n < 0) || !word.integer {
                        self.error(
                            Some(word),
                            "block number N must be a whole number 0 or more".into(),
                        );
                    }
                    n_seen = true;
                }
                b'G' => {
                    let Some(code) = word.as_int().filter(|_| word.integer) else {
                        self.error(
                            Some(word),
                            format!("G code must be a whole number, found G{}", num(word.value)),
                        );
                        continue;
                    };
                    match code {
                        // one branch for all four (programs mix them at random)
                        0..=3 => once!(
                            slot::MOTION,
                            w.motion = MOTIONS[code as usize],
                            "a motion G code (G00-G03)"
                        ),
                        4 => once!(slot::DWELL, "G04"),
                        17 => once!(slot::PLANE, w.plane = Plane::XY, "a plane G code (G17-G19)"),
                        18 => once!(slot::PLANE, w.plane = Plane::ZX, "a plane G code (G17-G19)"),
                        19 => once!(slot::PLANE, w.plane = Plane::YZ, "a plane G code (G17-G19)"),
                        90 => once!(slot::DISTANCE, w.absolute = true, "G90/G91"),
                        91 => once!(slot::DISTANCE, w.absolute = false, "G90/G91"),
                        40..=42 => once!(slot::COMP, w.comp = code as u8, "G40/G41/G42"),
                        61 | 64 => once!(slot::PATH, w.path = code as u8, "G61/G64"),
                        94 => once!(slot::FEED_MODE, w.per_rev = false, "G94/G95"),
                        95 => once!(slot::FEED_MODE, w.per_rev = true, "G94/G95"),
                        _ => match self.rules.g_code(code) {
                            Some((Meaning::Polar(k), what)) => {
                                once!(slot::MOTION, w.motion = POLAR[k as usize], what)
                            }
                            Some((Meaning::PolarLastDirection, what)) => {
                                once!(slot::MOTION, what);
                                w.at[slot::LAST_DIR] = k as u8 + 1;
                            }
                            Some((m, what)) => once!(slot::of(m), what),
                            None => self.error(
                                Some(word),
                                format!(
                                    "unsupported G code G{code:02} in the {} dialect",
                                    self.dialect
                                ),
                            ),
                        },
                    }
                }
                b'M' => {
                    let Some(code) = word.as_int().filter(|_| word.integer) else {
                        self.error(
                            Some(word),
                            format!("M code must be a whole number, found M{}", num(word.value)),
                        );
                        continue;
                    };
                    match code {
                        3 => once!(slot::SPINDLE, w.spindle = SpindleDir::Cw, "a spindle M code (M03-M05)"),
                        4 => once!(slot::SPINDLE, w.spindle = SpindleDir::Ccw, "a spindle M code (M03-M05)"),
                        5 => once!(slot::SPINDLE, w.spindle = SpindleDir::Off, "a spindle M code (M03-M05)"),
                        2 | 30 => once!(slot::END, "a program end (M02/M30)"),
                        // tool change and coolant: accepted, nothing to simulate
                        6 | 8 | 9 => {}
                        _ => self.error(
                            Some(word),
                            format!("unsupported M code M{code:02}: expected M02, M03, M04, M05, M06, M08, M09 or M30"),
                        ),
                    }
                }
                b'X' | b'Y' | b'Z' => {
                    let i = (word.letter - b'X') as usize;
                    if !self.present[i] {
                        self.error(
                            Some(word),
                            format!("axis {} is not on this machine", word.letter as char),
                        );
                    } else {
                        once!(slot::AXIS + i, format!("axis {}", word.letter as char));
                    }
                }
                b'I' | b'J' | b'K' => {
                    let i = (word.letter - b'I') as usize;
                    once!(
                        slot::CENTER + i,
                        format!("centre offset {}", word.letter as char)
                    );
                }
                b'F' => once!(slot::F, "F"),
                b'S' => once!(slot::S, "S"),
                b'T' => once!(slot::T, "T"),
                b'P' => once!(slot::P, "P"),
                other if self.rules.address(other).is_some() => {
                    if let Some(m) = self.rules.address(other) {
                        once!(slot::of(m), (other as char).to_string())
                    }
                }
                other => {
                    let axes: String = (0..3)
                        .filter(|&i| self.present[i])
                        .map(|i| format!(" {}", AXIS_LETTERS[i] as char))
                        .collect();
                    self.error(
                        Some(word),
                        format!(
                            "unknown address '{}' in the {} dialect: expected one of N G M{axes} I J K F S T P{}",
                            other as char,
                            self.dialect,
                            self.rules
                                .addresses
                                .iter()
                                .map(|a| format!(" {}", a.0 as char))
                                .collect::<String>()
                        ),
                    );
                }
            }
        }
    }

    fn exec_block(&mut self, block: &[Word]) {
        let mut words = Words::new(block);
        self.classify(&mut words);
        let w = &words;
        let src = self.last;
        // a thread block held back learns whether this block goes on with it
        let g33 = w.get(slot::THREAD);
        let chained = self.release_thread(g33.is_some());
        if !self.helix_block(w) || !self.pole_block(w) {
            return;
        }
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
                        "tool T must be a whole number 0..9999, found T{}",
                        num(t.value)
                    ),
                ),
            }
        }
        // --- spindle ---------------------------------------------------------------
        let before = self.modal.spindle_rpm();
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
                            "G15 (polar arc, last direction) needs a G12 or G13 before it".into(),
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
        if w.end().is_some() {
            self.finish();
            return;
        }
        if let Some(g73) = w.get(slot::JUMP) {
            self.exec_jump(w, &g73);
        }
    }

    /// The helix's block rules that come before the block runs: G98 alone,
    /// G10 pitch blocks, G09, the dragged axis; and L/Q only with a jump.
    /// False: the block is done.
    fn helix_block(&mut self, w: &Words) -> bool {
        if let Some(g98) = w.get(slot::HELIX_OFF) {
            let other = w.all.iter().find(|x| x.letter != b'N' && x.col != g98.col);
            if let Some(o) = other {
                self.error(
                    Some(o),
                    "G98 (helix off) must stand alone in its block (an N number and a comment are allowed)".into(),
                );
            }
            self.helix = None;
            return false;
        }
        if let Some(g10) = w.get(slot::PITCH) {
            let axes: Vec<(usize, Word)> =
                (0..3).filter_map(|i| w.axis(i).map(|a| (i, a))).collect();
            let other = w
                .all
                .iter()
                .find(|x| !matches!(x.letter, b'N' | b'X' | b'Y' | b'Z') && x.col != g10.col);
            if let Some(o) = other {
                self.error(
                    Some(o),
                    "a G10 block (helix pitch) holds only the pitch: one axis word, e.g. Z1.05 G10"
                        .into(),
                );
            } else if axes.len() != 1 {
                self.error(
                    axes.get(1).map(|a| &a.1).or(Some(&g10)),
                    format!(
                        "G10 (helix pitch) takes exactly one axis word, the dragged axis with its pitch; found {}",
                        axes.len()
                    ),
                );
            } else {
                let (i, a) = axes[0];
                let (p, q, _) = self.modal.plane.axes();
                if i == p || i == q {
                    self.error(
                        Some(&a),
                        format!(
                            "the dragged axis {} is an axis of the {} plane; the helix drags the third axis",
                            AXIS_LETTERS[i] as char,
                            self.modal.plane.gcode()
                        ),
                    );
                } else if self.helix.is_some() && self.pitch.is_some_and(|(d, _)| d != i) {
                    self.error(
                        Some(&a),
                        "the dragged axis cannot change while the helix is on (G98 first)".into(),
                    );
                } else {
                    let v = if i == 0 && self.diameter {
                        a.value * 0.5
                    } else {
                        a.value
                    };
                    self.pitch = Some((i, v));
                    // a new pitch counts from here
                    if self.helix.is_some() {
                        self.helix = Some((self.pos[i], 0.0));
                    }
                }
            }
            return false;
        }
        if let Some(g09) = w.get(slot::HELIX_ON) {
            match self.pitch {
                None => self.error(
                    Some(&g09),
                    "G09 (helix on) needs a pitch programmed before it (a G10 block such as Z1.05 G10)".into(),
                ),
                Some((d, _)) => {
                    if self.helix.is_none() {
                        self.helix = Some((self.pos[d], 0.0));
                    }
                }
            }
        }
        if let (Some((d, _)), Some(_)) = (self.pitch, self.helix) {
            if let Some(a) = w.axis(d) {
                self.error(
                    Some(&a),
                    format!(
                        "axis {} is dragged by the helix (G09): it cannot be programmed until G98",
                        AXIS_LETTERS[d] as char
                    ),
                );
                return false;
            }
        }
        if let Some(l) = w.get(slot::L).filter(|_| !w.has(slot::JUMP)) {
            self.error(Some(&l), "address L is only used with G73 (jump)".into());
        }
        if let Some(q) = w.get(slot::Q).filter(|_| !w.has(slot::JUMP)) {
            self.error(Some(&q), "address Q is only used with G73 (jump)".into());
        }
        true
    }

    /// G73 L<n> Q<q> after its block ran: jumps back to N<n> while the
    /// block's counter lasts; the counter resets when the loop is done.
    fn exec_jump(&mut self, w: &Words, g73: &Word) {
        let (Some(l), q) = (w.get(slot::L), w.get(slot::Q)) else {
            self.error(
                Some(g73),
                "G73 needs the target block L<n> (and the repeat count Q)".into(),
            );
            return;
        };
        let Some(n) = jump_target(&l) else {
            self.error(
                Some(&l),
                format!("L must be a block number, found L{}", num(l.value)),
            );
            return;
        };
        let count = match q {
            None => 0,
            Some(q) => match jump_count(&q) {
                Some(c) => c as u32,
                None => {
                    self.error(
                        Some(&q),
                        format!("Q must be a whole number 0..9999, found Q{}", num(q.value)),
                    );
                    return;
                }
            },
        };
        let line = self.last.line;
        let target = match self.targets.get(&line) {
            Some(t) => *t,
            None => {
                if !self.src.can_seek() {
                    self.needs_seek = true;
                    self.finished = true;
                    return;
                }
                if self.loop_scan == LoopScan::Wanted {
                    self.loop_scan = LoopScan::Done;
                    match self.scan_loops() {
                        Ok(None) => {}
                        Ok(Some(d)) => {
                            self.error_count += 1;
                            if self.errors.len() < self.max_errors {
                                self.errors.push(d);
                            }
                            self.finish();
                            return;
                        }
                        Err(e) => {
                            self.read_failed(&e);
                            return;
                        }
                    }
                }
                match self.find_block(n as u64, line) {
                    Ok(Some(t)) => {
                        self.targets.insert(line, t);
                        t
                    }
                    Ok(None) => {
                        self.error(
                            Some(&l),
                            format!("jump target N{n} is not a block at or before this one (G73 jumps back only)"),
                        );
                        return;
                    }
                    Err(e) => {
                        self.read_failed(&e);
                        return;
                    }
                }
            }
        };
        let i = match self.loops.iter().position(|l| l.0 == line) {
            Some(i) => i,
            None => {
                self.loops.push((line, count, None));
                self.loops.len() - 1
            }
        };
        if self.loops[i].1 == 0 {
            // done: the counter resets, so an enclosing loop may run it again
            self.loops.remove(i);
            return;
        }
        if !self.src.can_seek() {
            self.needs_seek = true;
            self.finished = true;
            return;
        }
        // the blocks this loop will have run: every pass runs the same
        // blocks (inner loops' counters reset), so after one repeated pass
        // the total is known; before it, what has run so far
        let (left, last) = (self.loops[i].1, self.loops[i].2);
        let projected = match last {
            Some(at) => self
                .executed
                .saturating_add((self.executed - at).saturating_mul(left as u64)),
            None => self.executed,
        };
        if projected > self.max_executed {
            let max = self.max_executed;
            let text = match last {
                Some(at) => format!(
                    "this loop would make the program execute {projected} blocks, more than the machine's limit of {max} (limits.max_executed_blocks): {left} more passes of {} blocks back to N{n}",
                    self.executed - at
                ),
                None => format!(
                    "this loop would make the program execute more than the machine's limit of {max} blocks (limits.max_executed_blocks): {} have run, and {left} more passes back to N{n} are due",
                    self.executed
                ),
            };
            self.error(Some(g73), text);
            self.finish();
            return;
        }
        self.loops[i].2 = Some(self.executed);
        self.loops[i].1 -= 1;
        self.jumps += 1;
        if let Err(e) = self.src.seek(target) {
            self.read_failed(&e);
        }
    }

    /// How many blocks the program would run with its G73 loops, counted
    /// from the loops' structure (two reads of the program, memory for its
    /// G73 blocks only): a block runs the product of (Q + 1) over the loops
    /// around it (exact for nested loops; overlapping ones are caught as
    /// they run, by the count in `exec_parsed`). Over `limits.max_executed_blocks`:
    /// the error, at the G73 of the outermost loop around the blocks that
    /// made it so. Returns to where the interpreter was.
    fn scan_loops(&mut self) -> Result<Option<Diagnostic>, SourceError> {
        struct Jump {
            pos: SourcePos,
            word: Word,
            block_no: Option<u64>,
            target: u64,
            times: f64,
            /// blocks through this one, and before its target
            end: u64,
            start: Option<u64>,
        }
        let here = self.cur_pos;
        let mut jumps: Vec<Jump> = Vec::new();
        let mut buf = Vec::new();
        let mut block = Block::default();
        let is_g73 = |w: &Word| w.letter == b'G' && w.value == 73.0;
        // first read: the G73 blocks (those the interpreter would run)
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let mut blocks = 0u64;
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_err()
                || block.words.is_empty()
            {
                continue;
            }
            blocks += 1;
            let Some(g73) = block.words.iter().find(|w| is_g73(w)) else {
                continue;
            };
            let word = |c: u8| block.words.iter().find(|w| w.letter == c);
            let target = word(b'L').and_then(jump_target);
            let times = match word(b'Q') {
                None => Some(1),
                Some(q) => jump_count(q).map(|c| c + 1),
            };
            if let (Some(target), Some(times)) = (target, times) {
                jumps.push(Jump {
                    pos,
                    word: *g73,
                    block_no: block_no(&block.words),
                    target: target as u64,
                    times: times as f64,
                    end: blocks,
                    start: None,
                });
            }
        }
        // second read: each loop's first block (the last N<target> at or
        // before its G73), counted in blocks
        let wanted: std::collections::HashSet<u64> = jumps.iter().map(|j| j.target).collect();
        let mut last_at: std::collections::HashMap<u64, u64> = std::collections::HashMap::new();
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let (mut blocks, mut next) = (0u64, 0usize);
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if next >= jumps.len() {
                break;
            }
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_err()
                || block.words.is_empty()
            {
                continue;
            }
            if let Some(n) = block_no(&block.words).filter(|n| wanted.contains(n)) {
                last_at.insert(n, blocks);
            }
            blocks += 1;
            while next < jumps.len() && jumps[next].pos.line == pos.line {
                jumps[next].start = last_at.get(&jumps[next].target).copied();
                next += 1;
            }
        }
        self.src.seek(here)?;
        self.src.read_line(&mut buf)?;
        // blocks run: over the stretches between the loops' ends, the
        // stretch's blocks times the product of the loops around it
        let mut edges: Vec<(u64, usize)> = Vec::new();
        for (i, j) in jumps.iter().enumerate() {
            if let Some(s) = j.start {
                edges.push((s, i));
                edges.push((j.end, i));
            }
        }
        edges.sort_unstable();
        let mut open: Vec<usize> = Vec::new();
        let (mut total, mut at) = (0.0f64, 0u64);
        for (x, i) in edges {
            // (exact while below 2^53; past f64's range it is infinite,
            // which is over any limit too)
            let times: f64 = open.iter().map(|&k| jumps[k].times).product();
            total += (x - at) as f64 * times;
            at = x;
            if total > self.max_executed as f64 {
                // the outermost loop around this stretch
                let Some(&k) = open
                    .iter()
                    .min_by_key(|&&k| (jumps[k].start, u64::MAX - jumps[k].end))
                else {
                    break;
                };
                let j = &jumps[k];
                let runs = total + (blocks.saturating_sub(at)) as f64;
                let runs = if runs < 1e15 {
                    format!("{runs:.0}")
                } else {
                    format!("about {runs:.1e}")
                };
                let mut d = Diagnostic::new(
                    j.pos.line,
                    j.word.col,
                    j.word.len,
                    format!(
                        "with its loops the program would run {runs} blocks or more, over the \
                         machine's limit of {} (limits.max_executed_blocks; loops are executed, \
                         not expanded: fewer repetitions, or fewer nested loops)",
                        self.max_executed
                    ),
                );
                d.block_no = j.block_no;
                self.src.seek(j.pos)?;
                if self.src.read_line(&mut buf)?.is_some() {
                    d.source = String::from_utf8_lossy(&buf).into_owned();
                }
                self.src.seek(here)?;
                self.src.read_line(&mut buf)?;
                return Ok(Some(d));
            }
            match open.iter().position(|&k| k == i) {
                Some(p) => {
                    open.swap_remove(p);
                }
                None => open.push(i),
            }
        }
        Ok(None)
    }

    /// The last line at or before `upto` whose block number is `n`; reads
    /// the program from the start and returns to the line after `upto`.
    fn find_block(&mut self, n: u64, upto: u32) -> Result<Option<SourcePos>, SourceError> {
        let here = self.cur_pos;
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let mut found = None;
        let mut buf = Vec::new();
        let mut block = Block::default();
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if pos.line > upto {
                break;
            }
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_ok()
                && block_no(&block.words) == Some(n)
            {
                found = Some(pos);
            }
        }
        self.src.seek(here)?;
        self.src.read_line(&mut buf)?;
        Ok(found)
    }

    /// Blocks that set the pole: I/J (plane-dependent) with no motion, in
    /// a dialect whose centre words alone set it, or G29 (the pole where
    /// the tool stands). False: the block is done.
    fn pole_block(&mut self, w: &Words) -> bool {
        let (p, q, n) = self.modal.plane.axes();
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
                    self.modal.plane.gcode(),
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
    fn exec_polar(&mut self, w: &Words, src: Src) {
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
            if h.value == 0.0 || (h.value > 0.0) != ccw {
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

    fn exec_dwell(&mut self, w: &Words, g4: &Word, src: Src) {
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

    fn exec_motion(&mut self, w: &Words, src: Src) {
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
            if let (Some(a), Some((d, pitch)), Some((base, turns))) =
                (arc.as_mut(), self.pitch, self.helix)
            {
                // G09: the dragged axis moves pitch x turns; the turns are
                // summed, and the position computed from them, so no error
                // accumulates over thousands of turns
                let (p, q, _) = a.plane.axes();
                if d == p || d == q {
                    self.error(
                        anchor.as_ref(),
                        format!(
                            "the dragged axis {} is an axis of this arc's {} plane",
                            AXIS_LETTERS[d] as char,
                            a.plane.gcode()
                        ),
                    );
                } else {
                    let turns = turns + a.sweep.abs() / std::f64::consts::TAU;
                    self.helix = Some((base, turns));
                    target[d] = base + pitch * turns;
                    *a = Arc::new(
                        a.start,
                        target,
                        a.center,
                        a.plane,
                        motion == Motion::CcwArc,
                        0,
                    );
                    // F is the speed of the circular motion in the plane
                    let c = a.plane_fraction();
                    feed = feed.map(|f| match f {
                        Feed::PerMin(v) => Feed::PerMin(v / c),
                        Feed::PerRev { mm_per_rev, rpm } => Feed::PerRev {
                            mm_per_rev: mm_per_rev / c,
                            rpm,
                        },
                        Feed::Rapid => Feed::Rapid,
                    });
                }
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

    /// Hands a canonical command on to the stages behind the interpreter
    /// (compensation, blending), reporting what they find at this block.
    #[inline]
    fn emit(&mut self, ev: Event) {
        self.canon.command(ev, &mut self.canon_errors);
        if !self.canon_errors.is_empty() {
            for e in std::mem::take(&mut self.canon_errors) {
                self.error(None, e);
            }
        }
    }

    /// T: selects a tool table entry (lathe `T####`: the offset is the
    /// last two digits, 00 cancels it; mill `T<n>`: tool n). False: an
    /// error was reported.
    fn select_tool(&mut self, n: u32, t: &Word) -> bool {
        if self.tools.is_empty() {
            return true;
        }
        let number = if self.lathe { n % 100 } else { n };
        if number == 0 {
            self.tool_cfg = None;
            self.canon.set_tool_offset(V3::zeros());
            return true;
        }
        match self.tools.iter().find(|x| x.number == number) {
            Some(cfg) => {
                self.canon.set_tool_offset(cfg.offset());
                self.tool_cfg = Some(cfg.clone());
                true
            }
            None => {
                let have: Vec<String> = self.tools.iter().map(|x| x.number.to_string()).collect();
                let what = if self.lathe {
                    format!("tool offset {number:02} (T{n:04})")
                } else {
                    format!("tool T{n}")
                };
                self.error(
                    Some(t),
                    format!(
                        "{what} is not in the machine's tool table (it has {})",
                        have.join(", ")
                    ),
                );
                false
            }
        }
    }

    /// G40/G41/G42.
    fn exec_comp(&mut self, code: u8, g: &Word) {
        if code == 40 {
            self.canon.set_compensation(None);
            return;
        }
        let Some(tool) = self.tool_cfg.clone() else {
            self.error(
                Some(g),
                format!(
                    "G{code} (radius compensation) needs a tool from the machine's tool table: select one with T first"
                ),
            );
            return;
        };
        let r = tool.radius_mm;
        let mut tip = V3::zeros();
        if self.lathe {
            let (x, z) = tip_vector(tool.tip);
            tip[0] = x * r;
            tip[2] = z * r;
        }
        self.canon.set_compensation(Some(CompMode {
            side: if code == 41 { 1.0 } else { -1.0 },
            radius: r,
            plane: self.modal.plane,
            tip,
        }));
    }

    /// G33: a thread block (cnc836). It is held back until the next block
    /// says whether the thread goes on (a chain) or ends here.
    fn exec_thread(&mut self, w: &Words, g33: &Word, src: Src, prev: Option<V3>) {
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
        let w_p = rpm.abs() * SPEED_MARGIN / 60.0; // rev/s
        let v_lead = pitch * w_p;
        let mut end = target;
        let mut runout = None;
        if let Some(j) = w.center(1) {
            let Some((ax, tan)) = self.th.runout else {
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
                    num(j.value),
                    num(len)
                ))
            } else {
                None
            };
            if let Some(why) = why {
                self.error(Some(&j), why);
                return;
            }
            // the kink is rounded so that the runout axis accelerates
            // within half its share (the other half: the deceleration)
            let blend = tan.abs() * v_lead * v_lead / (0.5 * THREAD_SHARE * self.th.amax[ax]);
            if 0.5 * blend > j.value {
                self.error(
                    Some(&j),
                    format!(
                        "runout J{} is too short to leave the thread at S{}: axis {} needs at least {} mm of {lead_name} travel to pick up speed (or lower S)",
                        num(j.value),
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
        // speeds and accelerations in the thread
        let (r0, r1) = seg.ratios();
        let mut accel = f64::INFINITY;
        for i in 0..3 {
            let r = r0[i].abs().max(r1[i].abs());
            if !self.present[i] || r < 1e-12 {
                continue;
            }
            if v_lead * r > self.th.vmax[i] {
                let s_max = self.th.vmax[i] / (r * pitch * SPEED_MARGIN) * 60.0;
                self.error(
                    Some(&anchor),
                    format!(
                        "G33 at S{} with pitch F{}: axis {} would move at {} mm/s in the thread, over its {} mm/s; lower S to at most {}",
                        num(rpm.abs()),
                        num(pitch),
                        AXIS_LETTERS[i] as char,
                        round_up(v_lead * r),
                        num(self.th.vmax[i]),
                        s_max.floor()
                    ),
                );
                return;
            }
            let share = if runout.is_some_and(|ro| ro.axis == i) {
                0.5
            } else {
                1.0
            };
            accel = accel.min(THREAD_SHARE * share * self.th.amax[i] / r);
        }
        let delta = pitch * w_p * w_p / accel; // revolutions
        let ramp = 0.5 * pitch * delta; // lead travel, mm
        let room = runout.map_or(len, |ro| ro.from - 0.5 * ro.blend);
        if !chained && ramp > room {
            self.error(
                Some(&anchor),
                format!(
                    "G33: the run-in needs {} mm of {lead_name} travel at S{} (pitch F{}) to reach the thread's speed; the block has {} mm{}: start the thread {} mm earlier or lower S",
                    round_up(ramp),
                    num(rpm.abs()),
                    num(pitch),
                    num(room),
                    if runout.is_some() { " before the runout" } else { "" },
                    round_up(ramp - room)
                ),
            );
            return;
        }
        if let Some(v_prev) = prev {
            let v_now = r0 * v_lead;
            for i in 0..3 {
                let jump = (v_now[i] - v_prev[i]).abs();
                if self.present[i] && jump > KINK_SHARE * self.th.amax[i] * self.th.dt {
                    self.error(
                        Some(&anchor),
                        format!(
                            "chained G33 blocks must continue the thread smoothly: axis {}'s speed would jump by {} mm/s at this block's start, more than the axis can follow in sync (same direction and pitch, or end the thread and start a new one)",
                            AXIS_LETTERS[i] as char,
                            round_up(jump)
                        ),
                    );
                    return;
                }
            }
        }
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
            runin: (!chained).then_some((start_rev, delta)),
            decel: None,
            accel,
        };
        self.held = Some(Box::new(Held {
            m,
            accel,
            runin_len: if chained { 0.0 } else { ramp },
            v_end: r1 * v_lead,
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
    fn release_thread(&mut self, next_is_g33: bool) -> Option<V3> {
        let h = self.held.take()?;
        let mut m = h.m;
        let chained = next_is_g33 && m.seg.runout.is_none();
        if !chained {
            let w_p = m.rpm.abs() * SPEED_MARGIN / 60.0;
            let delta = m.seg.pitch * w_p * w_p / h.accel;
            let ramp = 0.5 * m.seg.pitch * delta;
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
    fn runout_rules(&mut self, parsed: bool, words: &[Word]) {
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

    /// Checks a move's travel, adds it to the bounding box and queues it
    /// (if it has a feed).
    fn add_move(
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

    fn feed_for(&mut self, anchor: Option<&Word>, w: &Words) -> Option<Feed> {
        let fw = w.f();
        let f = match self.modal.feed {
            Some(f) if f > 0.0 => f,
            _ => {
                let at = fw.or(anchor.copied());
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
            Some(Feed::PerRev { mm_per_rev: f, rpm })
        } else {
            Some(Feed::PerMin(f))
        }
    }

    fn arc_geom(&mut self, w: &Words, target: V3, ccw: bool, anchor: Option<&Word>) -> Option<Arc> {
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
    fn changes_nothing(&self, geom: &Geom) -> bool {
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
    fn check_travel(&mut self, geom: &Geom, (lo, hi): (V3, V3), w: &Words, anchor: Option<&Word>) {
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
    fn grow_bbox(&mut self, lo: V3, hi: V3) {
        travel::grow(&mut self.bbox, lo, hi);
    }

    /// Axis `i`'s word `a` in machine coordinates (lathe X: the radius),
    /// absolute or from the current position.
    fn axis_target(&self, i: usize, a: &Word, absolute: bool) -> f64 {
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
    fn target_of(&self, w: &Words) -> V3 {
        let mut target = self.pos;
        for i in 0..3 {
            if let Some(a) = w.axis(i) {
                target[i] = self.axis_target(i, &a, self.modal.absolute);
            }
        }
        target
    }
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
