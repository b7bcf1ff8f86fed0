//! Travel limits: where a move leaves an axis's range, and the bounding
//! box of the path. The interpreter checks the path as programmed (its
//! errors point at the axis words); the compensation stage checks the
//! compensated path it makes (`pipeline.rs`).

use crate::diag::num;
use crate::geom::V3;
use crate::machine::Machine;

/// Tolerance of the range checks, mm (rounding of the path's extremes).
pub const EPS: f64 = 1e-9;

/// The machine's axis ranges.
#[derive(Clone, Copy, Debug)]
pub struct Travel {
    present: [bool; 3],
    lo: V3,
    hi: V3,
    /// lathe X is programmed as a diameter: messages say so
    diameter: bool,
}

const AXIS_LETTERS: [u8; 3] = [b'X', b'Y', b'Z'];

impl Travel {
    pub fn new(machine: &Machine) -> Self {
        Travel {
            present: [0, 1, 2].map(|i| machine.axis(i).is_some()),
            lo: V3::from_fn(|i, _| machine.axis(i).map_or(0.0, |a| a.min_mm)),
            hi: V3::from_fn(|i, _| machine.axis(i).map_or(0.0, |a| a.max_mm)),
            diameter: machine.diameter_mode(),
        }
    }

    /// `lo..hi` on axis `i` lies within its range (an axis the machine
    /// does not have has no range).
    #[inline]
    pub fn within(&self, i: usize, lo: f64, hi: f64) -> bool {
        !self.present[i] || (lo >= self.lo[i] - EPS && hi <= self.hi[i] + EPS)
    }

    /// Where a move from `start` with extent `lo`..`hi` on axis `i` leaves
    /// its travel, with the text "X (diameter) -3, outside the axis range
    /// 0..500"; `None` inside it, or when only the start is outside (that
    /// was reported with the move before). An axis the machine does not
    /// have has no travel at all: a move that goes along it anyway (a
    /// polar block, an arc or a compensated path in a plane with that
    /// axis; its words are refused by themselves) leaves it, "Y 12.071,
    /// an axis this machine does not have".
    pub fn exceeded(&self, i: usize, start: f64, lo: f64, hi: f64) -> Option<(f64, String)> {
        // (a missing axis's range is where it stands)
        let (min, max) = if self.present[i] {
            (self.lo[i], self.hi[i])
        } else {
            (start, start)
        };
        let v = if lo < min - EPS {
            lo
        } else if hi > max + EPS {
            hi
        } else {
            return None;
        };
        if v == start {
            return None;
        }
        if !self.present[i] {
            return Some((
                v,
                format!(
                    "{} {}, an axis this machine does not have",
                    AXIS_LETTERS[i] as char,
                    num(v)
                ),
            ));
        }
        let (k, what) = if i == 0 && self.diameter {
            (2.0, " (diameter)")
        } else {
            (1.0, "")
        };
        Some((
            v,
            format!(
                "{}{} {}, outside the axis range {}..{}",
                AXIS_LETTERS[i] as char,
                what,
                num(v * k),
                num(self.lo[i] * k),
                num(self.hi[i] * k)
            ),
        ))
    }
}

/// Adds an extent to a bounding box.
#[inline]
pub fn grow(bbox: &mut Option<(V3, V3)>, lo: V3, hi: V3) {
    *bbox = Some(match *bbox {
        None => (lo, hi),
        Some((a, b)) => (a.inf(&lo), b.sup(&hi)),
    });
}
