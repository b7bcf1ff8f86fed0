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
//!   recording) and [`plot_thread_error`] (a G33 pass's lead error against
//!   the spindle angle, from [`thread_error_series`]).
//!
//! Text is drawn with DejaVu Sans embedded in the binary (plotters'
//! `ab_glyph` feature), so PNG output needs no system fonts; SVG output
//! names the family `sans-serif`.

use crate::offline::{simulate, Step};
use crate::record::{self, topics};
use cnc_core::canon::{Event, Feed};
use cnc_core::exec::Sample;
use cnc_core::geom::{Geom, Plane};
use cnc_core::interp::Interpreter;
use cnc_core::machine::{axis_index, tip_vector, MachineKind, ToolConfig};
use cnc_core::parse::{parse_line, Block};
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

/// A point of a 2D plot, in data units (mm for paths).
pub type Point = (f64, f64);

/// Most points of one series of [`plot_program`] and [`plot_recording`].
pub const MAX_SERIES_POINTS: usize = 20_000;

/// An RGB colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    pub const BLACK: Rgb = Rgb(0, 0, 0);
    pub const GREY: Rgb = Rgb(160, 160, 160);
    pub const DARK_GREY: Rgb = Rgb(60, 60, 60);
    pub const BLUE: Rgb = Rgb(31, 119, 180);
    pub const RED: Rgb = Rgb(214, 39, 40);
    pub const GREEN: Rgb = Rgb(44, 160, 44);
    pub const ORANGE: Rgb = Rgb(255, 127, 14);

    fn color(self) -> RGBColor {
        RGBColor(self.0, self.1, self.2)
    }
}

/// How a series' lines are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    Solid,
    Dashed,
}

/// One labelled series: any number of polylines drawn alike.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// the legend entry; empty: none
    pub label: String,
    pub color: Rgb,
    /// line width, pixels
    pub width: u32,
    pub dash: Dash,
    pub polylines: Vec<Vec<Point>>,
}

impl Series {
    pub fn new(label: &str, color: Rgb, width: u32, dash: Dash) -> Series {
        Series {
            label: label.to_string(),
            color,
            width,
            dash,
            polylines: Vec::new(),
        }
    }

    /// Adds polylines (those with fewer than 1 point are dropped).
    pub fn with(mut self, polylines: impl IntoIterator<Item = Vec<Point>>) -> Series {
        self.polylines
            .extend(polylines.into_iter().filter(|p| !p.is_empty()));
        self
    }

    /// Points over all polylines.
    pub fn points(&self) -> usize {
        self.polylines.iter().map(Vec::len).sum()
    }
}

/// One chart: axes, ticks and series.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// drawn above the chart; empty: none
    pub caption: String,
    pub x_label: String,
    pub y_label: String,
    /// one data unit is as long on the x axis as on the y axis
    pub equal_aspect: bool,
    /// height (in a figure of columns: width) relative to the other
    /// panels of the figure
    pub weight: f64,
    /// the x axis's range as given (no padding; widened for an equal
    /// aspect); `None`: from the data
    pub x_range: Option<(f64, f64)>,
    /// the y axis's range as given (no padding; widened for an equal
    /// aspect); `None`: from the data
    pub y_range: Option<(f64, f64)>,
    /// shaded spans of x, drawn under the grid and the series
    pub bands: Vec<Band>,
    pub series: Vec<Series>,
}

/// A shaded span of x over the panel's whole height (in the legend when
/// labelled).
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// the legend entry; empty: none
    pub label: String,
    pub color: Rgb,
    /// from, to (data units)
    pub x: (f64, f64),
}

impl Panel {
    pub fn new(x_label: &str, y_label: &str) -> Panel {
        Panel {
            caption: String::new(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            equal_aspect: false,
            weight: 1.0,
            x_range: None,
            y_range: None,
            bands: Vec::new(),
            series: Vec::new(),
        }
    }

    /// The bounding box of all points, `((x0, x1), (y0, y1))`.
    pub fn bounds(&self) -> Option<(Point, Point)> {
        let mut it = self
            .series
            .iter()
            .flat_map(|s| s.polylines.iter().flatten())
            .filter(|p| p.0.is_finite() && p.1.is_finite());
        let first = it.next()?;
        let mut b = ((first.0, first.0), (first.1, first.1));
        for p in it {
            b.0 .0 = b.0 .0.min(p.0);
            b.0 .1 = b.0 .1.max(p.0);
            b.1 .0 = b.1 .0.min(p.1);
            b.1 .1 = b.1 .1.max(p.1);
        }
        Some(b)
    }
}

/// A titled figure: a legend (every distinct label of its panels, in as
/// many rows as it needs) and the panels stacked top to bottom, or side
/// by side.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    pub title: String,
    /// pixels (SVG: user units)
    pub width: u32,
    pub height: u32,
    /// the panels left to right (widths by weight) instead of top to
    /// bottom (heights by weight)
    pub columns: bool,
    pub panels: Vec<Panel>,
}

/// Output formats, by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
}

impl Format {
    /// The format for `path`'s extension (case-insensitive), or an error
    /// naming the allowed ones.
    pub fn from_path(path: &Path) -> Result<Format, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("svg") => Ok(Format::Svg),
            Some("png") => Ok(Format::Png),
            _ => Err(format!(
                "{}: unknown plot format (the output's extension must be .svg or .png)",
                path.display()
            )),
        }
    }
}

const FONT: &str = "sans-serif";

/// Registers the embedded font once (plotters' `ab_glyph` backend has no
/// system fonts).
fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // the bundled fonts are valid; a failure would only lose text
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Writes `fig` to `out` in the format of its extension.
pub fn render(fig: &Figure, out: &Path) -> Result<(), String> {
    let format = Format::from_path(out)?;
    let err = |e: String| format!("{}: {e}", out.display());
    match format {
        Format::Svg => {
            let svg = render_svg(fig)?;
            std::fs::write(out, svg).map_err(|e| err(e.to_string()))
        }
        Format::Png => {
            let png = render_png(fig)?;
            std::fs::write(out, png).map_err(|e| err(e.to_string()))
        }
    }
}

/// The figure as SVG text.
pub fn render_svg(fig: &Figure) -> Result<String, String> {
    fonts();
    let (w, h) = size(fig)?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
        draw_figure(fig, &root, false)?;
        root.present().map_err(|e| format!("drawing: {e}"))?;
    }
    Ok(text)
}

/// The figure as a PNG file's bytes (8-bit RGB).
pub fn render_png(fig: &Figure) -> Result<Vec<u8>, String> {
    fonts();
    let (w, h) = size(fig)?;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        draw_figure(fig, &root, true)?;
        root.present().map_err(|e| format!("drawing: {e}"))?;
    }
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc
            .write_header()
            .map_err(|e| format!("PNG encoding: {e}"))?;
        wr.write_image_data(&rgb)
            .map_err(|e| format!("PNG encoding: {e}"))?;
    }
    Ok(out)
}

fn size(fig: &Figure) -> Result<(u32, u32), String> {
    if !(200..=10_000).contains(&fig.width) || !(200..=10_000).contains(&fig.height) {
        return Err(format!(
            "figure size {}x{}: each side must be 200 to 10000 pixels",
            fig.width, fig.height
        ));
    }
    if fig.panels.is_empty() {
        return Err("figure without panels".to_string());
    }
    Ok((fig.width, fig.height))
}

const TITLE_PX: u32 = 22;
const TEXT_PX: u32 = 14;
const LEGEND_ROW_PX: u32 = 26;
const MARGIN_PX: u32 = 12;
const X_LABEL_AREA_PX: u32 = 44;
const Y_LABEL_AREA_PX: u32 = 70;
/// Least distance between drawn points of a polyline (Chebyshev), pixels.
const MIN_STEP_PX: i32 = 3;

/// `bitmap`: thick lines are drawn segment by segment (see [`draw_panel`]).
fn draw_figure<DB: DrawingBackend>(
    fig: &Figure,
    root: &DrawingArea<DB, Shift>,
    bitmap: bool,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing: {e}");
    root.fill(&WHITE).map_err(e)?;
    let (w, _) = root.dim_in_pixel();
    let (title_area, rest) = root.split_vertically(TITLE_PX + 16);
    title_area
        .draw(&Text::new(
            fig.title.clone(),
            (w as i32 / 2, 8),
            (FONT, TITLE_PX as f64)
                .into_font()
                .style(FontStyle::Bold)
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(e)?;
    let legend = legend_layout(fig, root)?;
    let rows = legend.iter().map(|l| l.row + 1).max().unwrap_or(1);
    let (legend_area, rest) = rest.split_vertically(LEGEND_ROW_PX * rows);
    draw_legend(&legend, &legend_area)?;
    let total: f64 = fig.panels.iter().map(|p| p.weight.max(0.01)).sum();
    let (w, h) = rest.dim_in_pixel();
    let side = if fig.columns { w } else { h };
    let mut at = 0.0;
    let mut breaks = Vec::new();
    for p in &fig.panels[..fig.panels.len() - 1] {
        at += p.weight.max(0.01) / total * side as f64;
        breaks.push(at.round() as i32);
    }
    let areas = if fig.columns {
        rest.split_by_breakpoints::<i32, i32, _, _>(breaks, Vec::<i32>::new())
    } else {
        rest.split_by_breakpoints::<i32, i32, _, _>(Vec::<i32>::new(), breaks)
    };
    for (panel, area) in fig.panels.iter().zip(&areas) {
        draw_panel(panel, area, bitmap)?;
    }
    Ok(())
}

/// A legend entry: a series' line or a band's swatch.
enum Entry<'a> {
    Line(&'a Series),
    Band(&'a Band),
}

/// Every distinct (label, colour, dash) of the figure's series, in order,
/// then every distinct (label, colour) of its bands.
fn legend_entries(fig: &Figure) -> Vec<Entry<'_>> {
    let mut out: Vec<&Series> = Vec::new();
    for s in fig.panels.iter().flat_map(|p| &p.series) {
        if !s.label.is_empty()
            && !out
                .iter()
                .any(|o| o.label == s.label && o.color == s.color && o.dash == s.dash)
        {
            out.push(s);
        }
    }
    let mut bands: Vec<&Band> = Vec::new();
    for b in fig.panels.iter().flat_map(|p| &p.bands) {
        if !b.label.is_empty()
            && !bands
                .iter()
                .any(|o| o.label == b.label && o.color == b.color)
        {
            bands.push(b);
        }
    }
    out.into_iter()
        .map(Entry::Line)
        .chain(bands.into_iter().map(Entry::Band))
        .collect()
}

/// A legend entry placed: its row and the x of its swatch.
struct Placed<'a> {
    entry: Entry<'a>,
    row: u32,
    x: i32,
}

fn entry_label<'a>(e: &Entry<'a>) -> &'a str {
    match e {
        Entry::Line(s) => &s.label,
        Entry::Band(b) => &b.label,
    }
}

fn legend_font() -> TextStyle<'static> {
    (FONT, TEXT_PX as f64)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center))
}

/// The legend's entries in rows that fit the figure's width.
fn legend_layout<'a, DB: DrawingBackend>(
    fig: &'a Figure,
    area: &DrawingArea<DB, Shift>,
) -> Result<Vec<Placed<'a>>, String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing: {e}");
    let font = legend_font();
    let left = Y_LABEL_AREA_PX as i32 + MARGIN_PX as i32;
    let right = fig.width as i32 - MARGIN_PX as i32;
    let (mut x, mut row) = (left, 0);
    let mut out = Vec::new();
    for entry in legend_entries(fig) {
        let (tw, _) = area
            .estimate_text_size(entry_label(&entry), &font)
            .map_err(e)?;
        let w = 36 + tw as i32;
        if x > left && x + w > right {
            row += 1;
            x = left;
        }
        out.push(Placed { entry, row, x });
        x += w + 24;
    }
    Ok(out)
}

fn draw_legend<DB: DrawingBackend>(
    legend: &[Placed<'_>],
    area: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing: {e}");
    let font = legend_font();
    for p in legend {
        let x = p.x;
        let y = (LEGEND_ROW_PX * p.row + LEGEND_ROW_PX / 2) as i32;
        match p.entry {
            Entry::Line(s) => {
                let style = s.color.color().stroke_width(s.width.max(1));
                match s.dash {
                    Dash::Solid => area
                        .draw(&PathElement::new(vec![(x, y), (x + 30, y)], style))
                        .map_err(e)?,
                    Dash::Dashed => {
                        for k in 0..3 {
                            let x0 = x + k * 11;
                            area.draw(&PathElement::new(vec![(x0, y), (x0 + 7, y)], style))
                                .map_err(e)?;
                        }
                    }
                }
            }
            Entry::Band(b) => {
                area.draw(&Rectangle::new(
                    [(x, y - 7), (x + 30, y + 7)],
                    b.color.color().filled(),
                ))
                .map_err(e)?;
            }
        }
        area.draw(&Text::new(
            entry_label(&p.entry).to_string(),
            (x + 36, y),
            font.clone(),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// `(lo, hi)` widened by 4 % and to a non-zero span.
fn pad(lo: f64, hi: f64) -> (f64, f64) {
    let span = hi - lo;
    if span <= 1e-9 * lo.abs().max(hi.abs()).max(1.0) {
        let d = (lo.abs() * 0.05).max(1.0);
        (lo - d, hi + d)
    } else {
        (lo - 0.04 * span, hi + 0.04 * span)
    }
}

/// Widens the ranges so that one unit has the same length in pixels on
/// both axes of a `w` x `h` plotting area.
fn equalize(x: (f64, f64), y: (f64, f64), w: u32, h: u32) -> ((f64, f64), (f64, f64)) {
    let (w, h) = (w.max(1) as f64, h.max(1) as f64);
    let scale = ((x.1 - x.0) / w).max((y.1 - y.0) / h); // units per pixel
    let grow = |r: (f64, f64), px: f64| {
        let c = 0.5 * (r.0 + r.1);
        let half = 0.5 * scale * px;
        (c - half, c + half)
    };
    (grow(x, w), grow(y, h))
}

/// A tick label: no trailing zeros, no `-0`.
fn tick(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    let r = if r == 0.0 { 0.0 } else { r };
    let s = format!("{r:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// `bitmap`: a thick solid line is drawn as its segments with round
/// joins, because plotters fills a thick polyline's outline as one polygon
/// (even-odd), which leaves holes and stray areas where the line crosses
/// or retraces itself (a helix's turns, a move back along the same line).
/// SVG keeps one polyline (the viewer strokes it).
fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, Shift>,
    bitmap: bool,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing: {e}");
    let ((x0, x1), (y0, y1)) = panel.bounds().unwrap_or(((0.0, 1.0), (0.0, 1.0)));
    let (mut xr, mut yr) = (pad(x0, x1), pad(y0, y1));
    let valid = |r: &(f64, f64)| r.0.is_finite() && r.1.is_finite() && r.0 < r.1;
    let fixed_x = panel.x_range.filter(valid);
    let fixed_y = panel.y_range.filter(valid);
    if let Some(r) = fixed_x {
        xr = r;
    }
    if let Some(r) = fixed_y {
        yr = r;
    }
    if panel.equal_aspect {
        // the plotting area's size is known only once a chart is built;
        // a chart without a caption draws nothing when built
        let probe = if panel.caption.is_empty() {
            area.clone()
        } else {
            // the caption's height, as plotters splits it off
            let font = TextStyle::from((FONT, TEXT_PX as f64 + 2.0).into_font());
            let (_, th) = area.estimate_text_size(&panel.caption, &font).map_err(e)?;
            let (_, a) = area.split_vertically(th + MARGIN_PX);
            a
        };
        let (pw, ph) = {
            let mut b = ChartBuilder::on(&probe);
            b.margin(MARGIN_PX)
                .x_label_area_size(X_LABEL_AREA_PX)
                .y_label_area_size(Y_LABEL_AREA_PX);
            let c = b.build_cartesian_2d(xr.0..xr.1, yr.0..yr.1).map_err(e)?;
            c.plotting_area().dim_in_pixel()
        };
        (xr, yr) = equalize(xr, yr, pw, ph);
    }
    let mut b = ChartBuilder::on(area);
    b.margin(MARGIN_PX)
        .x_label_area_size(X_LABEL_AREA_PX)
        .y_label_area_size(Y_LABEL_AREA_PX);
    if !panel.caption.is_empty() {
        b.caption(&panel.caption, (FONT, TEXT_PX as f64 + 2.0));
    }
    let mut chart = b.build_cartesian_2d(xr.0..xr.1, yr.0..yr.1).map_err(e)?;
    for band in &panel.bands {
        let (a, z) = (band.x.0.max(xr.0), band.x.1.min(xr.1));
        if a < z {
            chart
                .plotting_area()
                .draw(&Rectangle::new(
                    [(a, yr.0), (z, yr.1)],
                    band.color.color().filled(),
                ))
                .map_err(e)?;
        }
    }
    let label_font = (FONT, TEXT_PX as f64).into_font();
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(label_font.clone())
        .axis_desc_style(label_font)
        .x_max_light_lines(1)
        .y_max_light_lines(1)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(e)?;
    let plot = chart.plotting_area();
    for s in &panel.series {
        let style = s.color.color().stroke_width(s.width.max(1));
        // a fixed range leaves points outside: cut the lines at its edges
        // (the drawing area would pin them to the edge instead)
        let clipped: Vec<Vec<Point>>;
        let lines = if fixed_x.is_some() || fixed_y.is_some() {
            clipped = s
                .polylines
                .iter()
                .flat_map(|l| clip_polyline(l, xr, yr))
                .collect();
            &clipped
        } else {
            &s.polylines
        };
        for line in lines {
            // points closer than MIN_STEP_PX to the previous one add
            // nothing but bytes (and ragged thick lines in bitmaps)
            let mut px: Vec<(i32, i32)> = Vec::with_capacity(line.len());
            let mut skipped = None;
            for p in line {
                if !(p.0.is_finite() && p.1.is_finite()) {
                    continue;
                }
                let q = chart.backend_coord(p);
                match px.last() {
                    Some(l) if (l.0 - q.0).abs().max((l.1 - q.1).abs()) < MIN_STEP_PX => {
                        skipped = Some(q)
                    }
                    _ => {
                        px.push(q);
                        skipped = None;
                    }
                }
            }
            px.extend(skipped);
            if px.len() == 1 {
                px.push(px[0]);
            }
            let root = plot.strip_coord_spec();
            match s.dash {
                Dash::Solid if bitmap && s.width > 1 => {
                    let px = shift(&px, &root);
                    for seg in px.windows(2) {
                        root.draw(&PathElement::new(seg.to_vec(), style))
                            .map_err(e)?;
                    }
                    let r = s.width / 2;
                    for &p in px.iter().skip(1).take(px.len().saturating_sub(2)) {
                        root.draw(&Circle::new(p, r, style.filled())).map_err(e)?;
                    }
                }
                Dash::Solid => root
                    .draw(&PathElement::new(shift(&px, &root), style))
                    .map_err(e)?,
                Dash::Dashed => root
                    .draw(&DashedPathElement::new(shift(&px, &root), 6, 5, style))
                    .map_err(e)?,
            }
        }
    }
    Ok(())
}

/// The parts of a polyline inside the rectangle `xr` × `yr` (segments cut
/// at its edges, Liang–Barsky); points that are not finite break the line.
fn clip_polyline(line: &[Point], xr: (f64, f64), yr: (f64, f64)) -> Vec<Vec<Point>> {
    let inside = |p: Point| p.0 >= xr.0 && p.0 <= xr.1 && p.1 >= yr.0 && p.1 <= yr.1;
    let mut out: Vec<Vec<Point>> = Vec::new();
    let mut cur: Vec<Point> = Vec::new();
    let finite = |p: &Point| p.0.is_finite() && p.1.is_finite();
    let mut prev: Option<Point> = None;
    for &p in line {
        if !finite(&p) {
            prev = None;
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            continue;
        }
        let Some(a) = prev.replace(p) else {
            if inside(p) {
                cur.push(p);
            }
            continue;
        };
        // the segment a→p as a + t (p − a), t in [t0, t1]
        let (dx, dy) = (p.0 - a.0, p.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut visible = true;
        for (q, r) in [
            (-dx, a.0 - xr.0),
            (dx, xr.1 - a.0),
            (-dy, a.1 - yr.0),
            (dy, yr.1 - a.1),
        ] {
            if q == 0.0 {
                if r < 0.0 {
                    visible = false;
                }
            } else {
                let t = r / q;
                if q < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        if !visible || t0 > t1 {
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            continue;
        }
        let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
        if t0 > 0.0 || cur.is_empty() {
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            cur.push(at(t0));
        }
        cur.push(if t1 < 1.0 { at(t1) } else { p });
        if t1 < 1.0 {
            out.push(std::mem::take(&mut cur));
        }
    }
    out.extend((!cur.is_empty()).then_some(cur));
    out
}

/// Backend coordinates relative to `area` (whose drawing clips to it).
fn shift<DB: DrawingBackend>(px: &[(i32, i32)], area: &DrawingArea<DB, Shift>) -> Vec<(i32, i32)> {
    let (ox, oy) = area.get_base_pixel();
    px.iter().map(|&(x, y)| (x - ox, y - oy)).collect()
}

/// Thins a stream of points to at most `max` kept points (plus the last
/// of each run), with bounded memory: every `stride`-th point is kept, and
/// when more than `max` are kept every other one is dropped and the stride
/// doubles. Points carry a tag; a change of tag starts a new run (a new
/// polyline) that begins at the previous run's last point, so runs join.
#[derive(Clone, Debug)]
pub struct Decimator<T> {
    max: usize,
    stride: u64,
    count: u64,
    kept: usize,
    runs: Vec<(u8, Vec<T>)>,
    /// the newest point of the current run if it was not kept
    pending: Option<T>,
}

impl<T: Copy> Decimator<T> {
    pub fn new(max: usize) -> Self {
        Decimator {
            max: max.max(4),
            stride: 1,
            count: 0,
            kept: 0,
            runs: Vec::new(),
            pending: None,
        }
    }

    pub fn push(&mut self, tag: u8, p: T) {
        let new_run = self.runs.last().is_none_or(|r| r.0 != tag);
        if new_run {
            let join = self.close_run();
            let mut v = Vec::with_capacity(16);
            v.extend(join);
            v.push(p);
            self.kept += v.len();
            self.runs.push((tag, v));
            self.count = 0;
        } else {
            self.count += 1;
            if self.count.is_multiple_of(self.stride) {
                self.pending = None;
                if let Some(r) = self.runs.last_mut() {
                    r.1.push(p);
                }
                self.kept += 1;
            } else {
                self.pending = Some(p);
            }
        }
        if self.kept > self.max && self.stride < 1 << 40 {
            self.thin();
        }
    }

    /// Ends the current run (keeping its newest point); its last point.
    fn close_run(&mut self) -> Option<T> {
        let r = self.runs.last_mut()?;
        if let Some(p) = self.pending.take() {
            r.1.push(p);
            self.kept += 1;
        }
        r.1.last().copied()
    }

    fn thin(&mut self) {
        let mut kept = 0;
        for (_, v) in &mut self.runs {
            let n = v.len();
            if n > 2 {
                let last = v[n - 1];
                let mut i = 0;
                v.retain(|_| {
                    i += 1;
                    (i - 1) % 2 == 0
                });
                if n % 2 == 0 {
                    v.push(last); // the last was an odd index: keep it
                }
            }
            kept += v.len();
        }
        self.kept = kept;
        self.stride *= 2;
    }

    /// The runs: `(tag, points)` in order.
    pub fn finish(mut self) -> Vec<(u8, Vec<T>)> {
        self.close_run();
        self.runs
    }
}

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

const RAPID: u8 = 1;
const FEED: u8 = 0;

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
type Box3 = (V3, V3);

fn grow(b: &mut Option<Box3>, p: V3) {
    match b {
        Some((lo, hi)) => {
            *lo = lo.inf(&p);
            *hi = hi.sup(&p);
        }
        None => *b = Some((p, p)),
    }
}

/// The paths of a program under radius compensation, for [`plot_program`].
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
fn programmed_path(machine: &Machine, dialect: Dialect, text: &str) -> Vec<(u8, Vec<V3>)> {
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

/// Setpoints and actual positions (mm, machine axes) of a run.
struct Run {
    setpoints: Vec<V3>,
    actual: Vec<V3>,
}

fn one_run<T: Copy>(d: Decimator<T>) -> Vec<T> {
    d.finish().into_iter().flat_map(|(_, v)| v).collect()
}

fn simulated_run(machine: &Machine, dialect: Dialect, text: &str) -> Run {
    let joints = machine.joint_indices();
    let mut set = Decimator::new(MAX_SERIES_POINTS);
    let mut act = Decimator::new(MAX_SERIES_POINTS);
    simulate(StrSource::new(text), dialect, machine, |st| {
        let s: &Sample = st.sample;
        set.push(0, s.pos);
        let mut a = V3::zeros();
        for (j, &i) in joints.iter().enumerate() {
            if let (Some(v), true) = (st.actual.get(j), i < 3) {
                a[i] = *v;
            }
        }
        act.push(0, a);
    });
    Run {
        setpoints: one_run(set),
        actual: one_run(act),
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
    let comp = comp_paths(machine, dialect, text);
    let programmed = match &comp {
        Some(c) => c.contour.clone(),
        None => programmed_path(machine, dialect, text),
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
    checked(machine, dialect, program_name, text)?;
    let run = simulated_run(machine, dialect, text);
    let title = format!(
        "{program_name} on {} ({}, {})",
        machine.name,
        kind_name(machine),
        dialect.id()
    );
    Ok(path_figure(title, machine, dialect, text, &run))
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

/// The job and the run read back from a recording.
struct Recorded {
    program_name: Option<String>,
    dialect: Option<String>,
    program: Option<String>,
    machine: Option<String>,
    setpoints: Decimator<V3>,
    actual: Decimator<V3>,
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

fn read_recording(path: &Path) -> Result<Recorded, String> {
    let err = |e: String| format!("{}: {e}", path.display());
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(err(
            "not an MCAP recording (no MCAP magic at the start)".into()
        ));
    }
    let mut r = Recorded {
        program_name: None,
        dialect: None,
        program: None,
        machine: None,
        setpoints: Decimator::new(MAX_SERIES_POINTS),
        actual: Decimator::new(MAX_SERIES_POINTS),
    };
    // metadata and attachments are top-level records; a recording cut
    // short (no end magic) is read as far as it goes
    let opts = || mcap::read::Options::IgnoreEndMagic.into();
    let reader = mcap::read::LinearReader::new_with_options(&bytes, opts())
        .map_err(|e| err(format!("not an MCAP recording: {e}")))?;
    for rec in reader {
        let Ok(rec) = rec else { break };
        match rec {
            mcap::records::Record::Metadata(m) if m.name == "cnc" => {
                r.program_name = m.metadata.get("program_name").cloned();
                r.dialect = m.metadata.get("dialect").cloned();
            }
            mcap::records::Record::Attachment { header, data, .. } => {
                let text = String::from_utf8_lossy(&data).into_owned();
                match header.name.as_str() {
                    "program.nc" => r.program = Some(text),
                    "machine.toml" => r.machine = Some(text),
                    _ => {}
                }
            }
            _ => {}
        }
    }
    let stream = mcap::MessageStream::new_with_options(&bytes, opts())
        .map_err(|e| err(format!("not an MCAP recording: {e}")))?;
    for msg in stream {
        let msg = msg.map_err(|e| err(format!("reading messages: {e}")))?;
        let topic = msg.channel.topic.as_str();
        match topic {
            topics::JOINT_SETPOINTS | topics::JOINT_STATES => {
                let js: cnc_msgs::JointState =
                    record::from_cdr(&msg.data).map_err(|e| err(format!("{topic}: {e}")))?;
                let p = joint_positions(&js);
                if topic == topics::JOINT_SETPOINTS {
                    r.setpoints.push(0, p);
                } else {
                    r.actual.push(0, p);
                }
            }
            // the job as latched messages, for a recording without attachments
            topics::PROGRAM | topics::MACHINE_FILE => {
                let s: cnc_msgs::StringMsg =
                    record::from_cdr(&msg.data).map_err(|e| err(format!("{topic}: {e}")))?;
                let slot = if topic == topics::PROGRAM {
                    &mut r.program
                } else {
                    &mut r.machine
                };
                if slot.is_none() {
                    *slot = Some(s.data);
                }
            }
            _ => {}
        }
    }
    Ok(r)
}

/// Plots a recording (`cnc simulate --record` or the node): the programmed
/// path from its attachments (`program.nc`, `machine.toml`, the dialect of
/// the `cnc` metadata), the setpoints (`/cnc/joint_setpoints`) and the
/// actual positions (`/sim/joint_states`), as [`plot_program`] draws them.
pub fn plot_recording(recording: &Path, out: &Path) -> Result<(), String> {
    Format::from_path(out)?;
    let r = read_recording(recording)?;
    let err = |e: String| format!("{}: {e}", recording.display());
    let machine_text = r
        .machine
        .ok_or_else(|| err("no machine file (attachment machine.toml)".into()))?;
    let machine =
        Machine::from_toml(&machine_text).map_err(|e| err(format!("machine.toml: {}", e.0)))?;
    let program = r
        .program
        .ok_or_else(|| err("no program (attachment program.nc)".into()))?;
    let dialect = match r.dialect.as_deref() {
        Some(d) if !d.is_empty() => d
            .parse::<Dialect>()
            .map_err(|e| err(format!("metadata cnc: {e}")))?,
        _ => machine.dialect,
    };
    let run = Run {
        setpoints: one_run(r.setpoints),
        actual: one_run(r.actual),
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
    let name = r
        .program_name
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| "program".into());
    let title = format!(
        "{name} on {} ({}, {}), recording {file}",
        machine.name,
        kind_name(&machine),
        dialect.id()
    );
    render(&path_figure(title, &machine, dialect, &program, &run), out)
}

/// One sample of a thread pass: the lead error against the spindle angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadErrorPoint {
    /// spindle angle the setpoint is for, degrees from the pass's θ₀
    /// (`(theta − theta0) × 360`, counted in the direction of rotation)
    pub deg: f64,
    /// setpoint lead travel minus the ideal thread line
    /// `pitch × (true spindle angle − θ₀)`, µm
    pub set_um: f64,
    /// the same for the simulated actual position, µm
    pub act_um: f64,
    /// in the synchronized part (not run-in or deceleration)
    pub on_line: bool,
}

/// One pass of a thread: a chain of G33 blocks from its run-in to its
/// deceleration, one sync.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadPass {
    /// the pass's first G33 block
    pub line: u32,
    pub block_no: Option<u64>,
    /// lead axis (0 X, 1 Y, 2 Z) and the first block's pitch, mm/rev
    pub lead: usize,
    pub pitch: f64,
    /// θ₀ of the first block, revolutions (the x axis's zero)
    pub theta0: f64,
    /// one encoder count along the lead at `pitch`, µm
    pub count_um: f64,
    /// samples of the pass (from the start of the run-in), and of those
    /// on the thread line
    pub samples: u64,
    pub on_line_samples: u64,
    /// the synchronized parts, degrees from θ₀ (first to last sample
    /// on the line; one span per chain)
    pub sync_deg: Vec<(f64, f64)>,
    /// largest |error| on the line: setpoint and actual, in µm and in
    /// encoder counts (each block's own pitch), over every sample
    pub max_set_um: f64,
    pub max_set_counts: f64,
    pub max_act_um: f64,
    pub max_act_counts: f64,
    /// the angle from which the actual error stays within one count for
    /// the rest of the synchronized part (`None`: not at its end)
    pub act_within_count_from_deg: Option<f64>,
    /// the error curve, thinned to at most [`MAX_SERIES_POINTS`] points
    /// (the ends of run-in, line and deceleration kept)
    pub points: Vec<ThreadErrorPoint>,
}

/// The lead error of every G33 pass of a run ([`thread_error_series`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadErrorSeries {
    /// encoder counts per spindle revolution
    pub counts_per_rev: u32,
    pub passes: Vec<ThreadPass>,
    /// why the run stopped early, if it did
    pub fault: Option<String>,
}

/// The pass being collected.
struct PassAcc {
    pass: ThreadPass,
    points: Decimator<ThreadErrorPoint>,
    /// the latest sample still at rest at the start (waiting for the sync
    /// angle), kept until the run-in moves
    waiting: Option<ThreadErrorPoint>,
    moved: bool,
    /// the previous sample was on the line
    prev_on: bool,
}

/// Collects [`ThreadErrorSeries`] from the steps of an offline run
/// ([`crate::offline::simulate`] or `simulate_with`): a pass begins at a
/// sample with `sync` after one without. The lead error compares the
/// lead axis's travel from the block's start (setpoint, simulated actual)
/// with `pitch × (θ − θ₀)` at the simulated spindle's true angle θ (the
/// angle after the step, the instant the setpoint is for), for each
/// block's own θ₀ and pitch. Samples at rest before the run-in begins
/// (waiting for the sync angle) are left out but the last.
pub struct ThreadErrors {
    joints: Vec<usize>,
    cpr: u32,
    cur: Option<PassAcc>,
    passes: Vec<ThreadPass>,
}

impl ThreadErrors {
    pub fn new(machine: &Machine) -> ThreadErrors {
        ThreadErrors {
            joints: machine.joint_indices(),
            cpr: machine
                .spindle
                .as_ref()
                .map_or(0, |s| s.encoder_counts_per_rev),
            cur: None,
            passes: Vec::new(),
        }
    }

    /// Takes one step of the run.
    pub fn step(&mut self, st: &Step) {
        let (Some(sync), Some(sp)) = (st.sample.sync, st.spindle) else {
            self.close();
            return;
        };
        let Some(j) = self.joints.iter().position(|&i| i == sync.lead) else {
            return;
        };
        let cpr = sp.encoder().counts_per_rev.max(1);
        self.cpr = cpr;
        let dir = if st.sample.spindle_rpm < 0.0 {
            -1.0
        } else {
            1.0
        };
        let theta_true = dir * sp.revolutions();
        let acc = self.cur.get_or_insert_with(|| PassAcc {
            pass: ThreadPass {
                line: st.sample.src.line,
                block_no: st.sample.src.block_no,
                lead: sync.lead,
                pitch: sync.pitch,
                theta0: sync.theta0,
                count_um: sync.pitch / f64::from(cpr) * 1000.0,
                samples: 0,
                on_line_samples: 0,
                sync_deg: Vec::new(),
                max_set_um: 0.0,
                max_set_counts: 0.0,
                max_act_um: 0.0,
                max_act_counts: 0.0,
                act_within_count_from_deg: None,
                points: Vec::new(),
            },
            points: Decimator::new(MAX_SERIES_POINTS),
            waiting: None,
            moved: false,
            prev_on: false,
        });
        let ideal = sync.pitch * (theta_true - sync.theta0);
        let u_set =
            sync.lead_sign * (st.setpoints.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let u_act =
            sync.lead_sign * (st.actual.get(j).copied().unwrap_or(f64::NAN) - sync.lead_start);
        let pt = ThreadErrorPoint {
            deg: (sync.theta - acc.pass.theta0) * 360.0,
            set_um: (u_set - ideal) * 1000.0,
            act_um: (u_act - ideal) * 1000.0,
            on_line: sync.on_line,
        };
        if !acc.moved {
            if sync.u == 0.0 && !sync.on_line {
                acc.waiting = Some(pt);
                return;
            }
            acc.moved = true;
            if let Some(w) = acc.waiting.take() {
                acc.pass.samples += 1;
                acc.points.push(0, w);
            }
        }
        let p = &mut acc.pass;
        p.samples += 1;
        acc.points.push(u8::from(pt.on_line), pt);
        let prev_on = std::mem::replace(&mut acc.prev_on, pt.on_line);
        if !pt.on_line {
            return;
        }
        let count_um = sync.pitch / f64::from(cpr) * 1000.0;
        p.on_line_samples += 1;
        p.max_set_um = p.max_set_um.max(pt.set_um.abs());
        p.max_set_counts = p.max_set_counts.max(pt.set_um.abs() / count_um);
        p.max_act_um = p.max_act_um.max(pt.act_um.abs());
        p.max_act_counts = p.max_act_counts.max(pt.act_um.abs() / count_um);
        match p.sync_deg.last_mut() {
            Some(span) if prev_on => span.1 = pt.deg,
            _ => p.sync_deg.push((pt.deg, pt.deg)),
        }
        if pt.act_um.abs() > count_um {
            p.act_within_count_from_deg = None;
        } else if p.act_within_count_from_deg.is_none() {
            p.act_within_count_from_deg = Some(pt.deg);
        }
    }

    /// Ends the pass being collected, if any.
    fn close(&mut self) {
        if let Some(acc) = self.cur.take() {
            let mut pass = acc.pass;
            let mut points = Vec::new();
            for (k, (_, run)) in acc.points.finish().into_iter().enumerate() {
                // each run after the first begins with the previous one's end
                points.extend(run.into_iter().skip(usize::from(k > 0)));
            }
            points.extend(acc.waiting);
            pass.points = points;
            self.passes.push(pass);
        }
    }

    /// The passes collected; `fault` as the run reported it.
    pub fn finish(mut self, fault: Option<String>) -> ThreadErrorSeries {
        self.close();
        ThreadErrorSeries {
            counts_per_rev: self.cpr,
            passes: self.passes,
            fault,
        }
    }
}

fn checked(
    machine: &Machine,
    dialect: Dialect,
    program_name: &str,
    text: &str,
) -> Result<(), String> {
    let report = check(StrSource::new(text), dialect, machine);
    if report.ok() {
        Ok(())
    } else {
        Err(format!(
            "{program_name}: {} error(s), nothing plotted:\n{}",
            report.error_count,
            report.message()
        ))
    }
}

/// Runs a program offline against the simulated machine (as
/// `cnc simulate`: the spindle model and its encoder drive G33) and
/// returns the lead error of each G33 pass against the spindle angle (see
/// [`ThreadErrors`]). The program must pass the check; the machine must
/// have a spindle.
pub fn thread_error_series(
    machine: &Machine,
    dialect: Dialect,
    text: &str,
) -> Result<ThreadErrorSeries, String> {
    checked(machine, dialect, "program", text)?;
    thread_errors_of_checked(machine, dialect, text)
}

fn thread_errors_of_checked(
    machine: &Machine,
    dialect: Dialect,
    text: &str,
) -> Result<ThreadErrorSeries, String> {
    if machine.spindle.is_none() {
        return Err(format!(
            "machine {}: no spindle ([spindle] in the machine file), so no G33",
            machine.name
        ));
    }
    let mut acc = ThreadErrors::new(machine);
    let summary = simulate(StrSource::new(text), dialect, machine, |st| acc.step(st));
    Ok(acc.finish(summary.fault))
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
    checked(machine, dialect, program_name, text)?;
    let series = thread_errors_of_checked(machine, dialect, text)?;
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
        "{program_name} on {}: G33 {} lead error, pass {pass} of {n}",
        machine.name,
        axis_name(p.lead)
    );
    render(&thread_figure(title, &series, p), out)?;
    Ok(series)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimator_bounds_points_and_keeps_ends() {
        let mut d = Decimator::new(100);
        for i in 0..100_000u32 {
            d.push(0, i);
        }
        let runs = d.finish();
        assert_eq!(runs.len(), 1);
        let v = &runs[0].1;
        assert!(v.len() <= 101 && v.len() >= 50, "{}", v.len());
        assert_eq!(v[0], 0);
        assert_eq!(*v.last().unwrap(), 99_999);
        assert!(v.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn decimator_runs_join() {
        let mut d = Decimator::new(1000);
        for i in 0..10 {
            d.push(if i < 5 { 1 } else { 0 }, i);
        }
        let runs = d.finish();
        assert_eq!(
            runs,
            vec![(1, vec![0, 1, 2, 3, 4]), (0, vec![4, 5, 6, 7, 8, 9])]
        );
    }

    #[test]
    fn equal_aspect_ranges() {
        let (x, y) = equalize((0.0, 100.0), (0.0, 10.0), 1000, 500);
        assert!(((x.1 - x.0) / 1000.0 - (y.1 - y.0) / 500.0).abs() < 1e-12);
        assert!(x.1 - x.0 >= 100.0 && y.1 - y.0 >= 10.0);
    }

    #[test]
    fn clipping_cuts_lines_at_the_edges() {
        let r = ((0.0, 10.0), (-1.0, 1.0));
        // inside: unchanged
        let l = vec![(0.0, 0.0), (5.0, 0.5), (10.0, -1.0)];
        assert_eq!(clip_polyline(&l, r.0, r.1), vec![l.clone()]);
        // out at the top and back in: two pieces, cut at y = 1
        let l = vec![(0.0, 0.0), (2.0, 2.0), (4.0, 0.0)];
        assert_eq!(
            clip_polyline(&l, r.0, r.1),
            vec![vec![(0.0, 0.0), (1.0, 1.0)], vec![(3.0, 1.0), (4.0, 0.0)]]
        );
        // starts outside, a segment wholly outside, NaN breaks the line
        let l = vec![
            (1.0, -3.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (f64::NAN, 0.0),
            (3.0, 0.0),
            (3.0, 5.0),
            (4.0, 5.0),
        ];
        assert_eq!(
            clip_polyline(&l, r.0, r.1),
            vec![
                vec![(1.0, -1.0), (1.0, 0.0), (2.0, 0.0)],
                vec![(3.0, 0.0), (3.0, 1.0)]
            ]
        );
    }

    #[test]
    fn ticks() {
        assert_eq!(tick(10.0), "10");
        assert_eq!(tick(-0.0001), "0");
        assert_eq!(tick(2.5), "2.5");
    }
}
