//! What every run is planned with: the axes' limits less a margin for
//! the samples' finite differences, and the sample time.

use crate::geom::V3;
use crate::machine::Machine;
use crate::path_speed::AxisLimits;

/// The limits the runs keep are the axes' less a margin for the samples'
/// finite differences: acceleration and jerk.
const A_KEEP: f64 = 0.99;
const J_KEEP: f64 = 0.9;
/// An axis with no limit gets this one (it is never reached).
const NO_LIMIT: f64 = 1e12;

/// What every run is planned with: the axes' limits and the sample time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunLimits {
    /// what the planner keeps (a margin under the machine's)
    pub axes: AxisLimits,
    /// the machine's own, which every sample keeps
    pub machine: AxisLimits,
    /// the largest normal acceleration of a curve, mm/s²
    /// (`Machine::contour_accel`)
    pub normal_a: f64,
    pub dt: f64,
}

impl RunLimits {
    /// The machine's limits if it plans with the path planner.
    pub fn for_machine(m: &Machine) -> Option<RunLimits> {
        if !m.plans_path() {
            return None;
        }
        let lim = |v: V3, keep: f64| {
            [0, 1, 2].map(|i| {
                if v[i].is_finite() {
                    v[i] * keep
                } else {
                    NO_LIMIT
                }
            })
        };
        Some(RunLimits {
            axes: AxisLimits {
                v: lim(m.vmax(), 1.0),
                a: lim(m.amax(), A_KEEP),
                j: lim(m.jmax(), J_KEEP),
            },
            machine: AxisLimits {
                v: lim(m.vmax(), 1.0),
                a: lim(m.amax(), 1.0),
                j: lim(m.jmax(), 1.0),
            },
            normal_a: m.contour_accel(),
            dt: 1.0 / m.interpolation.rate_hz,
        })
    }
}
