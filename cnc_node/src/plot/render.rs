//! Drawing a [`Figure`] with plotters' SVG and bitmap backends: the title,
//! the legend, the panels (axes, ticks, grid, bands, series cut at fixed
//! ranges, points closer than a few pixels merged), and PNG encoding.

use super::figure::{Dash, Figure, Format, Panel, Point};
use super::legend::{draw_legend, legend_layout};
use super::scale::{clip_polyline, equalize, pad, tick};
use super::style::{
    fonts, FONT, LEGEND_ROW_PX, MARGIN_PX, MIN_STEP_PX, TEXT_PX, TITLE_PX, X_LABEL_AREA_PX,
    Y_LABEL_AREA_PX,
};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use std::path::Path;

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

/// Backend coordinates relative to `area` (whose drawing clips to it).
fn shift<DB: DrawingBackend>(px: &[(i32, i32)], area: &DrawingArea<DB, Shift>) -> Vec<(i32, i32)> {
    let (ox, oy) = area.get_base_pixel();
    px.iter().map(|&(x, y)| (x - ox, y - oy)).collect()
}
