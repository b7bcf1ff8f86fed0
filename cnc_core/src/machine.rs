//! Machine files (TOML): axes, limits, spindle, planner and interpolation
//! settings, the default dialect. Validated at load; every error names the
//! key.

use crate::dialect::Dialect;
use crate::geom::V3;
use crate::jerk::JerkBudget;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MachineKind {
    Mill,
    Lathe,
}

#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    /// joint name on ROS topics and in recordings: "x", "y" or "z"
    pub name: String,
    /// travel limits, mm (for a diameter-mode X: radius, i.e. slide position)
    pub min_mm: f64,
    pub max_mm: f64,
    /// where the axis stands when the controller starts, mm
    #[serde(default)]
    pub home_mm: f64,
    pub max_velocity_mm_s: f64,
    pub max_acceleration_mm_s2: f64,
    /// jerk limit, mm/s³ (absent: acceleration-limited only). The
    /// setpoints pass a moving-average filter long enough that every axis's
    /// sampled jerk stays under its limit (see `Machine::smoothing_samples`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_jerk_mm_s3: Option<f64>,
    /// lathe X programmed as a diameter (positions on topics stay radius)
    #[serde(default)]
    pub diameter_mode: bool,
    /// servo model of the simulator: position gain 1/s
    #[serde(default = "default_kp")]
    pub servo_kp: f64,
    /// servo model: velocity feed-forward 0..=1
    #[serde(default = "default_ff")]
    pub servo_feed_forward: f64,
    /// servo model: velocity-loop time constant, s
    #[serde(default = "default_lag")]
    pub servo_lag_s: f64,
    /// servo model: acceleration feed-forward 0..=1, the share of the
    /// velocity loop's lag under acceleration the drive makes up (0, the
    /// default: none)
    #[serde(default, skip_serializing_if = "is_zero")]
    pub servo_accel_feed_forward: f64,
}

/// Longest setpoint delay a machine file may set, ms.
pub const MAX_SETPOINT_DELAY_MS: f64 = 100.0;

/// Longest jerk filter, samples.
pub const MAX_SMOOTHING_SAMPLES: usize = 1000;

fn default_kp() -> f64 {
    60.0
}
fn default_ff() -> f64 {
    1.0
}
fn default_lag() -> f64 {
    0.002
}

#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleConfig {
    pub max_rpm: f64,
    pub acceleration_rpm_s: f64,
    pub encoder_counts_per_rev: u32,
    /// simulator: sinusoidal speed ripple as a fraction (0.02 = ±2 %)
    #[serde(default)]
    pub sim_ripple_fraction: f64,
    #[serde(default = "default_ripple_hz")]
    pub sim_ripple_hz: f64,
    #[serde(default)]
    pub sim_noise_rpm: f64,
    /// encoder readings missing this long during G33/G95 motion are a
    /// lost signal (controlled stop, error), ms; default 25 interpolation
    /// cycles
    #[serde(default)]
    pub encoder_timeout_ms: Option<f64>,
    /// a thread stops when the lead axis, as the drives report it, is off
    /// the thread line by more than this, degrees of the spindle (the
    /// median of the last 50 joint states; the node checks it); default 2
    #[serde(default)]
    pub thread_phase_limit_deg: Option<f64>,
}

fn default_ripple_hz() -> f64 {
    5.0
}

#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlannerConfig {
    /// junctions whose direction changes by more than this stop exactly
    #[serde(default = "default_exact_stop")]
    pub exact_stop_angle_deg: f64,
    /// how many segments the look-ahead may hold
    #[serde(default = "default_lookahead")]
    pub lookahead_blocks: usize,
    /// path tolerance at program start, mm: corners between feed lines are
    /// blended with arcs that stay within it (0: the exact path, as G61;
    /// programs set it with `G64 P<mm>`)
    #[serde(default)]
    pub path_tolerance_mm: f64,
    /// how the path is planned: `"filters"` (the look-ahead of
    /// trapezoidal profiles, corner blends and jerk filters), `"path"`
    /// (runs smoothed within P and planned sample by sample under every
    /// axis's jerk limit, `crate::path_run`) or `"auto"`, the default:
    /// the path planner where an axis's jerk limit is under
    /// `AUTO_PATH_BELOW_MM_S3`, else the filters (`Machine::plans_path`);
    /// written out only when it is not the default, so that a recording's
    /// machine is what it was
    #[serde(default, skip_serializing_if = "PlanMethod::is_auto")]
    pub method: PlanMethod,
    /// the path planner only: how far, mm, the drives' lag under the
    /// path's normal acceleration may take the tool off a curve, by each
    /// axis's servo model (`Machine::servo_accel_lag_s2`, the lag per unit
    /// of acceleration); the path planner keeps the normal acceleration
    /// under this over the largest of them (`Machine::contour_accel`); a
    /// machine that plans with the filters is refused with it. Absent
    /// (the default): no such cap
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contour_error_mm: Option<f64>,
}

/// How the path is planned ([`PlannerConfig::method`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PlanMethod {
    /// The path planner below `AUTO_PATH_BELOW_MM_S3`, else the filters.
    #[default]
    Auto,
    Filters,
    Path,
}

impl PlanMethod {
    pub fn is_auto(&self) -> bool {
        *self == PlanMethod::Auto
    }
}

/// Under `method = "auto"`, a machine with an axis whose jerk limit is
/// under this plans with the path planner, mm/s³. On bench/motion's CAM
/// program (`bench/motion/jerk.sh`) the filters keep within 5 % of
/// LinuxCNC's cycle time from 200 m/s³ up (1.045× at 200, 0.997× at
/// 1000), at about a hundredth of the path planner's CPU; below it they
/// do not (1.211× at 50, 1.503× at 20), and the path planner does
/// (1.019× at 50; at 20 the curvature bound and the stops bind).
pub const AUTO_PATH_BELOW_MM_S3: f64 = 2.0e5;

fn default_exact_stop() -> f64 {
    2.0
}
fn default_lookahead() -> usize {
    200
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            exact_stop_angle_deg: default_exact_stop(),
            lookahead_blocks: default_lookahead(),
            path_tolerance_mm: 0.0,
            method: PlanMethod::Auto,
            contour_error_mm: None,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InterpolationConfig {
    /// samples per second (default 1000)
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// the drives apply each setpoint this long after its stamp, ms (a
    /// fixed transport delay on a shared clock, as in cyclic synchronous
    /// position mode; 0: on arrival). G33 leads by it.
    #[serde(default)]
    pub setpoint_delay_ms: f64,
    /// how much of the lead axis's servo lag under the spindle's
    /// acceleration G33 leads by, 0..=1 (0, the default: none). The
    /// acceleration comes from the encoder tracker's fit, about 12 ms
    /// late: it takes up speed changes slower than about 10 Hz (a 5 Hz
    /// ripple's wander at S2000 from ±0.2° to ±0.07°) and adds to faster
    /// ones (a 33 Hz ripple's by 40 %): set it for a spindle whose speed
    /// varies slowly.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub thread_accel_lead: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn default_rate() -> f64 {
    1000.0
}

impl Default for InterpolationConfig {
    fn default() -> Self {
        InterpolationConfig {
            rate_hz: default_rate(),
            setpoint_delay_ms: 0.0,
            thread_accel_lead: 0.0,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// largest program accepted, bytes
    #[serde(default = "default_max_program")]
    pub max_program_bytes: u64,
    /// longest accepted line, bytes
    #[serde(default = "default_max_line")]
    pub max_line_bytes: usize,
    /// errors listed in one report before "and N more"
    #[serde(default = "default_max_errors")]
    pub max_errors: usize,
    /// blocks a program may execute, loop repetitions (G73) included: a
    /// program whose loops would run more is refused at the jump that
    /// goes past it (written only when not the default, so machine files
    /// recorded before this key read back the same)
    #[serde(
        default = "default_max_executed_blocks",
        skip_serializing_if = "is_default_max_executed_blocks"
    )]
    pub max_executed_blocks: u64,
}

fn default_max_program() -> u64 {
    64 * 1024 * 1024
}
fn default_max_line() -> usize {
    4096
}
fn default_max_errors() -> usize {
    1000
}
/// 1e9: five times the 9999 × 9999 loops of `bench/loops_9999x9999.sh`
/// (2e8 blocks, 80 s of check in a release build)
fn default_max_executed_blocks() -> u64 {
    1_000_000_000
}
fn is_default_max_executed_blocks(v: &u64) -> bool {
    *v == default_max_executed_blocks()
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_program_bytes: default_max_program(),
            max_line_bytes: default_max_line(),
            max_errors: default_max_errors(),
            max_executed_blocks: default_max_executed_blocks(),
        }
    }
}

/// Machine constants of the original controls.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Constants {
    /// MEFI machine constant 8 (`TAB0.REK`): the thread runout, a signed
    /// eight-decade number: decades 1-5 the angle in thousandths of a
    /// degree, decade 6 the axis (1 X, 2 Y, 3 Z), the sign the angle's;
    /// `"+00112345"` is 12.345 degrees on X. At most 60 degrees.
    #[serde(default)]
    pub mc8: Option<String>,
}

/// The thread runout of machine constant 8.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Runout {
    /// machine coordinate index (0 X, 1 Y, 2 Z)
    pub axis: usize,
    /// signed angle, degrees
    pub angle_deg: f64,
}

/// Decodes machine constant 8 (see [`Constants::mc8`]).
pub fn decode_mc8(text: &str) -> Result<Runout, String> {
    let t = text.trim();
    let (neg, digits) = match t.as_bytes().first() {
        Some(b'-') => (true, &t[1..]),
        Some(b'+') => (false, &t[1..]),
        _ => (false, t),
    };
    if digits.is_empty() || digits.len() > 8 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!(
            "\"{text}\" is not a signed eight-decade number such as \"+00112345\" (12.345 degrees on X)"
        ));
    }
    let v: u32 = digits
        .parse()
        .map_err(|_| format!("\"{text}\" is not a number"))?;
    let thousandths = v % 100_000;
    let axis = (v / 100_000) % 10;
    if !(1..=3).contains(&axis) {
        return Err(format!(
            "\"{text}\": decade 6 must name the runout axis, 1 (X), 2 (Y) or 3 (Z), not {axis}"
        ));
    }
    let angle = thousandths as f64 / 1000.0;
    if angle > 60.0 {
        return Err(format!(
            "\"{text}\": the runout angle {angle:.3} degrees is over 60 degrees"
        ));
    }
    Ok(Runout {
        axis: axis as usize - 1,
        angle_deg: if neg { -angle } else { angle },
    })
}

/// A machine file.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    pub name: String,
    pub kind: MachineKind,
    /// dialect of programs that do not name one
    pub dialect: Dialect,
    /// directory of programs sent by path (relative to the machine file)
    #[serde(default)]
    pub program_dir: Option<String>,
    #[serde(default)]
    pub interpolation: InterpolationConfig,
    #[serde(default)]
    pub planner: PlannerConfig,
    #[serde(default)]
    pub limits: Limits,
    /// the axes in joint order
    #[serde(rename = "axis")]
    pub axes: Vec<AxisConfig>,
    #[serde(default)]
    pub spindle: Option<SpindleConfig>,
    #[serde(default)]
    pub constants: Constants,
    /// radius compensation settings
    #[serde(default)]
    pub compensation: CompensationConfig,
    /// the tool table: lathe offsets (`T0101` selects offset 1), mill tools
    /// (`T5` selects tool 5)
    #[serde(default, rename = "tool")]
    pub tools: Vec<ToolConfig>,
}

/// One entry of the tool table.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ToolConfig {
    /// lathe: the offset number (the last two digits of `T####`, 1..99);
    /// mill: the tool number (`T<n>`, 1..9999)
    pub number: u32,
    /// nose (lathe) or cutter (mill) radius, mm
    #[serde(default)]
    pub radius_mm: f64,
    /// lathe tool type 0-9: where the imaginary tip lies from the nose
    /// centre (`docs/compensation.md` §3); 0 and 9: the nose centre is programmed
    #[serde(default)]
    pub tip: u8,
    /// geometry offsets: where the controlled point (the imaginary tip, or
    /// the cutter's end) lies from the slide's reference point, mm
    #[serde(default)]
    pub x_mm: f64,
    #[serde(default)]
    pub y_mm: f64,
    #[serde(default)]
    pub z_mm: f64,
}

impl ToolConfig {
    /// The geometry offset as a vector (X, Y, Z).
    pub fn offset(&self) -> V3 {
        V3::new(self.x_mm, self.y_mm, self.z_mm)
    }
}

/// Radius compensation settings.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CompensationConfig {
    /// outside corners: false (the default, as the seed's control) joins
    /// the offset elements at their intersection, extending both; true
    /// rounds them with an arc of the tool radius about the corner
    #[serde(default)]
    pub round_outside_corners: bool,
}

/// The direction of the imaginary tip from the nose centre for tool type
/// 0-9, in units of the nose radius, as (X, Z) (`docs/compensation.md` §3).
pub fn tip_vector(tip: u8) -> (f64, f64) {
    match tip {
        1 => (1.0, 1.0),
        2 => (1.0, -1.0),
        3 => (-1.0, -1.0),
        4 => (-1.0, 1.0),
        5 => (0.0, 1.0),
        6 => (1.0, 0.0),
        7 => (0.0, -1.0),
        8 => (-1.0, 0.0),
        _ => (0.0, 0.0),
    }
}

/// An error in a machine file; the text names the key.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineError(pub String);

impl std::fmt::Display for MachineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for MachineError {}

/// A value in a message about a machine file: as written for the usual
/// sizes, with an exponent for the tiny and the huge (1e-300, not 300
/// digits).
fn shown(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1.0e-4..1.0e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

impl Machine {
    /// Parses and validates a machine file's text.
    pub fn from_toml(text: &str) -> Result<Machine, MachineError> {
        let m: Machine = toml::from_str(text)
            .map_err(|e| MachineError(format!("machine file: {}", e.to_string().trim_end())))?;
        m.validate()?;
        Ok(m)
    }

    /// The bundled mill (X Y Z), the same as `config/mill.toml`.
    pub fn builtin_mill() -> Machine {
        // The bundled file is validated by the tests.
        Machine::from_toml(include_str!("../../config/mill.toml")).expect("bundled mill.toml")
    }

    /// The bundled lathe (X in diameter, Z, spindle), as `config/lathe.toml`.
    pub fn builtin_lathe() -> Machine {
        Machine::from_toml(include_str!("../../config/lathe.toml")).expect("bundled lathe.toml")
    }

    /// Checks every value against what a machine can have (the first that
    /// cannot, by its key). [`Machine::from_toml`] does; a caller that
    /// changes a value afterwards (the interpolation rate on the command
    /// line) checks again.
    pub fn validate(&self) -> Result<(), MachineError> {
        let bad = |key: String, why: String| {
            Err(MachineError(format!("machine file: key `{key}`: {why}")))
        };
        if self.axes.is_empty() {
            return bad("axis".into(), "at least one [[axis]] is required".into());
        }
        let mut seen = [false; 3];
        for (i, a) in self.axes.iter().enumerate() {
            let k = |f: &str| format!("axis[{i}].{f}");
            let Some(idx) = axis_index(&a.name) else {
                return bad(
                    k("name"),
                    format!(
                        "\"{}\" is not an axis; expected \"x\", \"y\" or \"z\"",
                        a.name
                    ),
                );
            };
            if seen[idx] {
                return bad(k("name"), format!("axis \"{}\" is defined twice", a.name));
            }
            seen[idx] = true;
            for (f, v) in [
                ("min_mm", a.min_mm),
                ("max_mm", a.max_mm),
                ("home_mm", a.home_mm),
            ] {
                if !v.is_finite() {
                    return bad(k(f), "must be a finite number".into());
                }
            }
            if a.min_mm >= a.max_mm {
                return bad(
                    k("max_mm"),
                    format!("must be greater than min_mm ({})", a.min_mm),
                );
            }
            if a.home_mm < a.min_mm || a.home_mm > a.max_mm {
                return bad(
                    k("home_mm"),
                    format!("{} is outside min_mm..max_mm", a.home_mm),
                );
            }
            // (a machine's own figures, not a float's: a limit of 1e-300
            // would make a 10 mm move last longer than the tick count holds)
            for (f, v, lo, hi) in [
                ("max_velocity_mm_s", a.max_velocity_mm_s, 0.01, 1.0e5),
                (
                    "max_acceleration_mm_s2",
                    a.max_acceleration_mm_s2,
                    1.0,
                    1.0e7,
                ),
                ("servo_kp", a.servo_kp, 0.1, 1.0e5),
            ] {
                if !(v.is_finite() && (lo..=hi).contains(&v)) {
                    return bad(
                        k(f),
                        format!("must be between {lo} and {hi} (got {})", shown(v)),
                    );
                }
            }
            if let Some(j) = a.max_jerk_mm_s3 {
                if !(j.is_finite() && j > 0.0 && j <= 1.0e10) {
                    return bad(
                        k("max_jerk_mm_s3"),
                        format!("must be greater than 0 and at most 1e10 (got {})", shown(j)),
                    );
                }
            }
            if !(0.0..=1.0).contains(&a.servo_accel_feed_forward) {
                return bad(
                    k("servo_accel_feed_forward"),
                    "must be between 0 and 1".into(),
                );
            }
            if !(0.0..=1.0).contains(&a.servo_feed_forward) {
                return bad(k("servo_feed_forward"), "must be between 0 and 1".into());
            }
            if !(a.servo_lag_s.is_finite() && a.servo_lag_s >= 0.0) {
                return bad(k("servo_lag_s"), "must be 0 or more".into());
            }
            if a.diameter_mode && (self.kind != MachineKind::Lathe || idx != 0) {
                return bad(
                    k("diameter_mode"),
                    "only the X axis of a lathe can be in diameter mode".into(),
                );
            }
        }
        if self.kind == MachineKind::Lathe && (!seen[0] || !seen[2] || seen[1]) {
            return bad("axis".into(), "a lathe has exactly the axes x and z".into());
        }
        let r = self.interpolation.rate_hz;
        if !(r.is_finite() && (10.0..=100_000.0).contains(&r)) {
            return bad(
                "interpolation.rate_hz".into(),
                format!("must be between 10 and 100000 (got {r})"),
            );
        }
        let d = self.interpolation.setpoint_delay_ms;
        if !(d.is_finite() && (0.0..=MAX_SETPOINT_DELAY_MS).contains(&d)) {
            return bad(
                "interpolation.setpoint_delay_ms".into(),
                format!("must be between 0 and {MAX_SETPOINT_DELAY_MS} (got {d})"),
            );
        }
        let w = self.interpolation.thread_accel_lead;
        if !(w.is_finite() && (0.0..=1.0).contains(&w)) {
            return bad(
                "interpolation.thread_accel_lead".into(),
                format!("must be between 0 and 1 (got {w})"),
            );
        }
        let p = &self.planner;
        if !(p.exact_stop_angle_deg.is_finite() && (0.0..=90.0).contains(&p.exact_stop_angle_deg)) {
            return bad(
                "planner.exact_stop_angle_deg".into(),
                "must be between 0 and 90".into(),
            );
        }
        if !(p.path_tolerance_mm.is_finite() && (0.0..=10.0).contains(&p.path_tolerance_mm)) {
            return bad(
                "planner.path_tolerance_mm".into(),
                "must be between 0 and 10".into(),
            );
        }
        if let Some(e) = p.contour_error_mm {
            if !(e.is_finite() && e > 0.0 && e <= 10.0) {
                return bad(
                    "planner.contour_error_mm".into(),
                    format!("must be over 0 and at most 10 (got {e})"),
                );
            }
            // (a key that would change nothing is a mistake to say so)
            if !self.plans_path() {
                return bad(
                    "planner.contour_error_mm".into(),
                    "only the path planner keeps it, and this machine plans with the filters \
                     (method = \"filters\", or \"auto\" with every axis's jerk limit at 200 m/s³ or more)"
                        .into(),
                );
            }
        }
        let m = self.smoothing_samples_f();
        if m > MAX_SMOOTHING_SAMPLES as f64 {
            return bad(
                "axis.max_jerk_mm_s3".into(),
                format!(
                    "too low for the acceleration: the jerk filter would need {m:.0} samples \
                     (at most {MAX_SMOOTHING_SAMPLES}); raise it to at least {:.0} mm/s³",
                    self.min_jerk()
                ),
            );
        }
        if !(2..=100_000).contains(&p.lookahead_blocks) {
            return bad(
                "planner.lookahead_blocks".into(),
                "must be between 2 and 100000".into(),
            );
        }
        if self.limits.max_line_bytes < 16 {
            return bad("limits.max_line_bytes".into(), "must be at least 16".into());
        }
        if self.limits.max_errors == 0 {
            return bad("limits.max_errors".into(), "must be at least 1".into());
        }
        if self.limits.max_executed_blocks == 0 {
            return bad(
                "limits.max_executed_blocks".into(),
                "must be at least 1".into(),
            );
        }
        let max_tool = if self.kind == MachineKind::Lathe {
            99
        } else {
            9999
        };
        for (i, t) in self.tools.iter().enumerate() {
            let k = |f: &str| format!("tool[{i}].{f}");
            if !(1..=max_tool).contains(&t.number) {
                return bad(k("number"), format!("must be 1..{max_tool}"));
            }
            if self.tools[..i].iter().any(|o| o.number == t.number) {
                return bad(k("number"), format!("{} is in the table twice", t.number));
            }
            if !(t.radius_mm.is_finite() && (0.0..=1000.0).contains(&t.radius_mm)) {
                return bad(k("radius_mm"), "must be between 0 and 1000".into());
            }
            if t.tip > 9 {
                return bad(k("tip"), "must be a tool type 0..9".into());
            }
            for (f, v) in [("x_mm", t.x_mm), ("y_mm", t.y_mm), ("z_mm", t.z_mm)] {
                if !(v.is_finite() && v.abs() <= 10_000.0) {
                    return bad(k(f), "must be a length within ±10000 mm".into());
                }
            }
        }
        if let Some(mc8) = &self.constants.mc8 {
            let r = decode_mc8(mc8)
                .map_err(|e| MachineError(format!("machine file: key `constants.mc8`: {e}")))?;
            if self.axis(r.axis).is_none() {
                return bad(
                    "constants.mc8".into(),
                    format!(
                        "the runout axis {} is not on this machine",
                        ["X", "Y", "Z"][r.axis]
                    ),
                );
            }
        }
        if let Some(t) = self.spindle.as_ref().and_then(|s| s.encoder_timeout_ms) {
            if !(t.is_finite() && (1.0..=1000.0).contains(&t)) {
                return bad(
                    "spindle.encoder_timeout_ms".into(),
                    "must be between 1 and 1000".into(),
                );
            }
        }
        if let Some(d) = self.spindle.as_ref().and_then(|s| s.thread_phase_limit_deg) {
            if !(d.is_finite() && (0.1..=180.0).contains(&d)) {
                return bad(
                    "spindle.thread_phase_limit_deg".into(),
                    "must be between 0.1 and 180".into(),
                );
            }
        }
        if let Some(s) = &self.spindle {
            for (f, v, lo, hi) in [
                ("max_rpm", s.max_rpm, 1.0, 1.0e6),
                ("acceleration_rpm_s", s.acceleration_rpm_s, 1.0, 1.0e7),
            ] {
                if !(v.is_finite() && (lo..=hi).contains(&v)) {
                    return bad(
                        format!("spindle.{f}"),
                        format!("must be between {lo} and {hi} (got {})", shown(v)),
                    );
                }
            }
            if s.encoder_counts_per_rev < 4 {
                return bad(
                    "spindle.encoder_counts_per_rev".into(),
                    "must be at least 4".into(),
                );
            }
            if !(0.0..0.5).contains(&s.sim_ripple_fraction) {
                return bad(
                    "spindle.sim_ripple_fraction".into(),
                    "must be between 0 and 0.5".into(),
                );
            }
            if !(s.sim_ripple_hz.is_finite() && (0.0..=1000.0).contains(&s.sim_ripple_hz)) {
                return bad(
                    "spindle.sim_ripple_hz".into(),
                    "must be between 0 and 1000".into(),
                );
            }
            if !(s.sim_noise_rpm.is_finite() && (0.0..=s.max_rpm).contains(&s.sim_noise_rpm)) {
                return bad(
                    "spindle.sim_noise_rpm".into(),
                    format!("must be between 0 and max_rpm ({})", s.max_rpm),
                );
            }
        } else if self.kind == MachineKind::Lathe {
            return bad("spindle".into(), "a lathe needs a [spindle] table".into());
        }
        Ok(())
    }

    /// Interpolation period, s.
    pub fn dt(&self) -> f64 {
        1.0 / self.interpolation.rate_hz
    }

    /// The drives' setpoint delay, s (`interpolation.setpoint_delay_ms`).
    pub fn setpoint_delay_s(&self) -> f64 {
        self.interpolation.setpoint_delay_ms * 1e-3
    }

    /// How long each axis's servo trails its setpoints at constant speed,
    /// s, per machine coordinate (absent axes 0): the following error of a
    /// P loop with velocity feed-forward is (1 − ff)·v/kp, i.e. a time lag
    /// of (1 − ff)/kp whatever the speed (0 with full feed-forward).
    pub fn servo_lag_s(&self) -> V3 {
        V3::from_fn(|i, _| {
            self.axis(i).map_or(0.0, |a| {
                ((1.0 - a.servo_feed_forward) / a.servo_kp).max(0.0)
            })
        })
    }

    /// How far each axis's servo trails its setpoints under acceleration,
    /// beyond [`servo_lag_s`](Self::servo_lag_s), s² (per machine
    /// coordinate, absent axes 0): a P loop with velocity feed-forward
    /// `ff` and a velocity loop of time constant τ, commanded `L` =
    /// (1 − ff)/kp ahead, stands `a·((τ − L)/kp + L²/2)` behind at a
    /// constant acceleration `a` (τ/kp with full feed-forward; τ is the lag
    /// the acceleration feed-forward leaves, (1 − aff)·τ). G33 adds
    /// it times the lead axis's acceleration (weighted by
    /// `interpolation.thread_accel_lead`), so the tool stays on the
    /// thread line while the spindle's speed changes.
    pub fn servo_accel_lag_s2(&self) -> V3 {
        V3::from_fn(|i, _| {
            self.axis(i).map_or(0.0, |a| {
                let l = ((1.0 - a.servo_feed_forward) / a.servo_kp).max(0.0);
                let tau = a.servo_lag_s * (1.0 - a.servo_accel_feed_forward);
                ((tau - l) / a.servo_kp + 0.5 * l * l).max(0.0)
            })
        })
    }

    /// The largest normal acceleration the path planner gives a curve,
    /// mm/s², for `planner.contour_error_mm`: that distance over the
    /// largest lag per unit of acceleration of the axes' servo models
    /// (`∞` without it, or where no axis lags under acceleration).
    pub fn contour_accel(&self) -> f64 {
        let lag = self.servo_accel_lag_s2().max();
        match self.planner.contour_error_mm {
            Some(e) if lag > 0.0 => e / lag,
            _ => f64::INFINITY,
        }
    }

    /// The configured axis for machine coordinate index 0..3 (X, Y, Z).
    pub fn axis(&self, idx: usize) -> Option<&AxisConfig> {
        self.axes.iter().find(|a| axis_index(&a.name) == Some(idx))
    }

    /// Machine coordinate index (0 = X) of each joint, in joint order.
    pub fn joint_indices(&self) -> Vec<usize> {
        self.axes
            .iter()
            .filter_map(|a| axis_index(&a.name))
            .collect()
    }

    /// Per-coordinate velocity limits, mm/s (absent axes: infinite; they
    /// never move).
    pub fn vmax(&self) -> V3 {
        V3::from_fn(|i, _| self.axis(i).map_or(f64::INFINITY, |a| a.max_velocity_mm_s))
    }

    /// Length of the path filter that limits the tangential jerk, in
    /// samples (1: no filter; see [`crate::jerk`]). A moving average over M
    /// samples of the profile's path length turns the planner's
    /// acceleration-limited speed into a jerk-limited one: the filtered
    /// sampled jerk is (a[k] − a[k−M]) / (M·dt), at most 2·a_max/(M·dt), so
    /// M = ⌈2·a_max / (γ·j_max·dt)⌉ over the axes with a jerk limit, γ =
    /// [`crate::shares::S_FILTER_SHARE`].
    pub fn smoothing_samples(&self) -> usize {
        (self.smoothing_samples_f() as usize).clamp(1, MAX_SMOOTHING_SAMPLES)
    }

    fn smoothing_samples_f(&self) -> f64 {
        self.average_samples_f(crate::shares::S_FILTER_SHARE)
    }

    /// ⌈2·a_max / (share·j_max·dt)⌉ over the axes with a jerk limit (1
    /// without): the samples a moving average needs to keep the sampled
    /// jerk of an acceleration-limited profile within `share` of the
    /// limit.
    fn average_samples_f(&self, share: f64) -> f64 {
        let dt = self.dt();
        self.axes
            .iter()
            .filter_map(|a| {
                let j = a.max_jerk_mm_s3? * share;
                Some((2.0 * a.max_acceleration_mm_s2 / (j * dt) - 1e-9).ceil())
            })
            .fold(1.0, f64::max)
    }

    /// The least jerk limit of the axes, mm/s³ (None: none has one).
    pub fn jerk_limit(&self) -> Option<f64> {
        self.axes
            .iter()
            .filter_map(|a| a.max_jerk_mm_s3)
            .reduce(f64::min)
    }

    /// The jerk budget under the default path tolerance
    /// ([`JerkBudget::for_tolerance`]; a program's G64 P or G61 changes
    /// it): where one moving average of the XYZ setpoints keeps the path
    /// within the XYZ filter's share of that tolerance (high jerk:
    /// [`Machine::single_average_error_mm`], at most
    /// [`crate::shares::SINGLE_AVERAGE_ERROR_MM`]), that filter alone
    /// ([`JerkBudget::single_average`]); else the path filter, the XYZ
    /// filter and the caps.
    pub fn jerk_budget(&self) -> JerkBudget {
        let dt = self.dt();
        let Some(j) = self.jerk_limit() else {
            return JerkBudget::new(dt, self.smoothing_samples(), None);
        };
        let err = self.single_average_error_mm();
        let single = (err <= crate::shares::SINGLE_AVERAGE_ERROR_MM)
            .then(|| (self.single_average_samples(), err));
        JerkBudget::for_machine(
            dt,
            self.smoothing_samples(),
            Some(j),
            single,
            self.planner.path_tolerance_mm,
        )
    }

    /// Length of the single XYZ moving average that limits jerk on its
    /// own, in samples (1: none): the filtered sampled jerk is
    /// (a[k] − a[k−M]) / (M·dt), at most 2·a_max/(M·dt), so M =
    /// ⌈2·a_max / (j_max·dt)⌉ over the axes with a jerk limit.
    pub fn single_average_samples(&self) -> usize {
        (self.average_samples_f(1.0) as usize).clamp(1, MAX_SMOOTHING_SAMPLES)
    }

    /// Largest distance, mm, by which the single XYZ moving average of
    /// [`Machine::single_average_samples`] moves a setpoint off the
    /// programmed path. The filtered point is the mean of the last M raw
    /// points, which lie on a piece of path (M − 1)·v·dt long, so it is no
    /// further from the path than that piece's chord: on an arc of radius
    /// r its sagitta, (M−1)²·dt²·v²/(8r) ≤ (M−1)²·dt²·a_c/8 with a_c the
    /// centripetal acceleration (the planner keeps it under
    /// `shares::ARC_NORMAL_MAX`·a_max). A nearly tangent junction, whose
    /// velocity jump is at most `shares::KINK_SHARE`·a_max·dt, is cut by
    /// at most (M−1)·dt·Δv/4. Straight lines are not moved at all.
    pub fn single_average_error_mm(&self) -> f64 {
        let m = self.single_average_samples() as f64;
        if m <= 1.0 {
            return 0.0;
        }
        let dt = self.dt();
        let a = self.max_acceleration();
        let w = (m - 1.0) * dt;
        let arc = w * w * crate::shares::ARC_NORMAL_MAX * a / 8.0;
        let kink = w * crate::shares::KINK_SHARE * a * dt / 4.0;
        arc + kink
    }

    /// The largest acceleration limit of any axis, mm/s².
    fn max_acceleration(&self) -> f64 {
        self.axes
            .iter()
            .map(|a| a.max_acceleration_mm_s2)
            .fold(0.0, f64::max)
    }

    /// The lowest jerk limit the filter allows (for the error message).
    fn min_jerk(&self) -> f64 {
        let a = self.max_acceleration();
        2.0 * a / (MAX_SMOOTHING_SAMPLES as f64 * self.dt() * crate::shares::S_FILTER_SHARE)
    }

    /// Largest distance, mm, by which the jerk filters move a setpoint off
    /// the programmed path under the machine's default path tolerance: the
    /// path filter not at all (the setpoint is the path at a filtered path
    /// length), the XYZ filter by at most [`JerkBudget::error_mm`] (the
    /// planner caps the normal acceleration for it, or the single average
    /// runs only where its bound fits): 1 µm under G61, at most half of P
    /// under a larger P. Blends keep within the tolerance less this.
    pub fn smoothing_error_mm(&self) -> f64 {
        self.jerk_budget().error_mm()
    }

    /// Per-coordinate acceleration limits, mm/s².
    pub fn amax(&self) -> V3 {
        V3::from_fn(|i, _| {
            self.axis(i)
                .map_or(f64::INFINITY, |a| a.max_acceleration_mm_s2)
        })
    }

    /// Whether the path planner plans this machine's moves (`[planner]
    /// method`; under `"auto"`, whether an axis's jerk limit is under
    /// `AUTO_PATH_BELOW_MM_S3`).
    pub fn plans_path(&self) -> bool {
        match self.planner.method {
            PlanMethod::Path => true,
            PlanMethod::Filters => false,
            PlanMethod::Auto => self.jmax().iter().any(|j| *j < AUTO_PATH_BELOW_MM_S3),
        }
    }

    /// Per-coordinate jerk limits, mm/s³ (infinite: none).
    pub fn jmax(&self) -> V3 {
        V3::from_fn(|i, _| {
            self.axis(i)
                .and_then(|a| a.max_jerk_mm_s3)
                .unwrap_or(f64::INFINITY)
        })
    }

    /// Start position of the machine coordinates.
    pub fn home(&self) -> V3 {
        V3::from_fn(|i, _| self.axis(i).map_or(0.0, |a| a.home_mm))
    }

    /// The tool table entry `number` (lathe: offset number).
    pub fn tool(&self, number: u32) -> Option<&ToolConfig> {
        self.tools.iter().find(|t| t.number == number)
    }

    /// The thread runout of machine constant 8, if set (validated at load).
    pub fn runout(&self) -> Option<Runout> {
        self.constants
            .mc8
            .as_deref()
            .and_then(|t| decode_mc8(t).ok())
    }

    /// The same machine starting where its joints stand now (`joints_mm`
    /// in joint order, slide positions): a job runs, and is checked, from
    /// the last setpoint rather than from home.
    pub fn starting_at(&self, joints_mm: &[f64]) -> Machine {
        let mut m = self.clone();
        for (a, &p) in m.axes.iter_mut().zip(joints_mm) {
            a.home_mm = p;
        }
        m
    }

    /// X programmed as a diameter.
    pub fn diameter_mode(&self) -> bool {
        self.axis(0).is_some_and(|a| a.diameter_mode)
    }
}

/// 0 for "x", 1 for "y", 2 for "z".
pub fn axis_index(name: &str) -> Option<usize> {
    match name {
        "x" | "X" => Some(0),
        "y" | "Y" => Some(1),
        "z" | "Z" => Some(2),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundled_files_load() {
        let m = Machine::builtin_mill();
        assert_eq!(m.joint_indices(), vec![0, 1, 2]);
        assert_eq!(m.dialect, Dialect::Cnc836);
        let l = Machine::builtin_lathe();
        assert_eq!(l.joint_indices(), vec![0, 2]);
        assert!(l.diameter_mode());
        assert_eq!(
            l.spindle.as_ref().map(|s| s.encoder_counts_per_rev),
            Some(4096)
        );
    }

    fn with(replace: &str, by: &str) -> Result<Machine, MachineError> {
        let t = include_str!("../../config/mill.toml");
        assert!(t.contains(replace), "{replace}");
        Machine::from_toml(&t.replacen(replace, by, 1))
    }

    #[test]
    fn starting_at_moves_home_to_the_joint_positions() {
        let l = Machine::builtin_lathe();
        let m = l.starting_at(&[12.5, -30.0]);
        assert_eq!(m.home(), V3::new(12.5, 0.0, -30.0));
        assert_eq!(
            l.home(),
            V3::new(100.0, 0.0, 20.0),
            "the original is untouched"
        );
        assert_eq!(m.axes[0].min_mm, l.axes[0].min_mm);
    }

    #[test]
    fn machine_constant_8() {
        assert_eq!(
            decode_mc8("+00112345"),
            Ok(Runout {
                axis: 0,
                angle_deg: 12.345
            })
        );
        assert_eq!(
            decode_mc8("-00330000"),
            Ok(Runout {
                axis: 2,
                angle_deg: -30.0
            })
        );
        assert_eq!(
            decode_mc8("360000"),
            Ok(Runout {
                axis: 2,
                angle_deg: 60.0
            })
        );
        assert!(decode_mc8("+00160001")
            .unwrap_err()
            .contains("60.001 degrees is over 60 degrees"));
        assert!(decode_mc8("+00412345")
            .unwrap_err()
            .contains("decade 6 must name the runout axis"));
        assert!(decode_mc8("12.5")
            .unwrap_err()
            .contains("not a signed eight-decade number"));
        assert!(decode_mc8("+123456789").is_err());
        let l = Machine::builtin_lathe();
        assert_eq!(
            l.runout(),
            Some(Runout {
                axis: 0,
                angle_deg: 30.0
            })
        );
        let t = include_str!("../../config/lathe.toml")
            .replace("mc8 = \"+00130000\"", "mc8 = \"+00170000\"");
        let e = Machine::from_toml(&t).unwrap_err();
        assert_eq!(e.0, "machine file: key `constants.mc8`: \"+00170000\": the runout angle 70.000 degrees is over 60 degrees");
        let t = include_str!("../../config/lathe.toml")
            .replace("mc8 = \"+00130000\"", "mc8 = \"+00230000\"");
        assert!(Machine::from_toml(&t)
            .unwrap_err()
            .0
            .contains("the runout axis Y is not on this machine"));
    }

    #[test]
    fn bad_files_name_the_key() {
        let e = with("max_velocity_mm_s = 250.0", "max_velocity_mm_s = -1.0").unwrap_err();
        assert_eq!(
            e.0,
            "machine file: key `axis[0].max_velocity_mm_s`: must be between 0.01 and 100000 (got -1)"
        );
        let e = with("max_velocity_mm_s = 250.0", "max_velocty_mm_s = 250.0").unwrap_err();
        assert!(e.0.contains("unknown field `max_velocty_mm_s`"), "{}", e.0);
        let e = with("dialect = \"cnc836\"", "dialect = \"fanuc\"").unwrap_err();
        assert!(e.0.contains("unknown variant `fanuc`"), "{}", e.0);
        let e = with("rate_hz = 1000.0", "rate_hz = 1.0").unwrap_err();
        assert!(e.0.contains("key `interpolation.rate_hz`"), "{}", e.0);
        let e = with("name = \"y\"", "name = \"x\"").unwrap_err();
        assert!(e.0.contains("axis[1].name"), "{}", e.0);
        let e = with("max_mm = 500.0", "max_mm = -50.0").unwrap_err();
        assert!(e.0.contains("axis[0].max_mm"), "{}", e.0);
        let e = with("thread_accel_lead = 1.0", "thread_accel_lead = 1.5").unwrap_err();
        assert_eq!(
            e.0,
            "machine file: key `interpolation.thread_accel_lead`: must be between 0 and 1 (got 1.5)"
        );
        let e = with(
            "lookahead_blocks = 200",
            "lookahead_blocks = 200\nmethod = \"paths\"",
        )
        .unwrap_err();
        assert!(e.0.contains("unknown variant `paths`"), "{}", e.0);
        assert!(e.0.contains("method = \"paths\""), "{}", e.0);
        let m = with(
            "lookahead_blocks = 200",
            "lookahead_blocks = 200\nmethod = \"path\"",
        )
        .unwrap();
        assert!(m.plans_path());
        // "auto" (no method given): the filters at the bundled 200 m/s³,
        // the path planner under it; "filters" keeps them at any jerk
        let mut m = Machine::builtin_mill();
        assert_eq!(m.planner.method, PlanMethod::Auto);
        assert!(!m.plans_path());
        m.axes[2].max_jerk_mm_s3 = Some(1.99e5);
        assert!(m.plans_path());
        m.planner.method = PlanMethod::Filters;
        assert!(!m.plans_path());
        let m = with(
            "lookahead_blocks = 200",
            "lookahead_blocks = 200\nmethod = \"auto\"",
        )
        .unwrap();
        assert_eq!(m, Machine::builtin_mill());
        assert!(!Machine::builtin_lathe().plans_path());
    }

    #[test]
    fn the_servo_lag_under_acceleration_follows_the_servo_model() {
        let mut m = Machine::builtin_lathe();
        assert_eq!(m.interpolation.thread_accel_lead, 1.0);
        // full feed-forward: τ/kp = 0.002/60
        assert!((m.servo_accel_lag_s2()[2] - 0.002 / 60.0).abs() < 1e-15);
        // 80 %: L = 0.2/60; (τ − L)/kp + L²/2 < 0, so none
        m.axes[1].servo_feed_forward = 0.8;
        assert_eq!(m.servo_accel_lag_s2()[2], 0.0);
        // 95 %: L = 0.05/60 = 0.833 ms
        m.axes[1].servo_feed_forward = 0.95;
        let l = 0.05 / 60.0;
        let want = (0.002 - l) / 60.0 + 0.5 * l * l;
        assert!((m.servo_accel_lag_s2()[2] - want).abs() < 1e-15);
        // acceleration feed-forward takes its share of τ out: half of it
        // with full velocity feed-forward leaves τ/2/kp, all of it none
        m.axes[1].servo_feed_forward = 1.0;
        m.axes[1].servo_accel_feed_forward = 0.5;
        assert!((m.servo_accel_lag_s2()[2] - 0.001 / 60.0).abs() < 1e-15);
        m.axes[1].servo_accel_feed_forward = 1.0;
        assert_eq!(m.servo_accel_lag_s2()[2], 0.0);
        // a machine file's value out of 0..1 is refused, naming the key
        let e = with(
            "max_velocity_mm_s = 250.0",
            "servo_accel_feed_forward = 1.5\nmax_velocity_mm_s = 250.0",
        )
        .unwrap_err();
        assert!(
            e.0.contains("servo_accel_feed_forward`: must be between 0 and 1"),
            "{}",
            e.0
        );
    }
}
