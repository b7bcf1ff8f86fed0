//! Linear axis: position loop (P + velocity feed-forward) around a first-order velocity loop
//! with acceleration and velocity saturation.

/// Parameters of one simulated linear axis (drive + position controller).
///
/// All lengths are in mm, times in s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisParams {
    /// Physical velocity limit of the drive, mm/s (> 0). The simulated velocity magnitude never
    /// exceeds it.
    pub max_velocity: f64,
    /// Physical acceleration limit of the drive, mm/s² (> 0). The simulated velocity never
    /// changes by more than `max_acceleration * dt` per cycle.
    pub max_acceleration: f64,
    /// Position loop gain (Kv), 1/s, e.g. 60. Without feed-forward the steady following error
    /// at constant velocity `v` is `v / kp` mm.
    pub kp: f64,
    /// Velocity feed-forward factor, dimensionless, 0..=1 (1.0 = full feed-forward, which
    /// gives zero steady following error at constant velocity).
    pub velocity_feed_forward: f64,
    /// Time constant of the (first-order) velocity loop, s, e.g. 0.002. 0 = ideal velocity
    /// loop (actual velocity equals the command up to the saturations).
    pub velocity_lag: f64,
    /// Acceleration feed-forward factor, dimensionless, 0..=1: the share of the velocity
    /// loop's lag under acceleration that the velocity command makes up (1.0: a setpoint
    /// whose velocity changes is followed as if the loop had no lag, up to the saturations;
    /// 0: none, the lag a·lag/kp stands under acceleration a).
    pub acceleration_feed_forward: f64,
}

impl Default for AxisParams {
    /// 500 mm/s, 10 000 mm/s², kp 60 1/s, full velocity feed-forward (1.0), velocity lag
    /// 2 ms, no acceleration feed-forward.
    fn default() -> Self {
        Self {
            max_velocity: 500.0,
            max_acceleration: 10_000.0,
            kp: 60.0,
            velocity_feed_forward: 1.0,
            velocity_lag: 0.002,
            acceleration_feed_forward: 0.0,
        }
    }
}

impl AxisParams {
    /// Checks that the parameters are physically meaningful: finite, positive limits, `kp > 0`,
    /// feed-forward in 0..=1, lag ≥ 0. The model never panics on bad parameters, but its
    /// behaviour is only meaningful for parameters that pass this check.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.max_velocity.is_finite() && self.max_velocity > 0.0) {
            return Err("max_velocity must be finite and > 0 mm/s");
        }
        if !(self.max_acceleration.is_finite() && self.max_acceleration > 0.0) {
            return Err("max_acceleration must be finite and > 0 mm/s^2");
        }
        if !(self.kp.is_finite() && self.kp > 0.0) {
            return Err("kp must be finite and > 0 1/s");
        }
        if !(0.0..=1.0).contains(&self.velocity_feed_forward) {
            return Err("velocity_feed_forward must be within 0..=1");
        }
        if !(self.velocity_lag.is_finite() && self.velocity_lag >= 0.0) {
            return Err("velocity_lag must be finite and >= 0 s");
        }
        if !(0.0..=1.0).contains(&self.acceleration_feed_forward) {
            return Err("acceleration_feed_forward must be within 0..=1");
        }
        Ok(())
    }
}

/// One simulated linear axis.
///
/// Per servo cycle ([`Axis::step`]) with setpoint `s_k`, previous setpoint `s_{k-1}`, position
/// `p` and the velocity loop's lagged part `v_l` (see the crate documentation for the
/// rationale):
///
/// ```text
/// w_k   = ff * (s_k - s_{k-1}) / dt
/// c     = (1 - aff) * w_k + kp * (s_{k-1} - p)          held over the cycle
/// v_l'  = c + (v_l - c) * exp(-dt / lag)                 (c if lag = 0)
/// v'    = v_l' + aff * w_k,   then |v' - v| <= a_max*dt and |v'| <= v_max
/// p'    = p + ∫ v over the cycle = p + c*dt + (v_l - c)*lag*(1 - exp(-dt/lag)) + aff*w_k*dt
///         (within the limits; where they cut in, the velocity ramps: p + (v + v')/2 * dt)
/// ```
///
/// No allocation, no I/O; bit-for-bit deterministic.
#[derive(Debug, Clone)]
pub struct Axis {
    params: AxisParams,
    position: f64,
    velocity: f64,
    /// the part of the velocity that follows the velocity loop's lag (all of it without
    /// acceleration feed-forward), mm/s
    lagged: f64,
    prev_setpoint: f64,
    following_error: f64,
    /// `dt` for which `alpha` was last computed (bitwise compared), s.
    alpha_dt: f64,
    alpha: f64,
}

impl Axis {
    /// Creates an axis at rest at `initial_position_mm` (mm). The "previous setpoint" of the
    /// first [`step`](Self::step) is this position.
    pub fn new(params: AxisParams, initial_position_mm: f64) -> Self {
        Self {
            params,
            position: initial_position_mm,
            velocity: 0.0,
            lagged: 0.0,
            prev_setpoint: initial_position_mm,
            following_error: 0.0,
            alpha_dt: f64::NAN,
            alpha: 1.0,
        }
    }

    /// Simulates one servo cycle of length `dt` (s) with the commanded position `setpoint_mm`
    /// (mm) for this cycle (the position the axis should reach at the end of the cycle).
    ///
    /// A `dt` that is not finite and > 0 makes the call a no-op. Stable for `dt` in
    /// 0.0001..=0.002 s with `kp` up to 200 1/s (in general: `kp * dt` well below 2).
    pub fn step(&mut self, setpoint_mm: f64, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let p = &self.params;
        if dt.to_bits() != self.alpha_dt.to_bits() {
            self.alpha = if p.velocity_lag > 0.0 {
                1.0 - (-dt / p.velocity_lag).exp()
            } else {
                1.0
            };
            self.alpha_dt = dt;
        }

        // Position loop: feed-forward of the setpoint increment, P-correction of the error
        // against the position the axis should have *now* (the previous setpoint). The
        // velocity loop follows this command with a first-order lag, except for the share
        // `aff` of the feed-forward that the acceleration feed-forward passes at once.
        let w = p.velocity_feed_forward * (setpoint_mm - self.prev_setpoint) / dt;
        let aff = p.acceleration_feed_forward;
        let c = (1.0 - aff) * w + p.kp * (self.prev_setpoint - self.position);
        // The lag's exact response to the command held over the cycle: its velocity at the
        // end and the distance it covers. (Stepping the position by the end velocity instead
        // made the lag under acceleration depend on the cycle: a·1.54 ms/kp at 1 kHz for a
        // 2 ms lag, a·1.95 ms/kp at 10 kHz, where the loop's law is a·lag/kp.)
        let decay = 1.0 - self.alpha;
        let lagged = c + (self.lagged - c) * decay;
        let covered = c * dt + (self.lagged - c) * p.velocity_lag * self.alpha + aff * w * dt;
        let v_free = lagged + aff * w;

        // Drive saturation. `max(0.0)` also maps NaN limits to 0 and avoids `f64::clamp` panics.
        let max_dv = p.max_acceleration.max(0.0) * dt;
        let v_max = p.max_velocity.max(0.0);
        if (v_free - self.velocity).abs() <= max_dv && v_free.abs() <= v_max {
            self.position += covered;
            self.lagged = lagged;
            self.velocity = v_free;
        } else {
            // a limit cuts in: the velocity ramps from the old to the new within the cycle
            let dv = (v_free - self.velocity).min(max_dv).max(-max_dv);
            let v_new = (self.velocity + dv).min(v_max).max(-v_max);
            self.position += 0.5 * (self.velocity + v_new) * dt;
            self.lagged = v_new - aff * w;
            self.velocity = v_new;
        }
        self.prev_setpoint = setpoint_mm;
        self.following_error = setpoint_mm - self.position;
    }

    /// Actual position, mm.
    pub fn position(&self) -> f64 {
        self.position
    }

    /// Actual velocity, mm/s.
    pub fn velocity(&self) -> f64 {
        self.velocity
    }

    /// Setpoint of the last [`step`](Self::step) minus the position after it, mm (0 before the
    /// first step). Positive = the axis lags behind a setpoint moving in + direction.
    pub fn following_error(&self) -> f64 {
        self.following_error
    }

    /// Setpoint of the last step, mm (the initial position before the first step).
    pub fn setpoint(&self) -> f64 {
        self.prev_setpoint
    }

    /// The parameters this axis was created with.
    pub fn params(&self) -> &AxisParams {
        &self.params
    }

    /// Puts the axis at rest at `position_mm` (mm) with setpoint = position (e.g. after homing).
    pub fn reset(&mut self, position_mm: f64) {
        self.position = position_mm;
        self.velocity = 0.0;
        self.lagged = 0.0;
        self.prev_setpoint = position_mm;
        self.following_error = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ideal(kp: f64, ff: f64, lag: f64) -> AxisParams {
        AxisParams {
            max_velocity: 1e12,
            max_acceleration: 1e15,
            kp,
            velocity_feed_forward: ff,
            velocity_lag: lag,
            acceleration_feed_forward: 0.0,
        }
    }

    /// Trapezoidal-velocity setpoint sampled at `t` (s): accelerate at `a` to `v`, cruise,
    /// decelerate at `a` to rest at `dist`; starts at 0.
    fn trapezoid(t: f64, a: f64, v: f64, dist: f64) -> f64 {
        let ta = v / a;
        let da = 0.5 * a * ta * ta;
        let tc = (dist - 2.0 * da) / v;
        assert!(tc >= 0.0);
        if t <= 0.0 {
            0.0
        } else if t < ta {
            0.5 * a * t * t
        } else if t < ta + tc {
            da + v * (t - ta)
        } else if t < 2.0 * ta + tc {
            let td = 2.0 * ta + tc - t;
            dist - 0.5 * a * td * td
        } else {
            dist
        }
    }

    #[test]
    fn default_params_are_as_documented_and_valid() {
        let p = AxisParams::default();
        assert_eq!(p.max_velocity, 500.0);
        assert_eq!(p.max_acceleration, 10_000.0);
        assert_eq!(p.kp, 60.0);
        assert_eq!(p.velocity_feed_forward, 1.0);
        assert_eq!(p.velocity_lag, 0.002);
        assert_eq!(p.validate(), Ok(()));
        let bad = AxisParams {
            velocity_feed_forward: 1.5,
            ..p
        };
        assert!(bad.validate().is_err());
        let bad = AxisParams {
            max_velocity: 0.0,
            ..p
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn first_step_uses_initial_position_as_previous_setpoint() {
        // ff only, lag 0: the first step moves exactly by (setpoint - initial).
        let mut ax = Axis::new(ideal(60.0, 1.0, 0.0), 10.0);
        ax.step(10.5, 0.001);
        assert!((ax.position() - 10.5).abs() < 1e-12, "{}", ax.position());
        assert!((ax.velocity() - 500.0).abs() < 1e-9);
        assert!(ax.following_error().abs() < 1e-12);
    }

    #[test]
    fn full_acceleration_feed_forward_takes_out_the_lag_under_acceleration() {
        // The default drive (kp 60, velocity lag 2 ms) under a trapezoid of
        // 5000 mm/s² trails by about a·lag/kp = 0.167 mm while it speeds
        // up; with full acceleration feed-forward it follows exactly.
        let run = |aff: f64| {
            let params = AxisParams {
                acceleration_feed_forward: aff,
                ..AxisParams::default()
            };
            let mut ax = Axis::new(params, 0.0);
            let dt = 0.001;
            let mut max_err = 0.0_f64;
            for k in 1..=500 {
                ax.step(trapezoid(k as f64 * dt, 5_000.0, 100.0, 30.0), dt);
                max_err = max_err.max(ax.following_error().abs());
            }
            max_err
        };
        let (none, full) = (run(0.0), run(1.0));
        assert!((none - 0.13).abs() < 0.04, "without: {none} mm");
        assert!(full < 1e-9, "with: {full} mm");
        let bad = AxisParams {
            acceleration_feed_forward: 1.5,
            ..AxisParams::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn ramp_tracking_with_full_ff_and_no_lag_is_exact() {
        // Realistic limits (defaults); the setpoint respects them (5000 mm/s², 100 mm/s).
        let params = AxisParams {
            velocity_lag: 0.0,
            ..AxisParams::default()
        };
        for &dt in &[0.0001, 0.001, 0.002] {
            let mut ax = Axis::new(params, 0.0);
            let n = (0.5 / dt) as usize;
            let mut max_err = 0.0_f64;
            for k in 1..=n {
                let s = trapezoid(k as f64 * dt, 5_000.0, 100.0, 30.0);
                ax.step(s, dt);
                max_err = max_err.max(ax.following_error().abs());
            }
            assert!(max_err < 1e-9, "dt {dt}: max following error {max_err} mm");
            assert!((ax.position() - 30.0).abs() < 1e-9);
        }
        // And a pure constant-velocity ramp (ideal drive, ramp starts with a velocity step).
        let mut ax = Axis::new(ideal(60.0, 1.0, 0.0), 0.0);
        for k in 1..=5000 {
            ax.step(100.0 * k as f64 * 0.001, 0.001);
            assert!(ax.following_error().abs() < 1e-9, "step {k}");
        }
    }

    /// Steady following error at constant velocity `r`:  e = (1 - ff) * r / kp, exactly,
    /// for any lag and dt (in steady state the lag filter passes v_cmd = r unchanged and the
    /// feed-forward term supplies ff*r, so the P-term must supply (1-ff)*r).
    #[test]
    fn ramp_with_lag_steady_following_error() {
        let r = 100.0; // mm/s
        let dt = 0.001;
        for &(ff, expected) in &[(1.0, 0.0), (0.5, 0.5 * 100.0 / 60.0), (0.0, 100.0 / 60.0)] {
            let params = AxisParams {
                velocity_feed_forward: ff,
                ..AxisParams::default() // lag 0.002 s, kp 60
            };
            let mut ax = Axis::new(params, 0.0);
            let mut peak = 0.0_f64;
            for k in 1..=2000 {
                ax.step(r * k as f64 * dt, dt);
                peak = peak.max(ax.following_error().abs());
            }
            let e = ax.following_error();
            if expected == 0.0 {
                assert!(e.abs() < 1e-9, "ff {ff}: steady error {e}");
                // ...but the start of the ramp (a velocity step) leaves a transient error.
                assert!(peak > 0.1, "ff {ff}: peak {peak}");
            } else {
                assert!(
                    (e - expected).abs() < 0.01 * expected,
                    "ff {ff}: steady error {e}, expected {expected}"
                );
            }
            assert!((ax.velocity() - r).abs() < 1e-6);
        }
    }

    /// With full feed-forward the velocity lag shows while accelerating: for a setpoint with
    /// constant acceleration `a` the steady following error is `a * lag / kp`, the loop's
    /// law, at every cycle time (it was `a * dt / (kp * (exp(dt/lag) - 1))` while the position
    /// stepped by the cycle's end velocity: 0.0128 mm here at 1 kHz, 77 % of the law). With
    /// half the acceleration feed-forward, half of it.
    #[test]
    fn lag_following_error_during_constant_acceleration() {
        let a = 500.0; // mm/s², reaches 100 mm/s after 0.2 s
        for &(aff, share) in &[(0.0, 1.0), (0.5, 0.5)] {
            let params = AxisParams {
                acceleration_feed_forward: aff,
                ..AxisParams::default() // kp 60, ff 1, lag 0.002
            };
            let expected = share * a * params.velocity_lag / params.kp;
            for &dt in &[0.0001_f64, 0.001, 0.002] {
                let mut ax = Axis::new(params, 0.0);
                let n = (0.2 / dt).round() as usize;
                for k in 1..=n {
                    let s = trapezoid(k as f64 * dt, a, 100.0, 100.0);
                    ax.step(s, dt);
                }
                let e = ax.following_error();
                assert!(
                    (e - expected).abs() < 0.001 * expected,
                    "aff {aff} dt {dt}: error {e}, expected {expected}"
                );
                // After the acceleration phase, at constant velocity, the error decays to 0.
                for k in n + 1..=n + (0.15 / dt) as usize {
                    let s = trapezoid(k as f64 * dt, a, 100.0, 100.0);
                    ax.step(s, dt);
                }
                assert!(
                    ax.following_error().abs() < 1e-6,
                    "{}",
                    ax.following_error()
                );
            }
        }
    }

    #[test]
    fn velocity_and_acceleration_limits_never_exceeded() {
        for &dt in &[0.0001, 0.0005, 0.001, 0.002] {
            for &kp in &[10.0, 60.0, 200.0] {
                for &lag in &[0.0, 0.002] {
                    let params = AxisParams {
                        kp,
                        velocity_lag: lag,
                        ..AxisParams::default()
                    };
                    let mut ax = Axis::new(params, 0.0);
                    let n = (1.5 / dt) as usize;
                    let (mut hit_v, mut hit_a) = (false, false);
                    let mut v_prev = 0.0;
                    for k in 1..=n {
                        let t = k as f64 * dt;
                        // Setpoint jumps and a fast sine: both far beyond the drive limits.
                        let s = if t < 0.5 {
                            300.0
                        } else if t < 0.8 {
                            -200.0
                        } else {
                            50.0 * (2.0 * std::f64::consts::PI * 20.0 * t).sin()
                        };
                        ax.step(s, dt);
                        let v = ax.velocity();
                        let dv = v - v_prev;
                        assert!(v.abs() <= 500.0 * (1.0 + 1e-12), "v {v} at step {k}");
                        let a_lim = 10_000.0 * dt;
                        assert!(dv.abs() <= a_lim * (1.0 + 1e-9), "dv {dv} at step {k}");
                        hit_v |= v.abs() >= 500.0 * (1.0 - 1e-12);
                        hit_a |= dv.abs() >= a_lim * (1.0 - 1e-9);
                        v_prev = v;
                    }
                    assert!(hit_v && hit_a, "limits not exercised");
                }
            }
        }
    }

    /// Ideal loop without feed-forward: after the first step (which still sees the old
    /// setpoint) the error decays as e_n = S * (1 - kp*dt)^(n-1), i.e. like exp(-kp*t).
    #[test]
    fn step_settles_like_exp_minus_kp_t() {
        let (kp, dt, s) = (60.0, 0.001, 1.0);
        let mut ax = Axis::new(ideal(kp, 0.0, 0.0), 0.0);
        let expected_steps = 1 + ((1e-6_f64 / s).ln() / (1.0 - kp * dt).ln()).ceil() as usize;
        assert_eq!(expected_steps, 225); // 0.225 s vs continuous ln(1e6)/kp = 0.2303 s
        let mut settled_at = None;
        for k in 1..=1000 {
            ax.step(s, dt);
            let e = ax.following_error();
            if k >= 2 {
                let theory = s * (1.0 - kp * dt).powi(k as i32 - 1);
                assert!((e - theory).abs() < 1e-12, "step {k}: {e} vs {theory}");
            }
            if e.abs() < 1e-6 && settled_at.is_none() {
                settled_at = Some(k);
            }
        }
        assert_eq!(settled_at, Some(expected_steps));
    }

    /// Realistic drive (defaults: lag 2 ms, full ff, limits): settling time of a 1 mm step to
    /// 1 µm is governed by the dominant closed-loop pole, which for kp 60 and lag 2 ms is
    /// slightly faster than kp itself (root of z² - (1+β-α·kp·dt)z + β, β = 1-α).
    #[test]
    fn step_settles_with_defaults_in_time_consistent_with_kp() {
        let p = AxisParams::default();
        let dt = 0.001;
        let alpha = 1.0 - (-dt / p.velocity_lag).exp();
        let beta = 1.0 - alpha;
        let b = 1.0 + beta - alpha * p.kp * dt;
        let disc = b * b - 4.0 * beta;
        assert!(disc > 0.0);
        let z1 = 0.5 * (b + disc.sqrt()); // dominant (slowest) real root
        let rate = -z1.ln() / dt; // 1/s
        assert!(rate > p.kp && rate < 1.3 * p.kp, "rate {rate}");
        let t_theory = (1.0 / 1e-6_f64).ln() / rate;

        let mut ax = Axis::new(p, 0.0);
        let mut last_outside = 0;
        for k in 1..=2000 {
            ax.step(1.0, dt);
            if ax.following_error().abs() >= 1e-6 {
                last_outside = k;
            }
        }
        let t_settle = (last_outside + 1) as f64 * dt;
        assert!(
            t_settle > 0.8 * t_theory && t_settle < 1.25 * t_theory,
            "settled after {t_settle} s, theory {t_theory} s"
        );
        assert!((ax.position() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn stable_over_dt_kp_and_lag_range() {
        // Small step (0.1 mm) so that the loop stays mostly linear; the overshoot bound covers
        // the underdamped case kp 200, lag 5 ms (zeta = 0.5 -> 16 % overshoot).
        let s = 0.1;
        for &dt in &[0.0001, 0.0005, 0.001, 0.002] {
            for &kp in &[1.0, 60.0, 200.0] {
                for &lag in &[0.0, 0.0005, 0.002, 0.005] {
                    for &ff in &[0.0, 1.0] {
                        let params = AxisParams {
                            kp,
                            velocity_lag: lag,
                            velocity_feed_forward: ff,
                            ..AxisParams::default()
                        };
                        let mut ax = Axis::new(params, 0.0);
                        let n = ((20.0 / kp).max(1.0) / dt) as usize;
                        let mut max_abs = 0.0_f64;
                        for _ in 0..n {
                            ax.step(s, dt);
                            max_abs = max_abs.max(ax.position().abs());
                        }
                        let tag = format!("dt {dt} kp {kp} lag {lag} ff {ff}");
                        assert!(max_abs < 1.5 * s, "{tag}: max {max_abs}");
                        assert!(
                            (ax.position() - s).abs() < 1e-6 * s,
                            "{tag}: {}",
                            ax.position()
                        );
                        assert!(ax.velocity().abs() < 1e-4, "{tag}: v {}", ax.velocity());
                    }
                }
            }
        }
    }

    /// A large step with a stiff loop is limited by the drive (the axis overshoots because it
    /// cannot decelerate as fast as the P-loop asks), but it still settles.
    #[test]
    fn large_step_with_saturation_still_settles() {
        for &dt in &[0.0001, 0.001, 0.002] {
            let params = AxisParams {
                kp: 200.0,
                ..AxisParams::default()
            };
            let mut ax = Axis::new(params, 0.0);
            for _ in 0..(2.0 / dt) as usize {
                ax.step(100.0, dt);
                assert!(ax.position() < 130.0);
            }
            assert!(
                (ax.position() - 100.0).abs() < 1e-6,
                "dt {dt}: {}",
                ax.position()
            );
        }
    }

    #[test]
    fn invalid_dt_is_a_no_op_and_reset_works() {
        let mut ax = Axis::new(AxisParams::default(), 1.0);
        ax.step(5.0, 0.0);
        ax.step(5.0, -0.001);
        ax.step(5.0, f64::NAN);
        assert_eq!(ax.position(), 1.0);
        assert_eq!(ax.setpoint(), 1.0);
        ax.step(5.0, 0.001);
        assert!(ax.velocity() > 0.0);
        ax.reset(-3.0);
        assert_eq!(
            (ax.position(), ax.velocity(), ax.setpoint()),
            (-3.0, 0.0, -3.0)
        );
        assert_eq!(ax.following_error(), 0.0);
    }
}
