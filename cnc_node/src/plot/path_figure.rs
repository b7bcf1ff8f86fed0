//! The path figures of a program and of a recording: the programmed path
//! (or contour), the setpoints and the simulated actual path, with G41/G42
//! the compensated paths, the tool outlines and a zoomed panel.

use super::decimate::{one_run, Decimator, MAX_SERIES_POINTS};
use super::figure::{Dash, Figure, Format, Panel, Point, Rgb, Series};
use super::program_paths::{grow, program_paths, ToolOutline, FEED, RAPID};
use super::render::render;
use super::run::{ProgramRun, Run};
use super::scale::pad;
use crate::bag::{Bag, Extent};
use crate::record::{from_cdr, topics};
use cnc_core::machine::{axis_index, MachineKind};
use cnc_core::{Dialect, Machine, V3};
use std::path::Path;

/// How machine positions are shown: the axes (0 = X, 1 = Y, 2 = Z) of
/// the panels, horizontal then vertical, with their labels.
struct View {
    panels: Vec<(usize, usize, &'static str, &'static str, f64)>,
}

fn view(machine: &Machine, z_moves: bool) -> View {
    match machine.kind {
        MachineKind::Lathe => View {
            panels: vec![(2, 0, "Z mm", "X (radius) mm", 1.0)],
        },
        _ => {
            let mut panels = vec![(0, 1, "X mm", "Y mm", 3.0)];
            if z_moves {
                panels.push((0, 2, "X mm", "Z mm", 1.0));
            }
            View { panels }
        }
    }
}

/// Legend labels of the CNC plots.
pub mod labels {
    pub const PROGRAMMED: &str = "programmed path";
    pub const RAPID: &str = "programmed rapid";
    pub const SETPOINTS: &str = "setpoints";
    pub const ACTUAL: &str = "simulated actual";
    /// with G41/G42: the programmed path is the contour (tool radius 0)
    pub const CONTOUR: &str = "programmed contour";
    pub const NOSE_CENTRE: &str = "nose-centre path";
    pub const TIP: &str = "imaginary tip path (commanded)";
    pub const NOSE: &str = "nose circle at block ends";
    pub const CUTTER_CENTRE: &str = "cutter-centre path (commanded)";
    pub const CUTTER: &str = "cutter at block ends";
}

/// Colours of the compensation series.
const CENTRE_COLOR: Rgb = Rgb::GREEN;
const TIP_COLOR: Rgb = Rgb::ORANGE;
const OUTLINE_COLOR: Rgb = Rgb(120, 190, 120);

/// Points of a circle about `o.centre` in its plane, projected on axes
/// `h`, `v`; `None` when the panel does not show that plane.
fn outline_points(o: &ToolOutline, h: usize, v: usize) -> Option<Vec<Point>> {
    let (p, q, _) = o.plane.axes();
    if !((h, v) == (p, q) || (h, v) == (q, p)) {
        return None;
    }
    Some(
        (0..=72)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 72.0;
                let mut x = o.centre;
                x[p] += o.radius * t.cos();
                x[q] += o.radius * t.sin();
                (x[h], x[v])
            })
            .collect(),
    )
}

/// The compensated part's box must be smaller than this share of the
/// whole view's area for a zoomed panel.
const ZOOM_AREA_SHARE: f64 = 0.3;
/// The zoomed panel's size relative to the other panels together.
const ZOOM_WEIGHT: f64 = 2.0;

fn path_figure(
    title: String,
    machine: &Machine,
    dialect: Dialect,
    text: &str,
    run: &Run,
) -> Figure {
    let paths = program_paths(machine, dialect, text);
    let comp = paths.comp;
    let programmed = match &comp {
        Some(c) => c.contour.clone(),
        None => paths.programmed,
    };
    let mut bbox = None;
    for p in programmed
        .iter()
        .flat_map(|(_, v)| v)
        .chain(&run.setpoints)
        .chain(&run.actual)
        .chain(comp.iter().flat_map(|c| c.centre.iter().chain(&c.tip)))
    {
        grow(&mut bbox, *p);
    }
    let z_moves = bbox.is_some_and(|(lo, hi)| hi[2] - lo[2] > 1e-6);
    let v = view(machine, z_moves);
    let series = |h: usize, vert: usize| {
        let proj = |pts: &[V3]| pts.iter().map(|p| (p[h], p[vert])).collect::<Vec<Point>>();
        let runs = |tag: u8| {
            programmed
                .iter()
                .filter(move |(t, _)| *t == tag)
                .map(|(_, v)| v.as_slice())
        };
        let label = if comp.is_some() {
            labels::CONTOUR
        } else {
            labels::PROGRAMMED
        };
        let mut s = vec![
            Series::new(label, Rgb::GREY, 6, Dash::Solid).with(runs(FEED).map(proj)),
            Series::new(labels::SETPOINTS, Rgb::BLUE, 3, Dash::Solid).with([proj(&run.setpoints)]),
            Series::new(labels::ACTUAL, Rgb::RED, 1, Dash::Solid).with([proj(&run.actual)]),
        ];
        if let Some(c) = &comp {
            let (centre, outline) = if c.lathe {
                (labels::NOSE_CENTRE, labels::NOSE)
            } else {
                (labels::CUTTER_CENTRE, labels::CUTTER)
            };
            s.push(
                Series::new(outline, OUTLINE_COLOR, 1, Dash::Solid)
                    .with(c.outlines.iter().filter_map(|o| outline_points(o, h, vert))),
            );
            // the commanded path on top of the setpoints that follow it
            s.push(Series::new(centre, CENTRE_COLOR, 2, Dash::Solid).with([proj(&c.centre)]));
            if c.lathe {
                s.push(Series::new(labels::TIP, TIP_COLOR, 2, Dash::Solid).with([proj(&c.tip)]));
            }
        }
        // on top: where the setpoints hide it the dashes still show
        s.push(
            Series::new(labels::RAPID, Rgb::DARK_GREY, 1, Dash::Dashed).with(runs(RAPID).map(proj)),
        );
        s
    };
    let mut panels = Vec::new();
    for (k, &(h, vert, xl, yl, weight)) in v.panels.iter().enumerate() {
        let mut p = Panel::new(xl, yl);
        p.equal_aspect = true;
        p.weight = weight;
        if v.panels.len() > 1 {
            p.caption = if k == 0 {
                "top view (XY)"
            } else {
                "side view (XZ)"
            }
            .to_string();
        }
        p.series = series(h, vert);
        panels.push(p);
    }
    // the compensated part zoomed, in the first panel's axes, when it is
    // small in the whole view
    if let (Some((lo, hi)), Some((blo, bhi)), Some(&(h, vert, xl, yl, _))) = (
        comp.as_ref().and_then(|c| c.comp_box),
        bbox,
        v.panels.first(),
    ) {
        let area = |lo: V3, hi: V3| (hi[h] - lo[h]).max(1e-9) * (hi[vert] - lo[vert]).max(1e-9);
        if area(lo, hi) < ZOOM_AREA_SHARE * area(blo, bhi) {
            let mut p = Panel::new(xl, yl);
            p.equal_aspect = true;
            p.weight = ZOOM_WEIGHT * panels.iter().map(|p| p.weight).sum::<f64>();
            p.caption = "compensated part (G41/G42), zoomed".to_string();
            p.x_range = Some(pad(lo[h], hi[h]));
            p.y_range = Some(pad(lo[vert], hi[vert]));
            p.series = series(h, vert);
            if let Some(first) = panels.first_mut() {
                if first.caption.is_empty() {
                    first.caption = "whole program".to_string();
                }
            }
            panels.push(p);
        }
    }
    // one view and its zoom: side by side (a lathe's whole program is
    // tall and narrow, the compensated part wide)
    let columns = panels.len() == 2 && v.panels.len() == 1;
    let (width, height) = match panels.len() {
        _ if columns => (1500, 860),
        1 => (1200, 760),
        2 => (1200, 1000),
        _ => (1200, 1300),
    };
    Figure {
        title,
        width,
        height,
        columns,
        panels,
    }
}

/// The figure [`plot_program`] draws (the offline run included), for a
/// program that passed the check.
pub fn program_figure(
    machine: &Machine,
    dialect: Dialect,
    program_name: &str,
    text: &str,
) -> Result<Figure, String> {
    run_figure(&ProgramRun::new(
        machine,
        dialect,
        program_name,
        text,
        true,
        false,
    )?)
}

/// The figure [`plot_program`] draws, of a run that collected the paths.
pub fn run_figure(run: &ProgramRun) -> Result<Figure, String> {
    let Some(paths) = &run.paths else {
        return Err(format!(
            "{}: the run did not collect the paths",
            run.program_name
        ));
    };
    let (machine, dialect) = (run.machine, run.dialect);
    let title = format!(
        "{} on {} ({}, {})",
        run.program_name,
        machine.name,
        kind_name(machine),
        dialect.id()
    );
    Ok(path_figure(title, machine, dialect, run.text, paths))
}

/// Plots a program: the programmed path, the setpoints and the simulated
/// actual path of an offline run (as `cnc simulate`), mill in the XY plane
/// (plus an XZ panel when Z moves), lathe with Z across and the X radius
/// up. A program with G41/G42 shows the programmed contour (the
/// interpreter on the machine with tool radius and type 0), the nose- or
/// cutter-centre path, on a lathe the imaginary tip's path (what is
/// commanded), the tool's outline at the ends of the compensated blocks,
/// and the compensated part zoomed when it is small in the whole view.
/// The program must pass the check; otherwise nothing is written and the
/// errors are returned. `out`'s extension picks SVG or PNG.
pub fn plot_program(
    machine: &Machine,
    dialect: Dialect,
    program_name: &str,
    text: &str,
    out: &Path,
) -> Result<(), String> {
    Format::from_path(out)?;
    let fig = program_figure(machine, dialect, program_name, text)?;
    render(&fig, out)
}

fn kind_name(machine: &Machine) -> &'static str {
    match machine.kind {
        MachineKind::Lathe => "lathe",
        _ => "mill",
    }
}

fn joint_positions(msg: &cnc_msgs::JointState) -> V3 {
    let mut p = V3::zeros();
    for (name, v) in msg.name.iter().zip(&msg.position) {
        if let Some(i) = axis_index(name) {
            p[i] = v * 1000.0;
        }
    }
    p
}

/// Plots a recording (`cnc simulate --record` or the node): the programmed
/// path from its attachments (`program.nc`, `machine.toml`, the dialect of
/// the `cnc` metadata), the setpoints (`/cnc/joint_setpoints`) and the
/// actual positions (`/sim/joint_states`), as [`plot_program`] draws them.
///
/// A recording cut short is plotted as far as its whole chunks go. The
/// positions are thinned as they are read: a long recording's messages
/// never sit in memory all at once.
pub fn plot_recording(recording: &Path, out: &Path) -> Result<(), String> {
    Format::from_path(out)?;
    let mut setpoints = Decimator::new(MAX_SERIES_POINTS);
    let mut actual = Decimator::new(MAX_SERIES_POINTS);
    let bag = Bag::scan(recording, Extent::AsFarAsItGoes, |m| match m.topic {
        topics::JOINT_SETPOINTS | topics::JOINT_STATES => {
            let js: cnc_msgs::JointState =
                from_cdr(m.data).map_err(|e| format!("{}: {e}", m.topic))?;
            let p = joint_positions(&js);
            if m.topic == topics::JOINT_SETPOINTS {
                setpoints.push(0, p);
            } else {
                actual.push(0, p);
            }
            Ok(false)
        }
        // the job as latched messages, for a recording without attachments
        topics::PROGRAM | topics::MACHINE_FILE => Ok(true),
        _ => Ok(false),
    })?;
    let err = |e: String| format!("{}: {e}", recording.display());
    let machine_text = bag
        .job_text("machine.toml", topics::MACHINE_FILE)
        .map_err(err)?
        .ok_or_else(|| err("no machine file (attachment machine.toml)".into()))?;
    let machine =
        Machine::from_toml(&machine_text).map_err(|e| err(format!("machine.toml: {}", e.0)))?;
    let program = bag
        .job_text("program.nc", topics::PROGRAM)
        .map_err(err)?
        .ok_or_else(|| err("no program (attachment program.nc)".into()))?;
    let cnc = bag.metadata.get("cnc");
    let dialect = match cnc.and_then(|m| m.get("dialect")).map(String::as_str) {
        Some(d) if !d.is_empty() => d
            .parse::<Dialect>()
            .map_err(|e| err(format!("metadata cnc: {e}")))?,
        _ => machine.dialect,
    };
    let run = Run {
        setpoints: one_run(setpoints),
        actual: one_run(actual),
    };
    if run.setpoints.is_empty() && run.actual.is_empty() {
        return Err(err(format!(
            "no positions on {} or {}",
            topics::JOINT_SETPOINTS,
            topics::JOINT_STATES
        )));
    }
    let file = recording
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = cnc
        .and_then(|m| m.get("program_name"))
        .filter(|n| !n.is_empty())
        .map_or("program", String::as_str);
    let title = format!(
        "{name} on {} ({}, {}), recording {file}",
        machine.name,
        kind_name(&machine),
        dialect.id()
    );
    render(&path_figure(title, &machine, dialect, &program, &run), out)
}
