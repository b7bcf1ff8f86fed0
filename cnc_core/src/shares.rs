//! How the axes' limits are shared out between the concerns that spend
//! them: the planner's moves and junctions, arcs' centripetal part, and
//! spindle-synchronized motion. A leaf: every module that sizes motion
//! against the machine's limits reads these numbers here.

/// Share of each axis's acceleration reserved for velocity jumps at
/// nearly tangent junctions (within one sample).
pub const KINK_SHARE: f64 = 0.15;
/// Share of the acceleration used by a move next to a kink.
pub const LINE_SHARE: f64 = 1.0 - KINK_SHARE;
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
/// runout use (the rest absorbs the spindle's speed ripple).
pub const THREAD_SHARE: f64 = 0.8;
