//! The programmed path and, under radius compensation (G41/G42), the
//! programmed contour, the nose- or cutter-centre path and the tip's path,
//! from one run of the interpreter whose canonical commands are watched
//! on their way into the pipeline's compensation stage and out of it
//! ([`Watch`], the [`Watcher`] of the pipeline's front stages).

use super::decimate::{one_run, Decimator, MAX_SERIES_POINTS};
use cnc_core::canon::{CompMode, Event, Feed, Src};
use cnc_core::geom::{Geom, Plane};
use cnc_core::interp::Interpreter;
use cnc_core::machine::{tip_vector, MachineKind};
use cnc_core::pipeline::Watcher;
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine, V3};
use std::collections::HashMap;

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

fn tag(feed: Feed) -> u8 {
    if matches!(feed, Feed::Rapid) {
        RAPID
    } else {
        FEED
    }
}

/// Where a move stands with respect to radius compensation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum CompMove {
    Off,
    /// the block with G41/G42: from the uncompensated to the compensated
    /// position
    Entry(CompMode),
    On(CompMode),
}

/// Every command as programmed on its way into the compensation (the
/// contour, and each move's compensation state by its line), and the
/// compensation mode and tool offset handed on.
struct Watch {
    /// G41/G42 in force (as programmed), and the block that programmed it
    mode: Option<(CompMode, Src)>,
    /// the tool's geometry offset
    offset: V3,
    /// G41/G42 was programmed at all
    used: bool,
    /// the state of each line's moves (a line run again by a loop takes
    /// the state of its latest run)
    state: HashMap<u32, CompMove>,
    contour: Decimator<V3>,
    comp_box: Option<Box3>,
}

impl Watcher for Watch {
    fn command(&mut self, cmd: &Event) {
        let Event::Move { geom, feed, src } = *cmd else {
            return;
        };
        let state = match self.mode {
            None => CompMove::Off,
            Some((m, at)) if at == src => CompMove::Entry(m),
            Some((m, _)) => CompMove::On(m),
        };
        self.state.insert(src.line, state);
        let t = tag(feed);
        let off = self.offset;
        geom_points(&geom, |p| {
            let p = p - off;
            self.contour.push(t, p);
            if matches!(state, CompMove::On(_)) {
                grow(&mut self.comp_box, p);
            }
        });
    }
    fn compensation(&mut self, mode: Option<CompMode>, at: Src) {
        self.used |= mode.is_some();
        self.mode = mode.map(|m| (m, at));
    }
    fn tool_offset(&mut self, offset: V3) {
        self.offset = offset;
    }
}

/// The paths of a program for its figure.
pub(crate) struct ProgramPaths {
    /// every move as the planner gets it (commanded), tagged rapid or feed
    pub programmed: Vec<(u8, Vec<V3>)>,
    /// with G41/G42: the contour, the centre and tip paths, the outlines
    pub comp: Option<CompPaths>,
}

/// The paths of a program from one run of its interpreter. The program
/// should pass the check first.
pub(crate) fn program_paths(machine: &Machine, dialect: Dialect, text: &str) -> ProgramPaths {
    let lathe = machine.kind == MachineKind::Lathe;
    let watch = Watch {
        mode: None,
        offset: V3::zeros(),
        used: false,
        state: HashMap::new(),
        contour: Decimator::new(MAX_SERIES_POINTS),
        comp_box: None,
    };
    let mut interp = Interpreter::watched(StrSource::new(text), dialect, machine, watch);
    let mut programmed = Decimator::new(MAX_SERIES_POINTS);
    let mut tip = Decimator::new(MAX_SERIES_POINTS);
    let mut centre = Decimator::new(MAX_SERIES_POINTS);
    let mut outlines = Decimator::new(MAX_OUTLINES);
    let mut comp_box = None;
    // the tool selected, in the commanded stream: (R × its tip vector on a
    // lathe)
    let mut v = V3::zeros();
    while let Some(ev) = interp.next() {
        let (geom, feed, src) = match ev {
            Event::Tool { number, .. } => {
                let n = if lathe { number % 100 } else { number };
                v = match machine.tools.iter().find(|t| n != 0 && t.number == n) {
                    Some(t) if lathe => {
                        let (x, z) = tip_vector(t.tip);
                        V3::new(x, 0.0, z) * t.radius_mm
                    }
                    _ => V3::zeros(),
                };
                continue;
            }
            Event::Move { geom, feed, src } => (geom, feed, src),
            _ => continue,
        };
        let t = tag(feed);
        geom_points(&geom, |p| programmed.push(t, p));
        let state = interp
            .watcher()
            .state
            .get(&src.line)
            .copied()
            .unwrap_or(CompMove::Off);
        geom_points(&geom, |p| {
            tip.push(0, p);
            centre.push(0, p - v);
            if matches!(state, CompMove::On(_)) {
                grow(&mut comp_box, p);
                grow(&mut comp_box, p - v);
            }
        });
        if let CompMove::Entry(m) | CompMove::On(m) = state {
            let c = geom.end() - v;
            let r = m.radius;
            let (p, q, _) = m.plane.axes();
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
                    plane: m.plane,
                },
            );
        }
    }
    let watch = interp.watcher();
    let comp = watch.used.then(|| {
        if let Some((lo, hi)) = watch.comp_box {
            grow(&mut comp_box, lo);
            grow(&mut comp_box, hi);
        }
        CompPaths {
            contour: watch.contour.clone().finish(),
            centre: one_run(centre),
            tip: one_run(tip),
            outlines: one_run(outlines),
            comp_box,
            lathe,
        }
    });
    ProgramPaths {
        programmed: programmed.finish(),
        comp,
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
    /// the programmed contour: the interpreter's moves as programmed
    /// (before compensation, moved by the tool's geometry offset into the
    /// setpoints' frame), as runs tagged rapid (1) or feed (0)
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
/// commanded (tip) path of a program that uses G41/G42 (`None` if it
/// programs neither). The program should pass the check first.
pub fn comp_paths(machine: &Machine, dialect: Dialect, text: &str) -> Option<CompPaths> {
    program_paths(machine, dialect, text).comp
}
