//! Plots of programs and recordings (`cnc plot`), as SVG or PNG.
//!
//! Two layers:
//! - A small reusable one: a [`Figure`] is a title, a legend row and
//!   [`Panel`]s stacked vertically; a panel holds [`Series`] of 2D
//!   polylines (label, colour, width, solid or dashed), axes with ticks and
//!   labels, optionally with an equal aspect ratio (1 mm is as long on both
//!   axes), shaded x spans ([`Band`]) and a fixed y range (lines are cut at
//!   its edges). [`render`] writes it by the output's extension ([`Format`]).
//!   [`Decimator`] thins a stream of points to a bounded number, so that a
//!   long run does not grow memory or the file.
//! - The CNC plots on top: [`plot_program`] (the programmed path from the
//!   interpreter's moves, the setpoints and the simulated actual positions
//!   of an offline run; with G41/G42 the programmed contour, the nose- or
//!   cutter-centre path and the imaginary tip's path, [`comp_paths`]),
//!   [`plot_recording`] (the same from an MCAP
//!   recording, read with [`crate::bag::Bag`]) and [`plot_thread_error`]
//!   (a G33 pass's lead error against the spindle angle, from
//!   [`thread_error_series`]; of a recording, [`plot_recording_thread`]
//!   against its recorded encoder, measured by
//!   [`crate::bag::measure_recording`]). A program is checked once and run once
//!   ([`ProgramRun`]) for both its figures.
//!
//! The files: `figure` (the model), `render`, `legend`, `scale` and
//! `style` (drawing: plotters' backends, the legend, ranges, ticks and
//! clipping, font and sizes), `decimate`, `program_paths` (the programmed
//! path and the compensated paths from one run of the interpreter, its
//! canonical commands watched on their way into compensation) and
//! `thread_errors` (analysis), `run` (the offline run behind a program's
//! figures), `path_figure` and `thread_figure` (the CNC figures).
//!
//! Text is drawn with DejaVu Sans embedded in the binary (plotters'
//! `ab_glyph` feature), so PNG output needs no system fonts; SVG output
//! names the family `sans-serif`.
mod decimate;
mod figure;
mod legend;
mod path_figure;
mod program_paths;
mod render;
mod run;
mod scale;
mod style;
mod thread_errors;
mod thread_figure;

pub use decimate::{Decimator, MAX_SERIES_POINTS};
pub use figure::{Band, Dash, Figure, Format, Panel, Point, Rgb, Series};
pub use path_figure::{labels, plot_program, plot_recording, program_figure, run_figure};
pub use program_paths::{comp_paths, CompPaths, ToolOutline, MAX_OUTLINES};
pub use render::{render, render_png, render_svg};
pub use run::ProgramRun;
pub use thread_errors::{
    phase_deg, signed_deg4, wrap_deg, PhaseStats, ThreadErrorPoint, ThreadErrorSeries,
    ThreadErrors, ThreadPass,
};
pub(crate) use thread_errors::{PassBuilder, AT_START_MM};
pub use thread_figure::{
    plot_recording_thread, plot_run_thread, plot_thread_error, thread_error_series, thread_labels,
    thread_summary,
};
