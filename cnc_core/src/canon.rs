//! The canonical commands: what the interpreter hands on, in program
//! order, to the stages behind it (compensation, blending, the planner),
//! and the interface it hands them through (LinuxCNC's `canon.hh` seam).
//! Everything downstream depends on this module; it depends on nothing
//! but the geometry. The data lives here; each command's behaviour lives
//! with its concern (a thread's lead as a function of the spindle angle
//! in `thread.rs`, compensation in `comp.rs`).

use crate::geom::{Geom, Plane, V3};
use std::collections::VecDeque;

/// Where an event came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Src {
    pub line: u32,
    pub block_no: Option<u64>,
}

/// The smallest feed a move or a thread's lead may have, mm/min (G94's F;
/// G95's F times S; G33's pitch times S): the smallest most controls
/// take. Below it a 10 mm move would take over a week, and at the least
/// sizes a float takes a move's time no longer counts in samples.
pub const MIN_FEED_MM_MIN: f64 = 0.001;

/// How fast a move goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Feed {
    /// G00: as fast as the axes allow
    Rapid,
    /// G94: mm/min along the path
    PerMin(f64),
    /// G95: mm per spindle revolution, with the commanded speed in rpm
    PerRev { mm_per_rev: f64, rpm: f64 },
}

impl Feed {
    /// Path speed in mm/s (infinite for rapid: the axes limit it).
    #[inline]
    pub fn speed_mm_s(&self) -> f64 {
        match *self {
            Feed::Rapid => f64::INFINITY,
            Feed::PerMin(f) => f / 60.0,
            Feed::PerRev { mm_per_rev, rpm } => mm_per_rev * rpm.abs() / 60.0,
        }
    }
}

/// A canonical command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    Move {
        geom: Geom,
        feed: Feed,
        src: Src,
    },
    Dwell {
        seconds: f64,
        src: Src,
    },
    /// spindle command, rpm, signed (+ = M03 clockwise)
    Spindle {
        rpm: f64,
        src: Src,
    },
    Tool {
        number: u32,
        src: Src,
    },
    /// G33: a thread block, synchronized with the spindle
    Thread(ThreadMove),
    /// The path tolerance (G64 P, G61) changed so much that the jerk
    /// filters must change with it (the front emits it only then): the
    /// moves before it end in an exact stop, those after run with the XYZ
    /// filter and caps for tolerance `mm` (0: G61).
    Tolerance {
        mm: f64,
    },
    /// M02/M30 or the end of the text
    End {
        src: Src,
    },
}

/// The runout of a thread block, along its lead travel `u`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunoutPath {
    /// the axis that leaves the thread (0 X, 1 Y, 2 Z)
    pub axis: usize,
    /// lead travel at which the runout begins (`len − J`), mm
    pub from: f64,
    /// tan of the runout angle, signed (the direction the axis moves)
    pub tan: f64,
    /// width of the curve that rounds the kink at `from`, mm: the runout
    /// axis's slope du/dθ grows from 0 to `tan` over it
    pub blend: f64,
    /// length of the jerk phase at either end of that curve, mm (0: a
    /// parabola, the acceleration steps; see [`crate::thread::s_ramp`])
    pub jerk_phase: f64,
}

/// The path of one G33 block, parametrized by the lead axis travel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadSeg {
    pub start: V3,
    /// the programmed end point
    pub prog_end: V3,
    /// where the tool ends: the programmed end, moved by the runout
    pub end: V3,
    /// the lead axis (largest travel)
    pub lead: usize,
    /// lead axis travel, mm (> 0)
    pub len: f64,
    /// pitch along the lead axis, mm per revolution
    pub pitch: f64,
    pub runout: Option<RunoutPath>,
}

/// A planned G33 block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadMove {
    pub seg: ThreadSeg,
    pub src: Src,
    /// programmed spindle speed, rpm, signed (+ M03)
    pub rpm: f64,
    /// the first block of a chain: its start angle from the index, in
    /// revolutions (I/360), and the run-in Δ, revolutions
    pub runin: Option<(f64, f64)>,
    /// the last block of a chain: the deceleration Δ, revolutions
    pub decel: Option<f64>,
    /// lead acceleration of the run-in and the deceleration, mm/s² (a
    /// controlled stop in the thread uses it too)
    pub accel: f64,
    /// lead jerk of the run-in and the deceleration, mm/s³ (infinite: the
    /// machine has no jerk limit, and both are parabolas in θ)
    pub jerk: f64,
}

/// Which side the tool is on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompMode {
    /// +1: G41 (left), −1: G42 (right)
    pub side: f64,
    /// tool radius, mm
    pub radius: f64,
    pub plane: Plane,
    /// R × the tip vector (lathe tool type), machine coordinates
    pub tip: V3,
}

/// What the interpreter drives, command by command, as each block runs:
/// the stages between it and the planner. The interpreter owns one and
/// reports the errors it returns at the block running now; it never
/// looks inside.
pub trait Canon {
    /// Takes the next command. Errors found (on the path this command
    /// completes) are added to `errors` as texts.
    fn command(&mut self, cmd: Event, errors: &mut Vec<String>);
    /// G40 (`None`), G41/G42: in force from the next move in the plane on;
    /// `at`: the block that programs it.
    fn set_compensation(&mut self, mode: Option<CompMode>, at: Src);
    /// The selected tool's geometry offset, machine coordinates.
    fn set_tool_offset(&mut self, offset: V3);
    /// The path tolerance (G64 P), mm; 0: exact path (G61).
    fn set_path_tolerance(&mut self, mm: f64);
    /// G41 or G42 is programmed (in force, or from the next move on).
    fn compensating(&self) -> bool;
    /// Moves pass on exactly as programmed: no compensation, nothing held
    /// back, no tool offset. (Otherwise the travel limits are checked on
    /// the compensated path, by the stage itself.)
    fn passes_through(&self) -> bool;
    /// Commands ready for the planner.
    fn ready(&self) -> usize;
    /// The next command ready for the planner.
    fn pop(&mut self) -> Option<Event>;
    /// Moves every command ready into `batch` (emptied first).
    fn take(&mut self, batch: &mut VecDeque<Event>);
}
