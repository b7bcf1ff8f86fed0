//! The thread error figure: the lead error of one G33 pass against the
//! spindle angle, the whole pass and the synchronized part zoomed.

use super::figure::{Band, Dash, Figure, Format, Panel, Rgb, Series};
use super::render::render;
use super::run::ProgramRun;
use super::scale::tick;
use super::thread_errors::{signed_deg4, PhaseStats, ThreadErrorSeries, ThreadPass};
use crate::bag::{measure_recording, RecordingThreads};
use cnc_core::{Dialect, Machine};
use std::path::Path;

/// Runs a program offline against the simulated machine (as
/// `cnc simulate`: the spindle model and its encoder drive G33) and
/// returns the lead error of each G33 pass against the spindle angle (see
/// [`ThreadErrors`](super::ThreadErrors)). The program must pass the
/// check; the machine must have a spindle.
pub fn thread_error_series(
    machine: &Machine,
    dialect: Dialect,
    text: &str,
) -> Result<ThreadErrorSeries, String> {
    ProgramRun::new(machine, dialect, "program", text, false, true)?.into_thread_errors()
}

/// Legend labels of the thread error plot.
pub mod thread_labels {
    pub const SETPOINT: &str = "setpoint error";
    pub const ACTUAL: &str = "simulated actual error";
    pub const COUNT: &str = "±1 encoder count";
    pub const SYNC: &str = "synchronized part";
}

const SYNC_BAND: Rgb = Rgb(222, 240, 222);
/// The zoomed panel shows at least this many counts either side of 0.
const ZOOM_COUNTS: f64 = 3.0;

fn axis_name(i: usize) -> &'static str {
    ["X", "Y", "Z"].get(i).copied().unwrap_or("?")
}

/// The figure of one pass: the whole pass (run-in, synchronized part,
/// deceleration) above, the same zoomed to a few encoder counts below.
fn thread_figure(title: String, series: &ThreadErrorSeries, pass: &ThreadPass) -> Figure {
    let pts = &pass.points;
    let (x0, x1) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.deg), b.max(p.deg))
        });
    let c = pass.count_um;
    let lead = axis_name(pass.lead);
    let make = |caption: String| {
        let mut p = Panel::new(
            "spindle angle from θ₀ (the thread's sync angle), degrees",
            &format!("{lead} lead error, µm"),
        );
        p.caption = caption;
        p.bands = pass
            .sync_deg
            .iter()
            .map(|&x| Band {
                label: thread_labels::SYNC.into(),
                color: SYNC_BAND,
                x,
            })
            .collect();
        p.series = vec![
            Series::new(thread_labels::COUNT, Rgb::DARK_GREY, 1, Dash::Dashed)
                .with([vec![(x0, c), (x1, c)], vec![(x0, -c), (x1, -c)]]),
            Series::new(thread_labels::SETPOINT, Rgb::BLUE, 2, Dash::Solid)
                .with([pts.iter().map(|p| (p.deg, p.set_um)).collect()]),
            Series::new(thread_labels::ACTUAL, Rgb::RED, 1, Dash::Solid)
                .with([pts.iter().map(|p| (p.deg, p.act_um)).collect()]),
        ];
        p
    };
    let block = pass.block_no.map(|n| format!("N{n}, ")).unwrap_or_default();
    let whole = make(format!(
        "whole pass ({block}line {}): run-in, synchronized part, deceleration",
        pass.line
    ));
    let half = (ZOOM_COUNTS * c).max(1.2 * pass.max_set_um);
    let mut zoom = make(format!(
        "synchronized part, zoomed: 1 count = {} µm (F{} / {} counts/rev); setpoint within {:.3} counts, actual {}",
        tick(c),
        tick(pass.pitch),
        series.counts_per_rev,
        pass.max_set_counts,
        match pass.act_within_count_from_deg {
            Some(d) => format!("within 1 count from {d:.0}°"),
            None => format!("up to {:.2} counts", pass.max_act_counts),
        }
    ));
    zoom.y_range = Some((-half, half));
    Figure {
        title,
        width: 1200,
        height: 900,
        columns: false,
        panels: vec![whole, zoom],
    }
}

/// Plots the lead error of one G33 pass (1 = the first) of an offline run
/// against the spindle angle: setpoint and simulated actual, the
/// synchronized part shaded, ±1 encoder count dashed; a panel over the
/// whole pass and one zoomed to a few counts. The program must pass the
/// check and have a G33 pass; otherwise nothing is written. Returns the
/// series of every pass.
pub fn plot_thread_error(
    machine: &Machine,
    dialect: Dialect,
    program_name: &str,
    text: &str,
    pass: usize,
    out: &Path,
) -> Result<ThreadErrorSeries, String> {
    Format::from_path(out)?;
    let run = ProgramRun::new(machine, dialect, program_name, text, false, true)?;
    plot_run_thread(&run, pass, out).cloned()
}

/// [`plot_thread_error`] of a run that collected the thread errors.
pub fn plot_run_thread<'r>(
    run: &'r ProgramRun,
    pass: usize,
    out: &Path,
) -> Result<&'r ThreadErrorSeries, String> {
    let series = run.thread_errors()?;
    plot_series(run.program_name, &run.machine.name, "", series, pass, out)?;
    Ok(series)
}

/// Plots pass `pass` of `series` (as [`plot_thread_error`]); `source`
/// ends the title (what was measured).
fn plot_series(
    program_name: &str,
    machine_name: &str,
    source: &str,
    series: &ThreadErrorSeries,
    pass: usize,
    out: &Path,
) -> Result<(), String> {
    let n = series.passes.len();
    if n == 0 {
        return Err(format!(
            "{program_name}: no G33 thread was cut{}, nothing plotted",
            series
                .fault
                .as_ref()
                .map(|f| format!(" (the run stopped: {f})"))
                .unwrap_or_default()
        ));
    }
    let Some(p) = pass.checked_sub(1).and_then(|i| series.passes.get(i)) else {
        return Err(format!(
            "{program_name}: thread pass {pass} asked for, the program cuts {n} (1 to {n})"
        ));
    };
    let title = format!(
        "{program_name} on {machine_name}: G33 {} lead error, pass {pass} of {n}{source}",
        axis_name(p.lead)
    );
    render(&thread_figure(title, series, p), out)
}

/// Plots the lead error of one G33 pass (1 = the first) of a recording
/// against its recorded spindle encoder (see [`crate::bag::measure_recording`]
/// for how it is measured): the figure of [`plot_thread_error`]. A
/// recording without G33, without encoder messages or without the pass
/// is an error, and nothing is written. Returns the measurement of every
/// pass.
pub fn plot_recording_thread(
    recording: &Path,
    pass: usize,
    out: &Path,
) -> Result<RecordingThreads, String> {
    Format::from_path(out)?;
    let r = measure_recording(recording)?;
    let file = recording
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    plot_series(
        &r.program_name,
        &r.machine_name,
        &format!(", recording {file} against its encoder"),
        &r.series,
        pass,
        out,
    )?;
    Ok(r)
}

/// The numbers of every pass, one line each and one for its groove's
/// phase (what `cnc plot --thread` prints, for a program and for a
/// recording alike).
pub fn thread_summary(series: &ThreadErrorSeries) -> String {
    let mut s = String::new();
    let phase = |g: &PhaseStats| {
        if g.n == 0 {
            "none".to_string()
        } else {
            format!(
                "mean {:+.4}°, worst {:.4}°, spread {:.4}° ({} samples)",
                signed_deg4(g.mean_deg),
                g.worst_deg,
                g.spread_deg,
                g.n
            )
        }
    };
    for (i, p) in series.passes.iter().enumerate() {
        let block = p.block_no.map(|n| format!("N{n}, ")).unwrap_or_default();
        let span = match (p.sync_deg.first(), p.sync_deg.last()) {
            (Some(a), Some(b)) => format!("{:.1}..{:.1}°", a.0, b.1),
            _ => "none".into(),
        };
        let settled = p
            .act_within_count_from_deg
            .map(|d| format!(", within 1 count from {d:.0}°"))
            .unwrap_or_default();
        s.push_str(&format!(
            "  pass {} ({block}line {}): F{} synchronized {span} ({} samples); largest error there: setpoint {:.4} µm ({:.3} counts), actual {:.3} µm ({:.2} counts){settled}; 1 count = {:.4} µm\n",
            i + 1,
            p.line,
            p.pitch,
            p.on_line_samples,
            p.max_set_um,
            p.max_set_counts,
            p.max_act_um,
            p.max_act_counts,
            p.count_um
        ));
        s.push_str(&format!(
            "    groove phase there (0 = the programmed start angle): setpoint {}; actual {}\n",
            phase(&p.groove_set),
            phase(&p.groove_act)
        ));
    }
    s
}
