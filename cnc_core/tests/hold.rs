//! Feed hold, resume and abort in the executor: deceleration along the path
//! within the axis limits, a still hold, and an exact end after resuming.

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine, V3};

fn max_accel_ratio(s: &[Sample], m: &Machine) -> f64 {
    let dt = m.dt();
    let amax = m.amax();
    let v: Vec<V3> = s.windows(2).map(|w| (w[1].pos - w[0].pos) / dt).collect();
    v.windows(2)
        .map(|w| {
            let a = (w[1] - w[0]) / dt;
            (0..3).map(|i| a[i].abs() / amax[i]).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[test]
fn hold_decelerates_on_the_path_holds_still_and_resumes_to_the_exact_end() {
    let m = Machine::builtin_mill();
    // a line and a full circle (R20) at 100 mm/s
    let prog = "G00 X10 Y100\nG01 X200 Y100 F6000\nG02 X200 Y100 I0 J20\n";
    let mut ex = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m);
    let mut s: Vec<Sample> = Vec::new();
    // run into the line, then hold
    while s.len() < 1500 {
        s.push(ex.next_sample().unwrap());
    }
    let v_before = (s[1499].pos - s[1498].pos).norm() / m.dt();
    assert!((v_before - 100.0).abs() < 1e-6, "cruising at {v_before}");
    ex.set_feed_target(0.0);
    for _ in 0..500 {
        s.push(ex.next_sample().unwrap());
    }
    assert_eq!(ex.feed_scale(), 0.0);
    // 100 mm/s at 2000 mm/s² (the line runs between two stops, so it has
    // the whole acceleration) stops in 50 ms, 2.5 mm, plus the 0.95 mm
    // that the setpoint lags: a line from rest to rest runs with a path
    // filter of its own, ⌈a/(j·dt)⌉ = 2000 / (200 · 1) = 10 samples (at
    // X's 200 m/s³), and no XYZ filter: (10 − 1)/2 samples (in the cruise
    // the hold may decelerate at once: no acceleration in the window)
    let stop = s[1999].pos;
    let travelled = stop[0] - s[1499].pos[0];
    let b = m.jerk_budget();
    let own = (2000.0 / (b.j * m.dt()) - 1e-9).ceil();
    assert_eq!(own, 10.0);
    let lag = (own - 1.0) / 2.0 * 0.1;
    assert!(
        (travelled - 100.0 * 100.0 / (2.0 * 2000.0) - lag).abs() < 0.1,
        "{travelled}"
    );
    // held still for the last 400 samples, on the line
    assert!(
        s[1600..2000].iter().all(|x| x.pos == stop),
        "moved while held"
    );
    assert!(
        s.iter()
            .filter(|x| x.src.line == 2)
            .all(|x| x.pos[1] == 100.0 && x.pos[2] == 0.0),
        "left the path"
    );
    // resume and hold again inside the circle
    ex.set_feed_target(1.0);
    while s.last().unwrap().src.line != 3 {
        s.push(ex.next_sample().unwrap());
    }
    for _ in 0..300 {
        s.push(ex.next_sample().unwrap());
    }
    ex.set_feed_target(0.0);
    for _ in 0..300 {
        s.push(ex.next_sample().unwrap());
    }
    ex.set_feed_target(1.0);
    while let Some(x) = ex.next_sample() {
        s.push(x);
    }
    // every sample of the circle on the circle, through hold and resume:
    // the path filter keeps it on the circle, the XYZ filter (M = 6)
    // pulls it inside by at most v²(M²−1)dt²/(24 r) = 100²·35·1e-6/480
    // = 0.73 µm
    assert_eq!(b.m_f, 6);
    for x in s.iter().filter(|x| x.src.line == 3) {
        let r = ((x.pos[0] - 200.0).powi(2) + (x.pos[1] - 120.0).powi(2)).sqrt();
        assert!(
            r <= 20.0 + 1e-9 && 20.0 - r < 7.3e-4,
            "off the circle by {}",
            r - 20.0
        );
    }
    assert_eq!(s.last().unwrap().pos, V3::new(200.0, 100.0, 0.0));
    assert!(s.last().unwrap().last);
    let ra = max_accel_ratio(&s, &m);
    assert!(ra <= 1.0 + 1e-6, "acceleration at {ra} of the limit");
    for (i, x) in s.iter().enumerate() {
        assert_eq!(x.k, i as u64);
    }
}

#[test]
fn without_hold_the_samples_are_the_unscaled_ones() {
    let m = Machine::builtin_mill();
    let prog = "G00 X10 Y100\nG01 X50 Y100 F6000\nG04 P0.2\nG02 X50 Y100 I0 J20\n";
    let a: Vec<Sample> = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m).collect();
    let mut ex = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m);
    ex.set_feed_target(1.0);
    let b: Vec<Sample> = ex.collect();
    assert_eq!(a, b);
    let r = cnc_core::check(StrSource::new(prog), Dialect::Cnc836, &m);
    assert_eq!(a.last().unwrap().k, r.ticks);
}

/// The feed override: 50 % halves the cruise, 150 % raises it, 200 % stops
/// at the axis's velocity limit; the planned deceleration is kept, every
/// sample within the acceleration and jerk limits, the end exact.
#[test]
fn feed_override_scales_the_cruise_within_every_limit() {
    let m = Machine::builtin_mill();
    let dt = m.dt();
    // 300 mm in X at F9000 = 150 mm/s; X allows 250 mm/s
    let prog = "G00 X10 Y10\nG01 X310 F9000\n";
    let speeds = |ovr: f64| {
        let mut ex = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m);
        ex.set_feed_target(ovr);
        let s: Vec<Sample> = ex.collect();
        let v: Vec<f64> = s
            .windows(2)
            .filter(|w| w[1].src.line == 2)
            .map(|w| (w[1].pos[0] - w[0].pos[0]) / dt)
            .collect();
        let top = v.iter().cloned().fold(0.0, f64::max);
        assert_eq!(s.last().unwrap().pos, V3::new(310.0, 10.0, 0.0));
        let ra = max_accel_ratio(&s, &m);
        assert!(ra <= 1.0 + 1e-6, "{ovr}: acceleration at {ra} of the limit");
        (top, s.len())
    };
    let (v100, n100) = speeds(1.0);
    assert!((v100 - 150.0).abs() < 1e-6, "{v100}");
    let (v50, n50) = speeds(0.5);
    assert!((v50 - 75.0).abs() < 1e-6, "{v50}");
    let (v150, n150) = speeds(1.5);
    assert!((v150 - 225.0).abs() < 1e-6, "{v150}");
    let (v200, n200) = speeds(2.0);
    assert!((v200 - 250.0).abs() < 1e-6, "{v200}");
    // 300 mm: at 75 mm/s about 2 s longer, at 225 about 0.67 s shorter
    assert!(
        n50 > n100 + 1900 && n150 + 600 < n100 && n200 < n150,
        "{n50} {n100} {n150} {n200}"
    );
}

/// Largest sampled jerk of X, mm/s³.
fn max_jerk_x(s: &[Sample], dt: f64) -> f64 {
    s.windows(4)
        .map(|w| (w[3].pos[0] - 3.0 * w[2].pos[0] + 3.0 * w[1].pos[0] - w[0].pos[0]).abs())
        .fold(0.0, f64::max)
        / (dt * dt * dt)
}

/// Runs `prog`, setting the feed target to `level` at sample `at` and
/// back to 1 at `back`.
fn run_with(m: &Machine, prog: &str, at: usize, level: f64, back: usize) -> Vec<Sample> {
    let mut ex = Executor::new(StrSource::new(prog), Dialect::Cnc836, m);
    let mut s = Vec::new();
    while let Some(x) = ex.next_sample() {
        s.push(x);
        if s.len() == at {
            ex.set_feed_target(level);
        } else if s.len() == back {
            ex.set_feed_target(1.0);
        }
    }
    s
}

/// A line run from rest to rest has a path filter of its own sized for
/// steps of a (10 samples on the bundled mill's X at 200 m/s³): a feed
/// hold while it speeds up may not turn +a into −a within that window
/// (2·a over 10 ms is twice the jerk limit). It first stops speeding up
/// (for the window), then decelerates; a resume just before the line's
/// planned deceleration rises only to √½ at a/2, so that it meets that
/// deceleration within the window too. The jerk stays at the limit.
#[test]
fn a_hold_on_a_line_from_rest_to_rest_keeps_its_own_filters_window() {
    let m = Machine::builtin_mill();
    let dt = m.dt();
    let prog = "G01 X100 F6000\n";
    // the line: a tick's wait, 50 ms up to 100 mm/s, its filter 10 ms
    // behind; a hold 30 ms into it, while it accelerates at 2000 mm/s²
    let s = run_with(&m, prog, 31, 0.0, 400);
    let a = |k: usize| (s[k].pos[0] - 2.0 * s[k - 1].pos[0] + s[k - 2].pos[0]) / (dt * dt);
    let jerk = max_jerk_x(&s, dt);
    assert!(jerk <= 2e5 * (1.0 + 1e-6), "{jerk} mm/s³");
    // (the raw path stops speeding up for the filter's window, then
    // decelerates at 2000 mm/s²: the setpoints' acceleration falls from
    // 2000 to 0 over 10 samples and on to −2000 over the next 10, the
    // limit's 200 mm/s² a sample; without the window it fell at twice that)
    let near = |x: f64, want: f64| (x - want).abs() < 1e-6;
    assert!(
        near(a(31), 2000.0) && near(a(41), 0.0) && near(a(51), -2000.0),
        "{} {} {}",
        a(31),
        a(41),
        a(51)
    );
    assert_eq!(s.last().unwrap().pos, V3::new(100.0, 0.0, 0.0));
    // held 50 ms before the deceleration would start (at 1.001 s), so
    // that it stops just before it, and resumed 80 ms later: at a from
    // rest to 1 it would meet the deceleration's −a within the window
    // (twice the limit); it rises to √½ at a/2
    let s = run_with(&m, prog, 950, 0.0, 1030);
    let jerk = max_jerk_x(&s, dt);
    assert!(jerk <= 2e5 * (1.0 + 1e-6), "{jerk} mm/s³");
    let ra = max_accel_ratio(&s, &m);
    assert!(ra <= 1.0 + 1e-6, "acceleration at {ra} of the limit");
    assert_eq!(s.last().unwrap().pos, V3::new(100.0, 0.0, 0.0));
}
