//! Spindle with speed ramp, speed ripple, random speed noise and a quadrature encoder with an
//! index (once-per-revolution) pulse.

use crate::rng::SplitMix64;
use std::f64::consts::TAU;

/// Time span over which [`EncoderReading::velocity`] is measured, s (10 ms).
///
/// The measured velocity is the encoder count difference over the most recent cycles whose
/// durations add up to at least this span (at most [`ENCODER_HISTORY_LEN`] cycles), so it lags
/// the true speed by about half of it (5 ms).
pub const ENCODER_VELOCITY_WINDOW_S: f64 = 0.01;

/// Number of past encoder samples kept in the fixed-size ring buffer used for the velocity
/// measurement. With cycles shorter than `ENCODER_VELOCITY_WINDOW_S / ENCODER_HISTORY_LEN`
/// (78 µs) the measurement window is shorter than [`ENCODER_VELOCITY_WINDOW_S`].
pub const ENCODER_HISTORY_LEN: usize = 128;

/// Parameters of the simulated spindle and its encoder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpindleParams {
    /// Maximum speed magnitude, rpm (> 0). Commands are clamped to ±`max_rpm`.
    pub max_rpm: f64,
    /// Ramp rate of the (nominal) speed towards the command, rpm/s (> 0). Never exceeded by
    /// the ramp itself; ripple and noise come on top.
    pub acceleration_rpm_per_s: f64,
    /// Quadrature encoder counts per revolution (4 × lines), e.g. 4096 (0 is treated as 1).
    pub encoder_counts_per_rev: u32,
    /// Relative amplitude of the sinusoidal speed ripple, dimensionless, e.g. 0.02 for ±2 %;
    /// 0 = none.
    pub ripple_fraction: f64,
    /// Ripple frequency, Hz.
    pub ripple_hz: f64,
    /// Amplitude (≈ standard deviation) of the random speed noise, rpm; 0 = none. A new,
    /// independent sample is drawn every cycle (bounded to about ±3.5 × this value).
    pub noise_rpm: f64,
    /// Seed of the noise generator; equal seeds give bit-identical runs.
    pub seed: u64,
}

impl Default for SpindleParams {
    /// 24 000 rpm, 5 000 rpm/s, 4096 counts/rev, no ripple (50 Hz if enabled), no noise,
    /// seed 0.
    fn default() -> Self {
        Self {
            max_rpm: 24_000.0,
            acceleration_rpm_per_s: 5_000.0,
            encoder_counts_per_rev: 4096,
            ripple_fraction: 0.0,
            ripple_hz: 50.0,
            noise_rpm: 0.0,
            seed: 0,
        }
    }
}

impl SpindleParams {
    /// Checks that the parameters are physically meaningful: finite, `max_rpm > 0`,
    /// `acceleration_rpm_per_s > 0`, `encoder_counts_per_rev > 0`, ripple fraction in
    /// 0..1, `ripple_hz >= 0`, `noise_rpm >= 0`. The model never panics on bad parameters.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.max_rpm.is_finite() && self.max_rpm > 0.0) {
            return Err("max_rpm must be finite and > 0 rpm");
        }
        if !(self.acceleration_rpm_per_s.is_finite() && self.acceleration_rpm_per_s > 0.0) {
            return Err("acceleration_rpm_per_s must be finite and > 0 rpm/s");
        }
        if self.encoder_counts_per_rev == 0 {
            return Err("encoder_counts_per_rev must be > 0");
        }
        if !(0.0..1.0).contains(&self.ripple_fraction) {
            return Err("ripple_fraction must be within 0..1");
        }
        if !(self.ripple_hz.is_finite() && self.ripple_hz >= 0.0) {
            return Err("ripple_hz must be finite and >= 0 Hz");
        }
        if !(self.noise_rpm.is_finite() && self.noise_rpm >= 0.0) {
            return Err("noise_rpm must be finite and >= 0 rpm");
        }
        Ok(())
    }
}

/// Snapshot of the simulated spindle encoder.
///
/// The index mark is at spindle angle 0 (mod 2π). Counts follow
/// `count = floor(angle / 2π * counts_per_rev)`, so the start angle 0 reads count 0 and lies
/// exactly on the mark; consequently the first index pulse comes after one full revolution
/// in + direction, but immediately when turning in − direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderReading {
    /// Quadrature count, signed, 0 at start: `floor(angle / 2π * counts_per_rev)`.
    pub count: i64,
    /// Counts per revolution (copied from the parameters).
    pub counts_per_rev: u32,
    /// Number of index pulses so far, i.e. crossings of a whole revolution `n·2π` in either
    /// direction (always increasing).
    pub index_count: i64,
    /// `count` value of the most recent index crossing, `n * counts_per_rev`; 0 while
    /// `index_count == 0`.
    pub count_at_index: i64,
    /// Measured angular velocity, rad/s, signed: count difference over the last
    /// [`ENCODER_VELOCITY_WINDOW_S`] (see there).
    pub velocity: f64,
}

impl EncoderReading {
    /// Spindle angle relative to the most recent index pulse, rad:
    /// `(count - count_at_index) / counts_per_rev * 2π`. Only meaningful once
    /// `index_count > 0`.
    pub fn angle_from_index_rad(&self) -> f64 {
        (self.count - self.count_at_index) as f64 / f64::from(self.counts_per_rev.max(1)) * TAU
    }

    /// Measured speed, rpm (signed), i.e. [`velocity`](Self::velocity) converted.
    pub fn velocity_rpm(&self) -> f64 {
        self.velocity * 60.0 / TAU
    }
}

/// Simulated spindle.
///
/// Per [`step`](Self::step) of `dt` seconds:
/// 1. the nominal speed ramps towards the command by at most `acceleration_rpm_per_s * dt`;
/// 2. the true speed is `nominal * (1 + ripple_fraction * sin(2π·ripple_hz·t)) + noise_rpm * g`
///    with `g` ≈ N(0, 1) from the seeded generator; it is 0 when the nominal speed is 0 and
///    never has the opposite sign of the nominal speed;
/// 3. the angle integrates the true speed (trapezoidal rule between the previous and the new
///    true speed);
/// 4. encoder count, index pulses and the measured velocity are updated.
///
/// The angle is kept as whole turns (`i64`) plus a fraction in `[0, 1)`, so precision does not
/// degrade in long runs. No allocation, no I/O; bit-for-bit deterministic.
#[derive(Debug, Clone)]
pub struct Spindle {
    params: SpindleParams,
    cpr: i64,
    rng: SplitMix64,
    command_rpm: f64,
    /// Stalled: stands still whatever the command (fault injection).
    stalled: bool,
    nominal_rpm: f64,
    speed_rpm: f64,
    /// Ripple phase in cycles, `[0, 1)`.
    ripple_phase: f64,
    turns: i64,
    frac: f64,
    count: i64,
    index_count: i64,
    count_at_index: i64,
    measured_velocity: f64,
    /// Ring buffer of (count, duration of the cycle that ended with this count).
    history: [(i64, f64); ENCODER_HISTORY_LEN],
    /// Index of the newest entry in `history`.
    history_head: usize,
    /// Number of valid entries in `history` (1..=ENCODER_HISTORY_LEN).
    history_len: usize,
}

impl Spindle {
    /// Creates a spindle at rest at angle 0 with command 0.
    pub fn new(params: SpindleParams) -> Self {
        Self {
            params,
            cpr: i64::from(params.encoder_counts_per_rev.max(1)),
            rng: SplitMix64::new(params.seed),
            command_rpm: 0.0,
            stalled: false,
            nominal_rpm: 0.0,
            speed_rpm: 0.0,
            ripple_phase: 0.0,
            turns: 0,
            frac: 0.0,
            count: 0,
            index_count: 0,
            count_at_index: 0,
            measured_velocity: 0.0,
            history: [(0, 0.0); ENCODER_HISTORY_LEN],
            history_head: 0,
            history_len: 1,
        }
    }

    /// Sets the commanded speed, rpm, signed (+ = M03 clockwise, − = M04), clamped to
    /// ±`max_rpm`. A NaN command is treated as 0 (stop).
    pub fn set_command_rpm(&mut self, rpm: f64) {
        let max = self.params.max_rpm.max(0.0);
        self.command_rpm = if rpm.is_nan() {
            0.0
        } else {
            rpm.min(max).max(-max)
        };
    }

    /// Stalls the spindle (`true`): from the next step it stands still whatever its command,
    /// as a blocked spindle or one whose drive ignores the command; the encoder keeps
    /// reporting (a constant count). Released (`false`), it ramps from rest towards its
    /// command again. For fault injection (the simulator node's `spindle_stalled` service).
    pub fn set_stalled(&mut self, stalled: bool) {
        self.stalled = stalled;
    }

    /// Whether the spindle is stalled (see [`set_stalled`](Self::set_stalled)).
    pub fn stalled(&self) -> bool {
        self.stalled
    }

    /// Simulates one cycle of `dt` seconds. A `dt` that is not finite and > 0 makes the call a
    /// no-op.
    pub fn step(&mut self, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let p = &self.params;

        // 1. Ramp of the nominal speed (a stalled spindle stands still).
        let max_dv = p.acceleration_rpm_per_s.max(0.0) * dt;
        let diff = self.command_rpm - self.nominal_rpm;
        if self.stalled {
            self.nominal_rpm = 0.0;
        } else if diff.abs() <= max_dv {
            self.nominal_rpm = self.command_rpm;
        } else {
            self.nominal_rpm += max_dv.copysign(diff);
        }

        // 2. Ripple and noise (the generator advances every cycle, turning or not).
        let phase = self.ripple_phase + p.ripple_hz * dt;
        self.ripple_phase = phase - phase.floor();
        let g = self.rng.next_gaussian();
        let previous_speed = self.speed_rpm;
        self.speed_rpm = if self.nominal_rpm == 0.0 {
            0.0
        } else {
            let ripple = if p.ripple_fraction == 0.0 {
                1.0
            } else {
                1.0 + p.ripple_fraction * (TAU * self.ripple_phase).sin()
            };
            let noise = if p.noise_rpm == 0.0 {
                0.0
            } else {
                p.noise_rpm * g
            };
            let s = self.nominal_rpm * ripple + noise;
            if self.nominal_rpm > 0.0 {
                s.max(0.0)
            } else {
                s.min(0.0)
            }
        };

        // 3. Angle, in revolutions (trapezoidal integration).
        let old_turns = self.turns;
        self.frac += 0.5 * (previous_speed + self.speed_rpm) / 60.0 * dt;
        let whole = self.frac.floor();
        if whole != 0.0 {
            self.turns = self.turns.saturating_add(whole as i64);
            self.frac -= whole;
        }
        if self.frac >= 1.0 {
            // Rounding of a tiny negative fraction up to 1.0.
            self.frac -= 1.0;
            self.turns = self.turns.saturating_add(1);
        }

        // 4. Encoder: index crossings, count, measured velocity.
        let crossed = self.turns - old_turns;
        if crossed > 0 {
            self.index_count += crossed;
            self.count_at_index = self.turns * self.cpr;
        } else if crossed < 0 {
            self.index_count -= crossed;
            // Last boundary crossed going down is the lowest one: turns + 1.
            self.count_at_index = (self.turns + 1) * self.cpr;
        }
        let within = ((self.frac * self.cpr as f64).floor() as i64).min(self.cpr - 1);
        self.count = self.turns * self.cpr + within;

        self.history_head = (self.history_head + 1) % ENCODER_HISTORY_LEN;
        self.history[self.history_head] = (self.count, dt);
        self.history_len = (self.history_len + 1).min(ENCODER_HISTORY_LEN);
        self.measured_velocity = self.measure_velocity();
    }

    /// Count difference over the last `ENCODER_VELOCITY_WINDOW_S`, in rad/s.
    fn measure_velocity(&self) -> f64 {
        let mut elapsed = 0.0;
        let mut idx = self.history_head;
        let mut remaining = self.history_len - 1;
        // The tiny tolerance makes e.g. 10 cycles of 1 ms count as a full 10 ms window despite
        // rounding in the sum.
        while remaining > 0 && elapsed < ENCODER_VELOCITY_WINDOW_S * (1.0 - 1e-9) {
            elapsed += self.history[idx].1;
            idx = (idx + ENCODER_HISTORY_LEN - 1) % ENCODER_HISTORY_LEN;
            remaining -= 1;
        }
        if elapsed > 0.0 {
            let counts = (self.count - self.history[idx].0) as f64;
            counts / self.cpr as f64 * TAU / elapsed
        } else {
            0.0
        }
    }

    /// Accumulated true angle since start, rad, signed (+ = M03 direction).
    pub fn angle_rad(&self) -> f64 {
        self.revolutions() * TAU
    }

    /// Accumulated true angle since start, revolutions, signed.
    pub fn revolutions(&self) -> f64 {
        self.turns as f64 + self.frac
    }

    /// True current speed including ripple and noise, rpm, signed.
    pub fn speed_rpm(&self) -> f64 {
        self.speed_rpm
    }

    /// Current speed of the ramp (without ripple and noise), rpm, signed.
    pub fn nominal_rpm(&self) -> f64 {
        self.nominal_rpm
    }

    /// Current (clamped) command, rpm, signed.
    pub fn command_rpm(&self) -> f64 {
        self.command_rpm
    }

    /// Current encoder state.
    pub fn encoder(&self) -> EncoderReading {
        EncoderReading {
            count: self.count,
            counts_per_rev: self.cpr as u32,
            index_count: self.index_count,
            count_at_index: self.count_at_index,
            velocity: self.measured_velocity,
        }
    }

    /// The parameters this spindle runs with.
    pub fn params(&self) -> &SpindleParams {
        &self.params
    }

    /// Changes the speed ripple (a fraction, 0..1) and the speed noise (rpm, >= 0) from the
    /// next step on, as the simulator node's parameters `ripple` and `noise_rpm` do while it
    /// runs; values [`SpindleParams::validate`] refuses change nothing.
    pub fn set_disturbances(
        &mut self,
        ripple_fraction: f64,
        noise_rpm: f64,
    ) -> Result<(), &'static str> {
        let p = SpindleParams {
            ripple_fraction,
            noise_rpm,
            ..self.params
        };
        p.validate()?;
        self.params = p;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet(cpr: u32, acc: f64) -> SpindleParams {
        SpindleParams {
            max_rpm: 24_000.0,
            acceleration_rpm_per_s: acc,
            encoder_counts_per_rev: cpr,
            ripple_fraction: 0.0,
            ripple_hz: 0.0,
            noise_rpm: 0.0,
            seed: 1,
        }
    }

    #[test]
    fn reaches_1000_rpm_at_500_rpm_per_s_in_2_s() {
        for &dt in &[0.0001, 0.001, 0.002, 0.0007] {
            let mut sp = Spindle::new(quiet(4096, 500.0));
            sp.set_command_rpm(1000.0);
            let mut reached = None;
            let mut prev = 0.0;
            for k in 1..=(3.0 / dt) as usize {
                sp.step(dt);
                let s = sp.speed_rpm();
                assert!(s - prev <= 500.0 * dt * (1.0 + 1e-9), "ramp too steep");
                assert!(s <= 1000.0);
                prev = s;
                if s == 1000.0 && reached.is_none() {
                    reached = Some(k as f64 * dt);
                }
            }
            let t = reached.expect("never reached 1000 rpm");
            assert!(
                (t - 2.0).abs() <= dt * (1.0 + 1e-9),
                "dt {dt}: reached at {t} s"
            );
            // Angle: 2 s ramp (1000/60 rev/s * 2 s / 2) + 1 s at 1000 rpm = 16.667 + 16.667 rev.
            let expected_rev = 1000.0 / 60.0 + 1000.0 / 60.0 * (3.0 - 2.0);
            assert!((sp.revolutions() - expected_rev).abs() < 2e-3 * expected_rev);
        }
    }

    #[test]
    fn command_is_clamped_and_ramps_through_zero() {
        let mut sp = Spindle::new(SpindleParams {
            max_rpm: 3000.0,
            ..quiet(4096, 10_000.0)
        });
        sp.set_command_rpm(99_999.0);
        assert_eq!(sp.command_rpm(), 3000.0);
        sp.set_command_rpm(f64::NAN);
        assert_eq!(sp.command_rpm(), 0.0);
        sp.set_command_rpm(-5000.0);
        assert_eq!(sp.command_rpm(), -3000.0);
        for _ in 0..1000 {
            sp.step(0.001);
        }
        assert_eq!(sp.speed_rpm(), -3000.0);
        sp.set_command_rpm(3000.0);
        for _ in 0..300 {
            sp.step(0.001);
        }
        assert!((sp.speed_rpm() - 0.0).abs() < 1e-9, "{}", sp.speed_rpm());
        for _ in 0..400 {
            sp.step(0.001);
        }
        assert_eq!(sp.speed_rpm(), 3000.0);
    }

    /// 960 rpm = 16 rev/s and dt = 1/1024 s make every angle increment a dyadic fraction, so
    /// the angle after the run is exactly 2.25 revolutions.
    /// Ramp: 61 440 rpm/s * dt = 60 rpm per cycle, 16 cycles to 960 rpm, covering
    /// sum (k - 1/2)/1024 = 0.125 rev; then 136 cycles of 1/64 rev = 2.125 rev.
    fn run_exact(direction: f64) -> Spindle {
        let dt = 1.0 / 1024.0;
        let mut sp = Spindle::new(quiet(4096, 61_440.0));
        sp.set_command_rpm(960.0 * direction);
        for _ in 0..16 + 136 {
            sp.step(dt);
        }
        sp
    }

    #[test]
    fn encoder_exact_count_and_index_forward() {
        let sp = run_exact(1.0);
        assert_eq!(sp.revolutions(), 2.25);
        assert_eq!(sp.angle_rad(), 2.25 * TAU);
        let e = sp.encoder();
        assert_eq!(e.count, 9216);
        assert_eq!(e.counts_per_rev, 4096);
        assert_eq!(e.index_count, 2);
        assert_eq!(e.count_at_index, 8192);
        assert_eq!(e.angle_from_index_rad(), 0.25 * TAU);
        // 960 rpm = 32π rad/s; the window is entirely at constant speed.
        assert!((e.velocity - 32.0 * std::f64::consts::PI).abs() < 1e-9 * e.velocity);
        assert!((e.velocity_rpm() - 960.0).abs() < 1e-9);
    }

    /// Reverse: angle -2.25 rev. The start (angle 0) lies on the index mark, so going
    /// backwards crosses marks 0, -1 and -2: three index pulses, the last at count -8192.
    #[test]
    fn encoder_exact_count_and_index_reverse() {
        let sp = run_exact(-1.0);
        assert_eq!(sp.revolutions(), -2.25);
        assert_eq!(sp.speed_rpm(), -960.0);
        let e = sp.encoder();
        assert_eq!(e.count, -9216);
        assert_eq!(e.index_count, 3);
        assert_eq!(e.count_at_index, -8192);
        assert_eq!(e.angle_from_index_rad(), -0.25 * TAU);
        assert!((e.velocity + 32.0 * std::f64::consts::PI).abs() < 1e-9 * 32.0);
    }

    /// Forward then back: each crossing of a mark counts, in either direction, and
    /// count_at_index is always n * counts_per_rev of the mark crossed last.
    #[test]
    fn index_counts_crossings_in_both_directions() {
        let dt = 1.0 / 1024.0;
        let mut sp = run_exact(1.0); // +2.25 rev, at 960 rpm, 2 crossings (marks 1, 2)
        sp.set_command_rpm(-960.0);
        // Reversal takes 32 cycles (960 -> -960 rpm) and covers net 0 rev, peaking at
        // 2.375 rev after 16 cycles; then 368 cycles at -1/64 rev each.
        let mut last_index_count = sp.encoder().index_count;
        let mut crossings = Vec::new();
        let mut prev_rev = sp.revolutions();
        for _ in 0..400 {
            sp.step(dt);
            let e = sp.encoder();
            let r = sp.revolutions();
            if e.index_count != last_index_count {
                assert_eq!(e.index_count, last_index_count + 1);
                // The mark crossed lies between the previous and the current angle.
                let mark = e.count_at_index / 4096;
                assert_eq!(e.count_at_index % 4096, 0);
                let (lo, hi) = if r < prev_rev {
                    (r, prev_rev)
                } else {
                    (prev_rev, r)
                };
                assert!(lo < mark as f64 + 1e-12 && mark as f64 <= hi + 1e-12);
                crossings.push(mark);
                last_index_count = e.index_count;
            }
            // Angle from the index agrees with the true angle to within one count.
            if e.index_count > 0 {
                let true_rel = (r - (e.count_at_index / 4096) as f64) * TAU;
                assert!((e.angle_from_index_rad() - true_rel).abs() <= TAU / 4096.0 + 1e-12);
                assert!(e.angle_from_index_rad() <= true_rel + 1e-12);
            }
            prev_rev = r;
        }
        // From 2.25 rev up to 2.375 and down to 2.25 - 368/64 = -3.5 rev:
        // marks 2, 1, 0, -1, -2, -3.
        assert_eq!(sp.revolutions(), -3.5);
        assert_eq!(crossings, vec![2, 1, 0, -1, -2, -3]);
        assert_eq!(sp.encoder().index_count, 8);
        assert_eq!(sp.encoder().count, -14_336);
        assert_eq!(sp.encoder().count_at_index, -3 * 4096);
    }

    #[test]
    fn count_floor_for_negative_angles_and_odd_cpr() {
        // 1000 counts/rev, -0.0005 rev -> count -1 (floor), not 0.
        let mut sp = Spindle::new(quiet(1000, 1e9));
        sp.set_command_rpm(-0.03); // -0.0005 rev/s
        sp.step(1.0); // trapezoid: half speed over the first cycle: -0.00025 rev
        assert_eq!(sp.encoder().count, -1);
        assert_eq!(sp.encoder().index_count, 1);
        assert_eq!(sp.encoder().count_at_index, 0);
        assert!((sp.encoder().angle_from_index_rad() + TAU / 1000.0).abs() < 1e-15);

        // Positive fraction of a count: 0.07 rev at 10 counts/rev reads 0 (not rounded to 1).
        let mut sp = Spindle::new(quiet(10, 1e9));
        sp.set_command_rpm(8.4); // 0.14 rev/s, first cycle at half speed: 0.07 rev
        sp.step(1.0);
        assert!((sp.revolutions() - 0.07).abs() < 1e-12);
        assert_eq!(sp.encoder().count, 0);
        sp.step(1.0); // 0.21 rev
        assert_eq!(sp.encoder().count, 2);
    }

    /// count == floor(revolutions * counts_per_rev) at every step of an irregular run.
    #[test]
    fn count_is_floor_of_angle_throughout() {
        let mut sp = Spindle::new(SpindleParams {
            encoder_counts_per_rev: 1000,
            ripple_fraction: 0.05,
            ripple_hz: 13.0,
            noise_rpm: 20.0,
            seed: 99,
            ..SpindleParams::default()
        });
        let mut fractional = 0;
        for k in 0..20_000 {
            sp.set_command_rpm(if (k / 3000) % 2 == 0 { 700.0 } else { -450.0 });
            sp.step(0.00037);
            let x = sp.revolutions() * 1000.0;
            if (x - x.round()).abs() > 1e-6 {
                assert_eq!(sp.encoder().count, x.floor() as i64, "step {k}: {x}");
                fractional += 1;
            }
        }
        assert!(fractional > 19_000);
    }

    #[test]
    fn ripple_two_percent_shows_in_speed() {
        let params = SpindleParams {
            ripple_fraction: 0.02,
            ripple_hz: 50.0,
            ..quiet(4096, 5000.0)
        };
        let mut sp = Spindle::new(params);
        sp.set_command_rpm(1000.0);
        let dt = 0.0001;
        for _ in 0..(0.5 / dt) as usize {
            sp.step(dt); // ramp done after 0.2 s
        }
        let (mut lo, mut hi, mut sum, n) = (f64::MAX, f64::MIN, 0.0, (1.0 / dt) as usize);
        for _ in 0..n {
            sp.step(dt);
            lo = lo.min(sp.speed_rpm());
            hi = hi.max(sp.speed_rpm());
            sum += sp.speed_rpm();
        }
        assert!((980.0 - 1e-9..=980.01).contains(&lo), "min {lo}");
        assert!((1019.99..=1020.0 + 1e-9).contains(&hi), "max {hi}");
        // Over whole ripple periods the mean speed is the nominal speed.
        assert!(
            (sum / n as f64 - 1000.0).abs() < 1e-6,
            "mean {}",
            sum / n as f64
        );
        assert_eq!(sp.nominal_rpm(), 1000.0);
    }

    #[test]
    fn noise_has_the_configured_amplitude_and_never_reverses() {
        let params = SpindleParams {
            noise_rpm: 5.0,
            seed: 7,
            ..quiet(4096, 1e9)
        };
        let mut sp = Spindle::new(params);
        sp.set_command_rpm(1000.0);
        let n = 100_000;
        let (mut s1, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            sp.step(0.001);
            let d = sp.speed_rpm() - 1000.0;
            s1 += d;
            s2 += d * d;
        }
        let mean = s1 / n as f64;
        let std = (s2 / n as f64 - mean * mean).sqrt();
        assert!(mean.abs() < 0.1, "mean {mean}");
        assert!((std - 5.0).abs() < 0.1, "std {std}");

        // Noise larger than the speed: the spindle still never turns backwards, and at
        // standstill there is no noise at all.
        let mut sp = Spindle::new(SpindleParams {
            noise_rpm: 50.0,
            ..params
        });
        for _ in 0..100 {
            sp.step(0.001);
            assert_eq!(sp.speed_rpm(), 0.0);
        }
        sp.set_command_rpm(10.0);
        let mut saw_zero = false;
        for _ in 0..10_000 {
            sp.step(0.001);
            assert!(sp.speed_rpm() >= 0.0);
            saw_zero |= sp.speed_rpm() == 0.0;
        }
        assert!(saw_zero);
    }

    fn noisy_run(seed: u64) -> Vec<(u64, u64, i64, u64)> {
        let mut sp = Spindle::new(SpindleParams {
            ripple_fraction: 0.02,
            ripple_hz: 37.0,
            noise_rpm: 3.0,
            seed,
            ..SpindleParams::default()
        });
        sp.set_command_rpm(-1500.0);
        (0..3000)
            .map(|k| {
                if k == 1500 {
                    sp.set_command_rpm(800.0);
                }
                sp.step(0.0005);
                let e = sp.encoder();
                (
                    sp.speed_rpm().to_bits(),
                    sp.angle_rad().to_bits(),
                    e.count,
                    e.velocity.to_bits(),
                )
            })
            .collect()
    }

    #[test]
    fn same_seed_is_bit_identical_different_seeds_differ() {
        let a = noisy_run(12345);
        let b = noisy_run(12345);
        assert_eq!(a, b);
        let c = noisy_run(12346);
        assert_ne!(a, c);
        let differing = a.iter().zip(&c).filter(|(x, y)| x.0 != y.0).count();
        assert!(differing > 2900, "only {differing} speed samples differ");
    }

    #[test]
    fn measured_velocity_within_half_percent_at_600_rpm() {
        let true_rad_s = 600.0 / 60.0 * TAU; // 62.83 rad/s
        for &dt in &[0.0001, 0.00025, 0.001, 0.002] {
            for &dir in &[1.0, -1.0] {
                let mut sp = Spindle::new(quiet(4096, 5000.0));
                sp.set_command_rpm(600.0 * dir);
                // Ramp takes 0.12 s; then the window (10 ms) must be at constant speed.
                let start = (0.14 / dt) as usize;
                let mut worst = 0.0_f64;
                for k in 0..(1.0 / dt) as usize {
                    sp.step(dt);
                    if k >= start {
                        let v = sp.encoder().velocity;
                        worst = worst.max((v - dir * true_rad_s).abs() / true_rad_s);
                    }
                }
                assert!(worst < 0.005, "dt {dt}: worst relative error {worst}");
            }
        }
    }

    #[test]
    fn measured_velocity_is_quantised_by_counts() {
        // 1 count in 10 ms at 100 counts/rev: very slow rotation reads coarse steps.
        let mut sp = Spindle::new(quiet(100, 1e9));
        sp.set_command_rpm(6.0); // 0.1 rev/s = 10 counts/s
        let q = TAU / 100.0 / ENCODER_VELOCITY_WINDOW_S; // rad/s per count in the window
        for _ in 0..2000 {
            sp.step(0.001);
            let v = sp.encoder().velocity;
            let n = v / q;
            assert!((n - n.round()).abs() < 1e-6, "not quantised: {v}");
        }
    }

    #[test]
    fn a_stalled_spindle_stands_still_whatever_its_command_and_ramps_up_when_released() {
        let dt = 0.001;
        let mut sp = Spindle::new(SpindleParams {
            ripple_fraction: 0.02,
            noise_rpm: 2.0,
            ..quiet(4096, 1000.0)
        });
        sp.set_command_rpm(600.0);
        for _ in 0..1000 {
            sp.step(dt);
        }
        assert!(sp.speed_rpm() > 500.0);
        // stalled while turning: it stops at once and the count stays
        sp.set_stalled(true);
        assert!(sp.stalled());
        sp.step(dt);
        let c = sp.encoder().count;
        let index = sp.encoder().index_count;
        for _ in 0..500 {
            sp.step(dt);
            assert_eq!(sp.speed_rpm(), 0.0);
            assert_eq!(sp.nominal_rpm(), 0.0);
        }
        let e = sp.encoder();
        assert_eq!((e.count, e.index_count), (c, index));
        assert_eq!(e.velocity, 0.0);
        // a new command is ignored too
        sp.set_command_rpm(-900.0);
        sp.step(dt);
        assert_eq!((sp.speed_rpm(), sp.encoder().count), (0.0, c));
        assert_eq!(sp.command_rpm(), -900.0);
        // released: it ramps from rest at its acceleration (1000 rpm/s)
        sp.set_stalled(false);
        for k in 1..=100 {
            sp.step(dt);
            assert!(
                (sp.nominal_rpm() + k as f64).abs() < 1e-9,
                "{}",
                sp.nominal_rpm()
            );
        }
        assert!(sp.encoder().count < c);
    }

    #[test]
    fn invalid_dt_is_a_no_op() {
        let mut sp = Spindle::new(SpindleParams::default());
        sp.set_command_rpm(1000.0);
        sp.step(0.0);
        sp.step(f64::INFINITY);
        sp.step(-1.0);
        assert_eq!(sp.speed_rpm(), 0.0);
        assert_eq!(sp.encoder().count, 0);
        assert_eq!(SpindleParams::default().validate(), Ok(()));
        assert!(SpindleParams {
            encoder_counts_per_rev: 0,
            ..SpindleParams::default()
        }
        .validate()
        .is_err());
    }
}
