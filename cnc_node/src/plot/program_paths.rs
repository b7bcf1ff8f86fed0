//! The programmed path and, under radius compensation (G41/G42), the
//! programmed contour, the nose- or cutter-centre path and the tip's path,
//! from the interpreter's moves (a second, partial reading of the program:
//! the plane, compensation and tool selection of each line).

use super::decimate::{one_run, Decimator, MAX_SERIES_POINTS};
use cnc_core::canon::{Event, Feed};
use cnc_core::geom::{Geom, Plane};
use cnc_core::interp::Interpreter;
use cnc_core::machine::{tip_vector, MachineKind, ToolConfig};
use cnc_core::parse::{parse_line, Block};
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine, V3};

/// Tags of the programmed path's runs.
pub(crate) const RAPID: u8 = 1;
pub(crate) const FEED: u8 = 0;

/// Largest angle of one chord when an arc is sampled, rad (2°).
const ARC_STEP_RAD: f64 = std::f64::consts::PI / 90.0;

/// A move's geometry sampled with `Geom::eval`: lines their ends, arcs
/// chords of at most 2°.
fn geom_points(geom: &Geom, mut f: impl FnMut(V3)) {
    f(geom.start());
    let n = match geom {
        Geom::Line { .. } => 1,
        Geom::Arc(a) => ((a.sweep.abs() / ARC_STEP_RAD).ceil() as usize).clamp(4, 100_000),
    };
    let len = geom.length();
    for i in 1..=n {
        f(geom.eval(len * i as f64 / n as f64));
    }
}

/// The machine with every tool's radius and tool type 0: on it the
/// interpreter's moves are the programmed contour (G41/G42 offset by
/// nothing; geometry offsets stay, so the contour is in the setpoints'
/// frame).
pub fn without_radii(machine: &Machine) -> Machine {
    let mut m = machine.clone();
    for t in &mut m.tools {
        t.radius_mm = 0.0;
        t.tip = 0;
    }
    m
}

/// The G words of one line the plot follows: the plane (G17-G19) and
/// radius compensation (40, 41, 42).
#[derive(Clone, Copy, Debug, Default)]
struct LineModes {
    plane: Option<Plane>,
    comp: Option<u8>,
}

/// Each line's [`LineModes`] (index: line − 1). A line that does not
/// parse counts with the words before its error (the program is checked
/// before it is plotted anyway).
fn line_modes(dialect: Dialect, text: &str) -> Vec<LineModes> {
    let mut block = Block::default();
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let mut m = LineModes::default();
            let _ = parse_line(dialect, i as u32 + 1, line.as_bytes(), &mut block);
            for w in block.words.iter().filter(|w| w.letter == b'G') {
                match w.as_int() {
                    Some(17) => m.plane = Some(Plane::XY),
                    Some(18) => m.plane = Some(Plane::ZX),
                    Some(19) => m.plane = Some(Plane::YZ),
                    Some(c @ 40..=42) => m.comp = Some(c as u8),
                    _ => {}
                }
            }
            m
        })
        .collect()
}

/// Follows the plane, radius compensation and the selected tool along the
/// interpreter's events. Events come in the order the blocks run; the
/// modes of the lines from the previous event's line to this event's are
/// applied in order (after a jump back, G73, only the event's own line).
struct CompTracker<'a> {
    modes: &'a [LineModes],
    next_line: u32,
    plane: Plane,
    active: bool,
    lathe: bool,
    tools: &'a [ToolConfig],
    tool: Option<&'a ToolConfig>,
}

/// Where a move stands with respect to radius compensation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CompMove {
    Off,
    /// the block with G41/G42: from the uncompensated to the compensated
    /// position
    Entry,
    On,
}

impl<'a> CompTracker<'a> {
    fn new(machine: &'a Machine, modes: &'a [LineModes]) -> CompTracker<'a> {
        let lathe = machine.kind == MachineKind::Lathe;
        CompTracker {
            modes,
            next_line: 1,
            plane: if lathe { Plane::ZX } else { Plane::XY },
            active: false,
            lathe,
            tools: &machine.tools,
            tool: None,
        }
    }

    /// The state of a move from `line`.
    fn at(&mut self, line: u32) -> CompMove {
        let from = if line >= self.next_line {
            self.next_line
        } else {
            line
        };
        let mut entry = false;
        for l in from.max(1)..=line {
            let Some(m) = self.modes.get(l as usize - 1) else {
                break;
            };
            if let Some(p) = m.plane {
                self.plane = p;
            }
            if let Some(c) = m.comp {
                self.active = c != 40;
                entry = l == line && c != 40;
            }
        }
        self.next_line = line.saturating_add(1);
        match (self.active, entry) {
            (false, _) => CompMove::Off,
            (true, true) => CompMove::Entry,
            (true, false) => CompMove::On,
        }
    }

    /// A `T` word: the tool (mill) or offset (lathe, the last two digits).
    fn select(&mut self, number: u32) {
        let n = if self.lathe { number % 100 } else { number };
        self.tool = (n != 0)
            .then(|| self.tools.iter().find(|t| t.number == n))
            .flatten();
    }

    /// The selected tool's radius, mm.
    fn radius(&self) -> f64 {
        self.tool.map_or(0.0, |t| t.radius_mm)
    }

    /// From the nose centre to the imaginary tip (lathe): R × the tool
    /// type's tip vector, machine coordinates.
    fn tip(&self) -> V3 {
        match self.tool {
            Some(t) if self.lathe => {
                let (x, z) = tip_vector(t.tip);
                V3::new(x, 0.0, z) * t.radius_mm
            }
            _ => V3::zeros(),
        }
    }
}

/// The outline of the tool (nose circle, cutter) at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolOutline {
    pub centre: V3,
    pub radius: f64,
    pub plane: Plane,
}

/// A bounding box, `(min, max)`.
pub(crate) type Box3 = (V3, V3);

pub(crate) fn grow(b: &mut Option<Box3>, p: V3) {
    match b {
        Some((lo, hi)) => {
            *lo = lo.inf(&p);
            *hi = hi.sup(&p);
        }
        None => *b = Some((p, p)),
    }
}

/// The paths of a program under radius compensation, for [`plot_program`](super::plot_program).
#[derive(Clone, Debug)]
pub struct CompPaths {
    /// the programmed contour: the interpreter's moves on
    /// [`without_radii`] of the machine, as runs tagged rapid (1) or feed (0)
    pub contour: Vec<(u8, Vec<V3>)>,
    /// the nose (lathe) or cutter (mill) centre: the commanded point minus
    /// R × the selected tool's tip vector (on a mill the commanded point)
    pub centre: Vec<V3>,
    /// the commanded point: the imaginary tip (lathe; the cutter centre on
    /// a mill), the interpreter's moves on the machine itself
    pub tip: Vec<V3>,
    /// the tool's outline at the end of every compensated move (the entry
    /// included, the G40 block not), thinned to at most
    /// [`MAX_OUTLINES`]
    pub outlines: Vec<ToolOutline>,
    /// the bounding box of the compensated part: the three paths of the
    /// compensated moves after the entry, the entries' ends, the outlines
    pub comp_box: Option<Box3>,
    /// the machine has tool types (a lathe): the tip and the centre differ
    pub lathe: bool,
}

/// Most tool outlines [`comp_paths`] keeps.
pub const MAX_OUTLINES: usize = 200;

/// The programmed contour, the nose- or cutter-centre path and the
/// commanded (tip) path of a program that uses G41/G42 (`None` if no line
/// holds either). The program should pass the check first.
pub fn comp_paths(machine: &Machine, dialect: Dialect, text: &str) -> Option<CompPaths> {
    let modes = line_modes(dialect, text);
    if !modes.iter().any(|m| matches!(m.comp, Some(41 | 42))) {
        return None;
    }
    let mut comp_box = None;
    // the contour
    let bare = without_radii(machine);
    let mut contour = Decimator::new(MAX_SERIES_POINTS);
    let mut tr = CompTracker::new(&bare, &modes);
    for ev in Interpreter::new(StrSource::new(text), dialect, &bare) {
        let Event::Move { geom, feed, src } = ev else {
            continue;
        };
        let state = tr.at(src.line);
        let tag = if matches!(feed, Feed::Rapid) {
            RAPID
        } else {
            FEED
        };
        geom_points(&geom, |p| {
            contour.push(tag, p);
            if state == CompMove::On {
                grow(&mut comp_box, p);
            }
        });
    }
    // the machine itself: the tip, the centre, the outlines
    let mut tip = Decimator::new(MAX_SERIES_POINTS);
    let mut centre = Decimator::new(MAX_SERIES_POINTS);
    let mut outlines = Decimator::new(MAX_OUTLINES);
    let mut tr = CompTracker::new(machine, &modes);
    for ev in Interpreter::new(StrSource::new(text), dialect, machine) {
        let (geom, src) = match ev {
            Event::Tool { number, .. } => {
                tr.select(number);
                continue;
            }
            Event::Move { geom, src, .. } => (geom, src),
            _ => continue,
        };
        let state = tr.at(src.line);
        let v = tr.tip();
        geom_points(&geom, |p| {
            tip.push(0, p);
            centre.push(0, p - v);
            if state == CompMove::On {
                grow(&mut comp_box, p);
                grow(&mut comp_box, p - v);
            }
        });
        if state != CompMove::Off {
            let c = geom.end() - v;
            let r = tr.radius();
            let (p, q, _) = tr.plane.axes();
            let mut d = V3::zeros();
            d[p] = r;
            d[q] = r;
            grow(&mut comp_box, c - d);
            grow(&mut comp_box, c + d);
            grow(&mut comp_box, geom.end());
            outlines.push(
                0,
                ToolOutline {
                    centre: c,
                    radius: r,
                    plane: tr.plane,
                },
            );
        }
    }
    Some(CompPaths {
        contour: contour.finish(),
        centre: one_run(centre),
        tip: one_run(tip),
        outlines: one_run(outlines),
        comp_box,
        lathe: tr.lathe,
    })
}

/// The programmed path: every move's geometry sampled (lines: their ends;
/// arcs: chords of at most 2°), tagged rapid or feed.
pub(crate) fn programmed_path(
    machine: &Machine,
    dialect: Dialect,
    text: &str,
) -> Vec<(u8, Vec<V3>)> {
    let mut d = Decimator::new(MAX_SERIES_POINTS);
    for ev in Interpreter::new(StrSource::new(text), dialect, machine) {
        let Event::Move { geom, feed, .. } = ev else {
            continue;
        };
        let tag = if matches!(feed, Feed::Rapid) {
            RAPID
        } else {
            FEED
        };
        geom_points(&geom, |p| d.push(tag, p));
    }
    d.finish()
}
