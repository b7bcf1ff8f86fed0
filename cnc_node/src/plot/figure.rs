//! The figure model: a [`Figure`] is a title, a legend row and [`Panel`]s
//! stacked vertically (or side by side); a panel holds [`Series`] of 2D
//! polylines, axes labels, shaded x spans ([`Band`]) and optional fixed
//! ranges. [`Format`] is the output format by a file's extension.

use plotters::style::RGBColor;
use std::path::Path;

/// A point of a 2D plot, in data units (mm for paths).
pub type Point = (f64, f64);

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

    pub(crate) fn color(self) -> RGBColor {
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
