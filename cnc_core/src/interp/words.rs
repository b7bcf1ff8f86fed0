//! The words of one block sorted by meaning: the shared core's codes and
//! addresses, and the dialect's (from its [`Rules`](crate::dialect::Rules)),
//! each claimed once, every unknown or doubled word reported.

use super::modal::{Motion, SpindleDir, MOTIONS, POLAR};
use super::state::Interpreter;
use crate::canon::Canon;
use crate::diag::num;
use crate::dialect::Meaning;
use crate::geom::Plane;
use crate::parse::Word;
use crate::source::ProgramSource;

pub(super) const AXIS_LETTERS: [u8; 3] = [b'X', b'Y', b'Z'];

pub(super) const CENTER_LETTERS: [u8; 3] = [b'I', b'J', b'K'];

/// Slots of [`Words`], one per meaning.
pub(super) mod slot {
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
    /// M06, and M08/M09 (accepted, nothing to simulate)
    pub const TOOL_CHANGE: usize = 30;
    pub const COOLANT: usize = 31;
    pub const COUNT: usize = 32;

    /// The slot of a word with a dialect's meaning.
    pub fn of(m: crate::dialect::Meaning) -> usize {
        use crate::dialect::Meaning as M;
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
pub(super) struct Words<'b> {
    pub(super) all: &'b [Word],
    pub(super) at: [u8; slot::COUNT],
    /// what the G/M code in the MOTION, PLANE, DISTANCE, FEED_MODE and
    /// SPINDLE slots selects (kept apart from the word: tuples of an enum
    /// and a word made slow copies)
    pub(super) motion: Motion,
    pub(super) plane: Plane,
    pub(super) absolute: bool,
    pub(super) per_rev: bool,
    pub(super) spindle: SpindleDir,
    /// 40, 41 or 42
    pub(super) comp: u8,
    /// 61 or 64
    pub(super) path: u8,
}

impl<'b> Words<'b> {
    #[inline]
    pub(super) fn new(all: &'b [Word]) -> Self {
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
    pub(super) fn get(&self, slot: usize) -> Option<Word> {
        match self.at[slot] {
            0 => None,
            k => Some(self.all[k as usize - 1]),
        }
    }
    #[inline]
    pub(super) fn has(&self, slot: usize) -> bool {
        self.at[slot] != 0
    }
    #[inline]
    pub(super) fn dwell(&self) -> Option<Word> {
        self.get(slot::DWELL)
    }
    #[inline]
    pub(super) fn axis(&self, i: usize) -> Option<Word> {
        self.get(slot::AXIS + i)
    }
    #[inline]
    pub(super) fn center(&self, i: usize) -> Option<Word> {
        self.get(slot::CENTER + i)
    }
    /// X, Y, Z in order
    #[inline]
    pub(super) fn axes(&self) -> impl Iterator<Item = Option<Word>> + '_ {
        (0..3).map(|i| self.axis(i))
    }
    /// I, J, K in order
    #[inline]
    pub(super) fn centers(&self) -> impl Iterator<Item = Option<Word>> + '_ {
        (0..3).map(|i| self.center(i))
    }
    #[inline]
    pub(super) fn f(&self) -> Option<Word> {
        self.get(slot::F)
    }
    #[inline]
    pub(super) fn s(&self) -> Option<Word> {
        self.get(slot::S)
    }
    #[inline]
    pub(super) fn t(&self) -> Option<Word> {
        self.get(slot::T)
    }
    #[inline]
    pub(super) fn p(&self) -> Option<Word> {
        self.get(slot::P)
    }
    #[inline]
    pub(super) fn end(&self) -> Option<Word> {
        self.get(slot::END)
    }
}

/// A word as written, for messages: `G1.` stays `G1.` (its point is
/// why it is not a whole number), `G1.5` is `G1.5`.
pub(super) fn written(word: &Word) -> String {
    let point = if !word.integer && word.value.fract() == 0.0 {
        "."
    } else {
        ""
    };
    format!("{}{}{point}", word.letter as char, num(word.value))
}

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// Sorts the words of a block, reporting unknown and duplicate words.
    pub(super) fn classify(&mut self, w: &mut Words) {
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
                            format!("G code must be a whole number, found {}", written(word)),
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
                            format!("M code must be a whole number, found {}", written(word)),
                        );
                        continue;
                    };
                    match code {
                        3 => once!(slot::SPINDLE, w.spindle = SpindleDir::Cw, "a spindle M code (M03-M05)"),
                        4 => once!(slot::SPINDLE, w.spindle = SpindleDir::Ccw, "a spindle M code (M03-M05)"),
                        5 => once!(slot::SPINDLE, w.spindle = SpindleDir::Off, "a spindle M code (M03-M05)"),
                        2 | 30 => once!(slot::END, "a program end (M02/M30)"),
                        // tool change and coolant: accepted, nothing to simulate
                        6 => once!(slot::TOOL_CHANGE, "a tool change (M06)"),
                        8 | 9 => once!(slot::COOLANT, "a coolant M code (M08/M09)"),
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
}
