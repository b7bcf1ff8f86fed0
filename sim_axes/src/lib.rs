//! Deterministic simulation of a machine tool's axes and spindle.
//!
//! Used by the offline `cnc simulate` command and by the simulator node. The crate does no
//! I/O, reads no clocks and has no global state; stepping never allocates. (It uses the
//! core's machine files and, for the node's `/diagnostics`, the message types.)
//! Identical inputs (and spindle seeds) give bit-identical results on the same platform
//! (the model uses `exp` and `sin` from the platform's math library).
//!
//! # Units
//! Lengths mm, velocities mm/s, accelerations mm/s², time s, spindle speed rpm (signed,
//! + = M03 / clockwise), angles rad, encoder velocity rad/s.
//!
//! # Axis model
//! Each servo cycle ([`Axis::step`]) with setpoint `s_k` (where the axis should be at the end
//! of the cycle), previous setpoint `s_{k-1}`, actual position `p` and velocity `v`:
//!
//! ```text
//! v_cmd = ff * (s_k - s_{k-1}) / dt  +  kp * (s_{k-1} - p)     held over the cycle
//! v(t)  = v_cmd + (v - v_cmd) * exp(-t / lag)                  the velocity loop, a lag
//! p'    = p + ∫ v(t) dt over the cycle,  v' = v(dt)
//! following_error = s_k - p'
//! ```
//!
//! The position loop is sampled, the velocity loop is not: the axis moves during the cycle
//! as a first-order lag does, so its behaviour does not depend on the cycle time beyond the
//! position loop's own sampling. Where the drive's limits cut in (`|v' - v| > a_max*dt` or
//! `|v'| > v_max`) the velocity ramps at the limit instead. Acceleration feed-forward `aff`
//! passes that share of the feed-forward term without the lag ([`Axis`]).
//!
//! The P-term compares the position with the *previous* setpoint, i.e. with where the axis
//! should be at the start of the cycle, while the feed-forward term supplies the motion
//! during the cycle (the usual setpoint delay of drives with feed-forward). With the undelayed
//! error `kp * (s_k - p)` feed-forward and P-term would count the same increment twice and a
//! ramp would run one cycle *ahead* (error `-v*dt`) instead of being tracked exactly.
//!
//! Resulting steady following errors (exact in the model, at every `dt`):
//! * constant velocity `v`: `(1 - ff) * v / kp` — independent of the lag, so 0 with full
//!   feed-forward (`ff = 1`), `v / kp` without (the classic Kv relation);
//! * constant acceleration `a` with `ff = 1`: `(1 - aff) * a * lag / kp`; this is where the
//!   velocity lag shows;
//! * a setpoint step without feed-forward decays as `(1 - kp*dt)^n` ≈ `exp(-kp*t)`.
//!
//! The drive limits are hard: the velocity never exceeds `max_velocity` and never changes by
//! more than `max_acceleration * dt` per cycle. Setpoints that demand more (steps, a stiff
//! loop approaching a target faster than it can brake, i.e. `kp * v > max_acceleration`)
//! produce overshoot, as on a real machine; feed setpoints from a planner that respects the
//! limits. The loop is stable for `dt` 0.1–2 ms and `kp` up to 200 1/s.
//!
//! # Spindle model
//! See [`Spindle`]: ramped nominal speed, sinusoidal ripple, seeded random noise, trapezoidal
//! angle integration, and a quadrature encoder with an index mark at angle 0 (mod 2π) whose
//! measured velocity is the count difference over the last [`ENCODER_VELOCITY_WINDOW_S`].
//!
//! # Example
//! ```
//! use sim_axes::{Axis, AxisParams, MachineModel, Spindle, SpindleParams};
//!
//! let axes = vec![Axis::new(AxisParams::default(), 0.0); 3];
//! let spindle = Spindle::new(SpindleParams { noise_rpm: 1.0, seed: 42, ..Default::default() });
//! let mut m = MachineModel::new(axes, Some(spindle));
//! let dt = 0.001;
//! for k in 1..=1000 {
//!     let x = 5.0 * k as f64 * dt; // 5 mm/s ramp on X
//!     m.step(&[x, 0.0, 0.0], 1000.0, dt);
//! }
//! assert_eq!(m.time(), 1000.0 * dt);
//! assert!(m.axes[0].following_error().abs() < 1e-3);
//! let enc = m.spindle.as_ref().unwrap().encoder();
//! assert!(enc.index_count > 0);
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod axis;
pub mod clocked;
pub mod diagnostics;
pub mod machine;
pub mod model;
pub mod rng;
pub mod spindle;

pub use axis::{Axis, AxisParams};
pub use clocked::SetpointQueue;
pub use model::MachineModel;
pub use rng::SplitMix64;
pub use spindle::{
    EncoderReading, Spindle, SpindleParams, ENCODER_HISTORY_LEN, ENCODER_VELOCITY_WINDOW_S,
};
