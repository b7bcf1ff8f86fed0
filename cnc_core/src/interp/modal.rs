//! Modal state: the G codes in force, the spindle, the tool.

use crate::geom::Plane;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    Rapid,
    Linear,
    CwArc,
    CcwArc,
    /// heidenhain G10: polar line at rapid
    PolarRapid,
    /// heidenhain G11: polar line at feed
    PolarLine,
    /// heidenhain G12: polar arc clockwise about the pole
    PolarCw,
    /// heidenhain G13: polar arc counter-clockwise about the pole
    PolarCcw,
}

impl Motion {
    pub fn gcode(self) -> &'static str {
        match self {
            Motion::Rapid => "G00",
            Motion::Linear => "G01",
            Motion::CwArc => "G02",
            Motion::CcwArc => "G03",
            Motion::PolarRapid => "G10",
            Motion::PolarLine => "G11",
            Motion::PolarCw => "G12",
            Motion::PolarCcw => "G13",
        }
    }

    pub(super) fn polar(self) -> bool {
        matches!(
            self,
            Motion::PolarRapid | Motion::PolarLine | Motion::PolarCw | Motion::PolarCcw
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpindleDir {
    Off,
    Cw,
    Ccw,
}

/// The modal state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    pub motion: Motion,
    pub plane: Plane,
    pub absolute: bool,
    pub per_rev: bool,
    /// F as programmed (mm/min or mm/rev)
    pub feed: Option<f64>,
    /// S, rpm
    pub speed: f64,
    pub spindle: SpindleDir,
    pub tool: u32,
}

impl Modal {
    /// The active modal G codes, e.g. `["G01", "G17", "G90", "G94"]`.
    pub fn gcodes(&self) -> [&'static str; 4] {
        [
            self.motion.gcode(),
            self.plane.gcode(),
            if self.absolute { "G90" } else { "G91" },
            if self.per_rev { "G95" } else { "G94" },
        ]
    }
    /// Signed commanded spindle speed, rpm.
    pub fn spindle_rpm(&self) -> f64 {
        match self.spindle {
            SpindleDir::Off => 0.0,
            SpindleDir::Cw => self.speed,
            SpindleDir::Ccw => -self.speed,
        }
    }
}

/// G00..G03
pub(super) const MOTIONS: [Motion; 4] =
    [Motion::Rapid, Motion::Linear, Motion::CwArc, Motion::CcwArc];

pub(super) const POLAR: [Motion; 4] = [
    Motion::PolarRapid,
    Motion::PolarLine,
    Motion::PolarCw,
    Motion::PolarCcw,
];
