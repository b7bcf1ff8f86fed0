//! The model of a machine file's axes and spindle.

use crate::{Axis, AxisParams, MachineModel, Spindle, SpindleParams};
use cnc_core::Machine;

/// Drive headroom of the simulated axes over the planner's limits.
pub const DRIVE_HEADROOM: f64 = 1.25;

/// The axis and spindle model for a machine file, axes in joint order.
/// `seed` seeds the spindle noise.
pub fn model_for(machine: &Machine, seed: u64) -> MachineModel {
    let axes = machine
        .axes
        .iter()
        .map(|a| {
            Axis::new(
                AxisParams {
                    max_velocity: a.max_velocity_mm_s * DRIVE_HEADROOM,
                    max_acceleration: a.max_acceleration_mm_s2 * DRIVE_HEADROOM,
                    kp: a.servo_kp,
                    velocity_feed_forward: a.servo_feed_forward,
                    velocity_lag: a.servo_lag_s,
                    acceleration_feed_forward: a.servo_accel_feed_forward,
                },
                a.home_mm,
            )
        })
        .collect();
    let spindle = machine.spindle.as_ref().map(|s| {
        Spindle::new(SpindleParams {
            max_rpm: s.max_rpm,
            acceleration_rpm_per_s: s.acceleration_rpm_s,
            encoder_counts_per_rev: s.encoder_counts_per_rev,
            ripple_fraction: s.sim_ripple_fraction,
            ripple_hz: s.sim_ripple_hz,
            noise_rpm: s.sim_noise_rpm,
            seed,
        })
    });
    MachineModel::new(axes, spindle)
}

/// The largest machine file read, bytes (the bundled ones are about 3 KiB).
pub const MAX_MACHINE_FILE_BYTES: u64 = 1 << 20;

/// Loads a machine: a path to a TOML file, or the name of a bundled one
/// (`mill`, `lathe`) when no such file exists.
pub fn load_machine(arg: &str) -> Result<Machine, String> {
    let p = std::path::Path::new(arg);
    if p.exists() {
        // (not a device, a pipe or a directory: /dev/zero would be read
        // until the memory runs out, a FIFO would wait for a writer)
        let meta = std::fs::metadata(p).map_err(|e| format!("{arg}: {e}"))?;
        if !meta.is_file() {
            return Err(format!("{arg}: not a regular file"));
        }
        if meta.len() > MAX_MACHINE_FILE_BYTES {
            return Err(format!(
                "{arg}: {} bytes; a machine file is at most {MAX_MACHINE_FILE_BYTES} bytes",
                meta.len()
            ));
        }
        let text = std::fs::read_to_string(p).map_err(|e| format!("{arg}: {e}"))?;
        return Machine::from_toml(&text).map_err(|e| format!("{arg}: {e}"));
    }
    match arg {
        "mill" => Ok(Machine::builtin_mill()),
        "lathe" => Ok(Machine::builtin_lathe()),
        _ => Err(format!(
            "{arg}: no such machine file (bundled machines: mill, lathe)"
        )),
    }
}
