//! How the axes' limits are shared out between the concerns that spend
//! them: the planner's moves and junctions, arcs' centripetal part, and
//! spindle-synchronized motion. A leaf: every module that sizes motion
//! against the machine's limits reads these numbers here.

/// Share of each axis's acceleration reserved for velocity jumps at
/// nearly tangent junctions (within one sample).
pub const KINK_SHARE: f64 = 0.15;
/// Share of the acceleration used by a move next to a kink.
pub const LINE_SHARE: f64 = 1.0 - KINK_SHARE;
/// Share reserved at a fine kink: a junction whose velocity jump within
/// one sample is at most this share of each axis's acceleration even at
/// the fastest path speed (CAM-rounded helix blends meeting at slopes
/// 10⁻⁴ apart, a line meeting an arc a hair off tangent). The moves next
/// to it keep [`FINE_SHARE`] instead of [`LINE_SHARE`].
pub const FINE_KINK_SHARE: f64 = 0.02;
/// Share of the acceleration used by a move next to a fine kink (and no
/// kink).
pub const FINE_SHARE: f64 = 1.0 - FINE_KINK_SHARE;
/// A junction counts as smooth if its velocity jump at the moves' speed
/// cap is at most this share of each axis's acceleration (a rounding-level
/// direction change, as between an arc and its tangent line).
pub const SMOOTH_SHARE: f64 = 1e-9;
/// Largest share of an arc's acceleration spent on the centripetal part
/// (cos 30°, as LinuxCNC); the tangential part gets what is left of the
/// move's share, √(S² − n²) for share S, at least half of it.
pub const ARC_NORMAL_MAX: f64 = 0.866_025_403_784_438_6;

/// The spindle may turn this much faster than S while a run-in or a
/// deceleration runs; they are planned for it.
pub const SPEED_MARGIN: f64 = 1.05;
/// Share of an axis's acceleration a thread's run-in, deceleration and
/// runout use (the rest absorbs the spindle's speed ripple), and of its
/// jerk at most ([`TRACKER_JERK_COUNTS`]).
pub const THREAD_SHARE: f64 = 0.8;
/// The spindle tracker's predicted angle moves by up to this many counts
/// in its third difference from one cycle to the next on a steady spindle
/// (its quantization; `tracker`'s test
/// `a_steady_spindle_s_prediction_changes_smoothly`, 0.30 measured). A
/// thread's setpoints carry it as jerk, pitch·0.35/(counts·dt³): 128
/// m/s³ on a 1.5 mm pitch at 4096 counts and 1 kHz. Where a run-in or a
/// deceleration adds its own jerk, the two add up, so theirs is what the
/// axis's limit leaves beside it (at most [`THREAD_SHARE`] of it, at
/// least [`THREAD_JERK_FLOOR`]; `thread::run_in_jerk`). With
/// [`THREAD_SHARE`] alone the run-in's end made the bundled lathe's Z 234
/// m/s³ over its 200 where a few readings were lost there.
pub const TRACKER_JERK_COUNTS: f64 = 0.35;
/// The least share of an axis's jerk a run-in or deceleration uses where
/// the encoder's noise leaves less (a coarse encoder, a fine rate: the
/// noise alone then exceeds the limit, README "Thread cutting").
pub const THREAD_JERK_FLOOR: f64 = 0.25;

/// Jerk (issue 17, [`crate::jerk`]): share of each axis's jerk limit the
/// path-parameter filter (the S-curve of the speed profile) uses.
pub const S_FILTER_SHARE: f64 = 0.5;
/// Share of the jerk limit for changes of the normal acceleration (arcs'
/// centripetal acceleration coming and going at curvature steps, the
/// velocity jumps of kinks): the XYZ filter spreads them over its window.
pub const NORMAL_JERK_SHARE: f64 = 0.4;
/// What is left, for the turn of the tangential acceleration on arcs.
pub const TURN_JERK_SHARE: f64 = 1.0 - S_FILTER_SHARE - NORMAL_JERK_SHARE;
/// Jerk: share of the jerk limit the own path filter of an arc run from
/// rest to rest gives its tangential jerk; the rest is for the normal
/// acceleration's growth and turn, 3·v·a·κ + v³·κ²
/// ([`crate::jerk::JerkBudget::own_arc_cap`]).
pub const OWN_ARC_TANGENT_SHARE: f64 = 0.5;
/// Largest distance, mm, by which the XYZ filter may move a setpoint off
/// a curve (programmed arcs and blend arcs) under G61, and the least it
/// may under G64 P: the planner caps the normal acceleration for it. Also
/// what a G61 path may deviate.
pub const XYZ_FILTER_ERROR_MM: f64 = 0.001;
/// Share of the path tolerance (G64 P) the XYZ filter may move a setpoint
/// off a curve ([`crate::jerk::JerkBudget::for_tolerance`]); the corner
/// blends keep within the rest. Half: on bench/motion's CAM program at 50
/// m/s³ and P 0.01 mm, 0.3, 0.4, 0.5, 0.6 and 0.7 of P gave 28.99,
/// 28.57, 28.31, 28.13 and 30.21 s (0.1: 31.81 s): more makes the blends
/// of fine polylines smaller than their kinks need.
pub const XYZ_FILTER_TOLERANCE_SHARE: f64 = 0.5;
/// Jerk: a machine whose single XYZ moving average (the design before the
/// path filter, [`crate::Machine::single_average_error_mm`]) keeps the
/// path within this many mm may run that filter alone, without the path
/// filter and the caps ([`crate::jerk::JerkBudget::single_average`]),
/// where the path tolerance allows its bound: under G64 P when it is
/// within [`XYZ_FILTER_TOLERANCE_SHARE`] of P, under G61 only when it is
/// within [`XYZ_FILTER_ERROR_MM`] (that bound at 1000 m/s³ is 2.17 µm on
/// the bundled mill's axes, M = 4, and 4.71 µm on the lathe's, M = 5:
/// they run the average under G64 P0.01 and the caps under G61; the
/// bundled machines' 200 m/s³ take the path filter). Blends shrink by
/// that bound, so G64 P keeps its tolerance either way.
pub const SINGLE_AVERAGE_ERROR_MM: f64 = 0.005;

/// The largest feed override, as a scale (200 %): a move runs at most
/// this many times its planned speed, and never over its `vlim`.
pub const MAX_OVERRIDE: f64 = 2.0;
