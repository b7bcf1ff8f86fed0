//! `cnc_core`: the pure, deterministic heart of the controller.
//!
//! Program text flows through a pipeline with no I/O and no clocks:
//!
//! ```text
//! ProgramSource -> parse (per dialect, with spans) -> interp (modal state)
//!   -> Event stream (canonical motion commands) -> plan (look-ahead, limits)
//!   -> exec (fixed-rate samples, t = k * dt)
//! ```
//!
//! [`check::check`] runs the same pipeline without sampling and reports every
//! error, the estimated cycle time and the bounding box. [`exec::Executor`]
//! produces setpoint samples. Both read the program line by line through a
//! [`source::ProgramSource`], so memory does not grow with program length.

pub mod blend;
pub mod canon;
pub mod check;
pub mod comp;
pub mod diag;
pub mod dialect;
pub mod exec;
pub mod geom;
pub mod interp;
pub mod jerk;
pub mod limits;
pub mod machine;
pub mod parse;
pub mod path_run;
pub mod path_smooth;
pub mod path_speed;
pub mod pipeline;
pub mod plan;
pub mod profile;
pub mod shares;
pub mod source;
pub mod thread;
pub mod timeline;
pub mod tracker;
pub mod travel;

pub use check::{check, CheckReport};
pub use diag::Diagnostic;
pub use dialect::Dialect;
pub use machine::Machine;

pub use geom::V3;

/// One step of the xorshift64 generator the unit tests draw their
/// pseudo-random cases from (deterministic, no dependency): advances `x`
/// and returns it.
#[cfg(test)]
pub(crate) fn xorshift64(x: &mut u64) -> u64 {
    *x ^= *x << 13;
    *x ^= *x >> 7;
    *x ^= *x << 17;
    *x
}
