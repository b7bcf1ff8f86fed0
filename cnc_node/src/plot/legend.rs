//! The legend: every distinct label of a figure's series and bands, laid
//! out in rows that fit the figure's width.

use super::figure::{Band, Dash, Figure, Series};
use super::style::{FONT, LEGEND_ROW_PX, MARGIN_PX, TEXT_PX, Y_LABEL_AREA_PX};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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
pub(crate) struct Placed<'a> {
    entry: Entry<'a>,
    pub(crate) row: u32,
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
pub(crate) fn legend_layout<'a, DB: DrawingBackend>(
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

pub(crate) fn draw_legend<DB: DrawingBackend>(
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
