//! The thread module's tests (a file of their own: thread.rs would be
//! over 800 lines).
use super::*;
use crate::canon::Src;

fn seg(len: f64, pitch: f64) -> ThreadSeg {
    let start = V3::new(10.0, 0.0, 5.0);
    let end = V3::new(10.0, 0.0, 5.0 - len);
    ThreadSeg {
        start,
        prog_end: end,
        end,
        lead: 2,
        len,
        pitch,
        runout: None,
    }
}

#[test]
fn run_in_merges_into_the_line_and_the_deceleration_ends_on_the_point() {
    let m = ThreadMove {
        seg: seg(20.0, 1.5),
        src: Src::default(),
        rpm: 800.0,
        runin: Some((0.5, 0.8)),
        decel: Some(0.6),
        accel: 1000.0,
        jerk: f64::INFINITY,
    };
    // before the run-in: at rest at the start
    assert_eq!(m.u_at(-0.41), 0.0);
    // at the end of the run-in the parabola meets the line: same u, same slope
    let x = 0.4;
    assert!((m.u_at(x) - 1.5 * x).abs() < 1e-12);
    assert!((m.u_at(x - 1e-9) - 1.5 * (x - 1e-9)).abs() < 1e-12);
    assert_eq!(m.du_dx(x + 1e-9), 1.5);
    // on the line
    assert!((m.u_at(5.0) - 7.5).abs() < 1e-12);
    // the deceleration ends at the end point at rest
    assert_eq!(m.u_at(m.end_x()), 20.0);
    assert!(m.du_dx(m.end_x() - 1e-9) < 1e-8);
    // and leaves the line tangentially
    let xl = 20.0 / 1.5 - 0.3;
    assert!((m.u_at(xl) - 1.5 * xl).abs() < 1e-12);
    // sync: the start angle I = 0.5 rev after the index at 3.0 revs,
    // with the run-in starting 0.4 rev earlier and not before now
    assert_eq!(m.sync_angle(3.0, 3.0), 3.5);
    assert_eq!(m.sync_angle(3.2, 3.0), 4.5);
    assert_eq!(m.sync_angle(2.1, 1.0), 2.5);
}

#[test]
fn the_s_ramp_is_continuous_symmetric_and_keeps_its_jerk() {
    // c = 0: the parabola, bit for bit
    for y in [0.0, 0.1, 0.37, 0.8] {
        let (r, w) = (1.5, 0.8);
        assert_eq!(s_ramp(y, r, w, 0.0), (r * y * y / (2.0 * w), r * y / w));
    }
    // a trapezoid (c < w/2) and a triangle (c = w/2) of acceleration
    for (r, w, c) in [(1.5, 0.9, 0.2), (-0.577, 0.035, 0.0175), (2.0, 1.0, 0.5)] {
        let a = r / (w - c);
        let j = a / c;
        // the ends: at rest, and on the line of slope r through w/2
        assert_eq!(s_ramp(0.0, r, w, c), (0.0, 0.0));
        let (u, du) = s_ramp(w, r, w, c);
        assert!((u - 0.5 * r * w).abs() < 1e-15 && du == r, "{u} {du}");
        assert_eq!(s_ramp(-1.0, r, w, c), (0.0, 0.0));
        assert_eq!(s_ramp(w + 1.0, r, w, c), (0.5 * r * w, r));
        // numerically: slope = d(value), curvature within |a|, its
        // change within |j|, continuous through the phase boundaries
        let n = 20_000;
        let h = w / n as f64;
        let at = |k: usize| s_ramp(k as f64 * h, r, w, c);
        let mut d2 = Vec::new();
        for k in 0..n {
            let ((u0, s0), (u1, s1)) = (at(k), at(k + 1));
            assert!(
                ((u1 - u0) / h - 0.5 * (s0 + s1)).abs() < 1e-6,
                "{r} {w} {c} {k}"
            );
            d2.push((s1 - s0) / h);
        }
        assert!(
            d2.iter().all(|x| x.abs() <= a.abs() * (1.0 + 1e-9)),
            "{r} {w} {c}"
        );
        // s_ramp_curvature is that second derivative
        for (k, x) in d2.iter().enumerate() {
            let y = (k as f64 + 0.5) * h;
            assert!(
                (s_ramp_curvature(y, r, w, c) - x).abs() <= j.abs() * h,
                "{r} {w} {c} {y}"
            );
        }
        assert_eq!(s_ramp_curvature(-h, r, w, c), 0.0);
        let peak = d2.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!((peak - a.abs()).abs() < 1e-3 * a.abs(), "{peak} {a}");
        for p in d2.windows(2) {
            assert!(
                ((p[1] - p[0]) / h).abs() <= j.abs() * (1.0 + 1e-6),
                "{r} {w} {c}"
            );
        }
        // symmetric: the slope at w - y is r minus the slope at y
        for y in [0.1 * c, c, 0.5 * w, w - c] {
            assert!((s_ramp(w - y, r, w, c).1 - (r - s_ramp(y, r, w, c).1)).abs() < 1e-12);
        }
    }
}

#[test]
fn a_run_in_under_a_jerk_limit_is_an_s_curve_of_its_time() {
    // no jerk limit: the parabola's Δ = pitch ω² / a
    let (w_p, pitch, a) = (800.0 * 1.05 / 60.0, 1.5, 2000.0);
    assert_eq!(
        ramp_revs(pitch, w_p, a, f64::INFINITY),
        (pitch * w_p * w_p / a, 0.0)
    );
    // 21 mm/s at 2000 mm/s² and 160 m/s³: a triangle of 2·√(21/160000) s
    let (d, c) = ramp_revs(pitch, w_p, a, 1.6e5);
    let tj = (21.0f64 / 1.6e5).sqrt();
    assert!((c - tj * w_p).abs() < 1e-12 && (d - 2.0 * c).abs() < 1e-12);
    // 35 mm/s (F1 at 2000 rpm + 5 %): 35/2000 + 2000/160000 = 30 ms
    let w_p = 2000.0 * 1.05 / 60.0;
    let (d, c) = ramp_revs(1.0, w_p, a, 1.6e5);
    assert!((d / w_p - 0.03).abs() < 1e-12 && (c / w_p - 0.0125).abs() < 1e-12);
    // the run-in's lead travel in time: from rest, jerk 160 m/s³ at
    // first, on the line after d/2 past θ₀
    let m = ThreadMove {
        seg: seg(20.0, 1.0),
        src: Src::default(),
        rpm: 2000.0,
        runin: Some((0.0, d)),
        decel: Some(d),
        accel: a,
        jerk: 1.6e5,
    };
    assert_eq!(m.jerk_phase(), c);
    let t = 0.001; // 1 ms into the run-in
    let u = m.u_at(-0.5 * d + t * w_p);
    assert!((u - 1.6e5 * t * t * t / 6.0).abs() < 1e-12, "{u}");
    assert_eq!(m.at(0.5 * d), (0.5 * d, 1.0));
    assert_eq!(m.du_dx(0.5 * d + 1e-9), 1.0);
    assert_eq!(m.u_at(m.end_x()), 20.0);
}

#[test]
fn runout_ends_j_tan_alpha_away_with_a_smooth_kink() {
    let mut s = seg(43.0, 1.0);
    let tan = 30f64.to_radians().tan();
    s.runout = Some(RunoutPath {
        axis: 0,
        from: 40.0,
        tan,
        blend: 0.4,
        jerk_phase: 0.0,
    });
    s.end[0] += 3.0 * tan;
    assert_eq!(s.pos(43.0), s.end);
    assert!((s.pos(42.99)[0] - (10.0 + 2.99 * tan)).abs() < 1e-12);
    assert_eq!(s.pos(39.8)[0], 10.0);
    // continuous value and slope through the blend
    let r = s.runout.unwrap();
    for u in [39.8, 40.2] {
        let e = 1e-7;
        assert!((r.offset(u + e) - r.offset(u - e)).abs() < 2.0 * e * tan + 1e-12);
    }
    assert!((r.offset(40.2) - 0.2 * tan).abs() < 1e-12);
}

/// The acceleration lead's weight: 0 where the run-in meets the line,
/// 1 from 20 ms of the programmed speed after it (at S800, 0.2667 rev)
/// to as long before the deceleration, 0 where that begins, half-way
/// at the middle of each ease; an inner block of a chain (no run-in,
/// no deceleration) takes the whole lead everywhere.
#[test]
fn the_acceleration_lead_eases_in_after_the_run_in_and_out_before_the_deceleration() {
    let m = ThreadMove {
        seg: seg(20.0, 1.5),
        src: Src::default(),
        rpm: -800.0,
        runin: Some((0.5, 0.8)),
        decel: Some(0.6),
        accel: 1000.0,
        jerk: f64::INFINITY,
    };
    // the line runs from x = 0.4 to 20/1.5 - 0.3 = 13.0333 rev
    let (a, b, ease) = (0.4, 20.0 / 1.5 - 0.3, 800.0 / 60.0 * 0.02);
    assert_eq!(m.accel_lead_weight(a), 0.0);
    assert_eq!(m.accel_lead_weight(a - 0.1), 0.0);
    assert!((m.accel_lead_weight(a + 0.5 * ease) - 0.5).abs() < 1e-12);
    assert_eq!(m.accel_lead_weight(a + ease), 1.0);
    assert_eq!(m.accel_lead_weight(6.0), 1.0);
    assert_eq!(m.accel_lead_weight(b - ease), 1.0);
    assert!((m.accel_lead_weight(b - 0.5 * ease) - 0.5).abs() < 1e-12);
    assert_eq!(m.accel_lead_weight(b), 0.0);
    // (no slope at the ends: a tenth of the ease in, 0.0086)
    assert!((m.accel_lead_weight(a + 0.1 * ease) - 0.00856).abs() < 1e-12);
    let inner = ThreadMove {
        runin: None,
        decel: None,
        ..m
    };
    for x in [-1.0, 0.0, 0.4, 6.0, 13.3] {
        assert_eq!(inner.accel_lead_weight(x), 1.0);
    }
}

/// The lead's acceleration at 1 kHz averages the last 8 values with
/// sin² weights (0.038, 0.309, 0.691, 0.962 and back, summing to 4):
/// a constant passes unchanged, a step rises over 8 cycles in an S
/// (no step of its own), and while fewer values than the window are
/// there the average is over those.
#[test]
fn the_lead_s_acceleration_is_a_weighted_average_over_8_ms() {
    let mut a = LeadAccel::new(0.001);
    assert_eq!(a.push(5.0), 5.0);
    for _ in 0..10 {
        assert!((a.push(5.0) - 5.0).abs() < 1e-12);
    }
    a.reset();
    for _ in 0..8 {
        a.push(0.0);
    }
    let got: Vec<f64> = (0..9).map(|_| a.push(1.0)).collect();
    let want = [
        0.00952, 0.08671, 0.25954, 0.5, 0.74046, 0.91329, 0.99048, 1.0, 1.0,
    ];
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 1e-4, "{got:?}");
    }
    // two values of eight: their weights' average
    a.reset();
    a.push(2.0);
    let w = [0.03806, 0.30866];
    let expect = (w[0] * 4.0 + w[1] * 2.0) / (w[0] + w[1]);
    assert!((a.push(4.0) - expect).abs() < 1e-4);
}
