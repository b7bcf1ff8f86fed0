//! The whole machine: a set of axes plus an optional spindle, stepped together.

pub use crate::axis::{Axis, AxisParams};
pub use crate::spindle::{EncoderReading, Spindle, SpindleParams};

/// A machine tool: axes (in the caller's order, e.g. X, Y, Z) and an optional spindle.
///
/// The fields are public so callers can inspect or reconfigure individual components; stepping
/// through [`MachineModel::step`] keeps everything (and the clock) in lock-step.
#[derive(Debug, Clone)]
pub struct MachineModel {
    /// The axes, in the order of the setpoints passed to [`step`](Self::step).
    pub axes: Vec<Axis>,
    /// The spindle, if the machine has one.
    pub spindle: Option<Spindle>,
    /// Total number of steps taken.
    steps: u64,
    /// Time at which the current run of equal `dt` started, s.
    segment_start_time: f64,
    /// Number of steps taken with `segment_dt` since `segment_start_time`.
    segment_steps: u64,
    /// The `dt` of the current run of equal steps, s.
    segment_dt: f64,
}

impl MachineModel {
    /// Creates a machine at time 0. The axes vector is the only allocation; stepping does not
    /// allocate.
    pub fn new(axes: Vec<Axis>, spindle: Option<Spindle>) -> Self {
        Self {
            axes,
            spindle,
            steps: 0,
            segment_start_time: 0.0,
            segment_steps: 0,
            segment_dt: 0.0,
        }
    }

    /// Simulates one cycle of `dt` seconds.
    ///
    /// `setpoints_mm` are the commanded positions (mm) for this cycle, in the order of
    /// [`axes`](Self::axes); axes without a setpoint (slice too short) hold their last
    /// setpoint, surplus setpoints are ignored. `spindle_cmd_rpm` is the signed spindle command
    /// (rpm, + = M03), ignored without a spindle. A `dt` that is not finite and > 0 makes the
    /// call a no-op (the clock does not advance either).
    pub fn step(&mut self, setpoints_mm: &[f64], spindle_cmd_rpm: f64, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        for (i, axis) in self.axes.iter_mut().enumerate() {
            let sp = setpoints_mm
                .get(i)
                .copied()
                .unwrap_or_else(|| axis.setpoint());
            axis.step(sp, dt);
        }
        if let Some(spindle) = &mut self.spindle {
            spindle.set_command_rpm(spindle_cmd_rpm);
            spindle.step(dt);
        }
        if dt.to_bits() != self.segment_dt.to_bits() {
            self.segment_start_time = self.time();
            self.segment_steps = 0;
            self.segment_dt = dt;
        }
        self.segment_steps += 1;
        self.steps += 1;
    }

    /// Simulated time, s. With a constant `dt` this is exactly `steps as f64 * dt` (no
    /// accumulation drift); when `dt` changes, the time of the change is added as an offset.
    pub fn time(&self) -> f64 {
        self.segment_start_time + self.segment_steps as f64 * self.segment_dt
    }

    /// Number of steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Actual positions of all axes, mm, written into `out` (up to `out.len()` axes); returns
    /// the number written. Allocation-free helper for loggers.
    pub fn positions_into(&self, out: &mut [f64]) -> usize {
        let n = out.len().min(self.axes.len());
        for (o, a) in out.iter_mut().zip(&self.axes) {
            *o = a.position();
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(seed: u64) -> MachineModel {
        let axes = vec![
            Axis::new(AxisParams::default(), 0.0),
            Axis::new(
                AxisParams {
                    kp: 40.0,
                    ..AxisParams::default()
                },
                5.0,
            ),
        ];
        let spindle = Spindle::new(SpindleParams {
            ripple_fraction: 0.01,
            noise_rpm: 2.0,
            seed,
            ..SpindleParams::default()
        });
        MachineModel::new(axes, Some(spindle))
    }

    #[test]
    fn time_is_steps_times_dt_without_drift() {
        let mut m = machine(1);
        for k in 1..=100_000u64 {
            m.step(&[0.0, 5.0], 0.0, 0.001);
            assert_eq!(m.time(), k as f64 * 0.001);
        }
        assert_eq!(m.steps(), 100_000);
        // Naive accumulation would drift: demonstrate that this differs.
        let naive = (0..100_000).fold(0.0, |t, _| t + 0.001);
        assert_ne!(naive, m.time());
        // Changing dt continues from the current time.
        m.step(&[0.0, 5.0], 0.0, 0.0005);
        m.step(&[0.0, 5.0], 0.0, 0.0005);
        assert_eq!(m.time(), 100_000.0 * 0.001 + 2.0 * 0.0005);
        m.step(&[0.0, 5.0], 0.0, 0.0);
        assert_eq!(m.steps(), 100_002);
    }

    #[test]
    fn steps_axes_and_spindle_and_holds_missing_setpoints() {
        let mut m = machine(3);
        for k in 1..=1000 {
            let t = k as f64 * 0.001;
            m.step(&[10.0 * t], 1200.0, 0.001);
        }
        assert!((m.axes[0].position() - 10.0).abs() < 1e-6);
        assert!(m.axes[0].following_error().abs() < 1e-9);
        assert_eq!(m.axes[1].position(), 5.0); // held its initial setpoint
        let sp = m.spindle.as_ref().unwrap();
        assert_eq!(sp.command_rpm(), 1200.0);
        assert_eq!(sp.nominal_rpm(), 1200.0); // 5000 rpm/s ramp: 0.24 s
        assert!((sp.encoder().velocity_rpm() - 1200.0).abs() < 40.0);
        let mut pos = [0.0; 3];
        assert_eq!(m.positions_into(&mut pos), 2);
        assert_eq!(pos[1], 5.0);
    }

    #[test]
    fn whole_machine_is_deterministic() {
        let run = |seed| {
            let mut m = machine(seed);
            let mut trace = Vec::new();
            for k in 0..2000 {
                let t = k as f64 * 0.0005;
                m.step(&[(7.0 * t).sin() * 20.0, 5.0 - 30.0 * t], 3000.0, 0.0005);
                let s = m.spindle.as_ref().unwrap();
                trace.push((
                    m.axes[0].position().to_bits(),
                    m.axes[1].velocity().to_bits(),
                    s.angle_rad().to_bits(),
                    s.encoder().count,
                ));
            }
            trace
        };
        assert_eq!(run(9), run(9));
        assert_ne!(run(9), run(10));
    }
}
