//! The path planner (`[planner] method = "path"`) end to end: a program of
//! rapids, feed lines, an arc, a sharp corner, a dwell and a G61 stretch,
//! checked and run on bench/motion's mill at a realistic jerk. Values in
//! mm.

use cnc_core::exec::{Executor, Sample};
use cnc_core::machine::PlanMethod;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};

/// bench/motion's mill (100 mm/s, 1000 mm/s²) at `jerk` mm/s³, planned by
/// the path planner.
fn machine(jerk: f64) -> Machine {
    let mut m = Machine::builtin_mill();
    for a in &mut m.axes {
        a.max_velocity_mm_s = 100.0;
        a.max_acceleration_mm_s2 = 1000.0;
        a.max_jerk_mm_s3 = Some(jerk);
    }
    m.planner.method = PlanMethod::Path;
    m
}

const PROGRAM: &str = "\
N10 G17 G90 G94 M03 S3000 T1
N20 G00 X20 Y10 Z5
N30 G64 P0.01
N40 G01 Z-2 F300
N50 X80 F6000
N60 G03 X90 Y20 I0 J10
N70 G01 Y60
N80 X60 Y40
N90 G04 P0.5
N100 G61
N110 G01 X20 Y40 F3000
N120 Y10
N130 G00 Z5
N140 M30
";

/// Distance from `p` to the segment `a`-`b`.
fn seg(p: V3, a: V3, b: V3) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
    (p - (a + d * t)).norm()
}

/// Distance from `p` to the quarter arc of N60 (centre X80 Y20, R10, from
/// -90° to 0°, at Z-2).
fn arc(p: V3) -> f64 {
    let (dx, dy) = (p.x - 80.0, p.y - 20.0);
    let a = dy.atan2(dx);
    if (-std::f64::consts::FRAC_PI_2..=0.0).contains(&a) {
        ((dx.hypot(dy) - 10.0).hypot(p.z + 2.0)).abs()
    } else {
        (p - V3::new(80.0, 10.0, -2.0))
            .norm()
            .min((p - V3::new(90.0, 20.0, -2.0)).norm())
    }
}

/// Asserts every axis within 100 mm/s, 1000 mm/s² and `jerk` at every
/// sample (the samples' differences).
fn within_limits(s: &[Sample], m: &Machine, jerk: f64) {
    let dt = m.dt();
    for w in s.windows(4) {
        for i in 0..3 {
            let p = [w[0].pos[i], w[1].pos[i], w[2].pos[i], w[3].pos[i]];
            let v = (p[3] - p[2]) / dt;
            let a = (p[3] - 2.0 * p[2] + p[1]) / (dt * dt);
            let j = (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]) / (dt * dt * dt);
            assert!(v.abs() <= 100.0 + 1e-9, "v {v} at k={} ({jerk})", w[3].k);
            assert!(a.abs() <= 1000.0 + 1e-6, "a {a} at k={} ({jerk})", w[3].k);
            assert!(
                j.abs() <= jerk * (1.0 + 1e-9),
                "j {j} at k={} ({jerk})",
                w[3].k
            );
        }
    }
}

/// The largest distance of the samples of N40 to N80 (lines 4 to 8,
/// under G64 P0.01) from their programmed path.
fn off_path(s: &[Sample]) -> f64 {
    let pts = [
        V3::new(20.0, 10.0, 5.0),
        V3::new(20.0, 10.0, -2.0),
        V3::new(80.0, 10.0, -2.0),
    ];
    let mut worst: f64 = 0.0;
    for x in s.iter().filter(|x| (4..=8).contains(&x.src.line)) {
        let d = seg(x.pos, pts[1], pts[2])
            .min(seg(x.pos, pts[0], pts[1]))
            .min(arc(x.pos))
            .min(seg(
                x.pos,
                V3::new(90.0, 20.0, -2.0),
                V3::new(90.0, 60.0, -2.0),
            ))
            .min(seg(
                x.pos,
                V3::new(90.0, 60.0, -2.0),
                V3::new(60.0, 40.0, -2.0),
            ));
        worst = worst.max(d);
    }
    worst
}

fn run(m: &Machine) -> (Vec<Sample>, u64) {
    let r = check(StrSource::new(PROGRAM), Dialect::Cnc836, m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(PROGRAM), Dialect::Cnc836, m).collect();
    (s, r.ticks)
}

#[test]
fn the_path_planner_runs_a_program_as_the_check_said_within_every_limit_and_p() {
    for jerk in [2e4, 5e4, 1e6] {
        let m = machine(jerk);
        let (s, ticks) = run(&m);
        // the estimate is the run, to the tick; the end exact
        let last = s.last().unwrap();
        assert!(last.last);
        assert_eq!(last.k, ticks, "at {jerk}");
        assert_eq!(last.pos, V3::new(20.0, 10.0, 5.0));
        for (i, x) in s.iter().enumerate() {
            assert_eq!(x.k, i as u64);
        }
        // every axis within its velocity, acceleration and jerk at every
        // sample (the samples' differences)
        within_limits(&s, &m, jerk);
        // within P of the programmed path under G64 P0.01 (N40 to N80:
        // lines 4 to 8)
        let worst = off_path(&s);
        assert!(worst <= 0.01 && worst > 0.001, "{worst} mm at {jerk}");
        // the corner at X90 Y60 turns by 146°: an exact stop on it
        let at = |p: V3| s.iter().filter(|x| x.pos == p).count();
        assert!(
            at(V3::new(90.0, 60.0, -2.0)) >= 1,
            "no stop at the corner ({jerk})"
        );
        // the dwell: half a second standing on N80's end
        assert!(
            at(V3::new(60.0, 40.0, -2.0)) >= 500,
            "{}",
            at(V3::new(60.0, 40.0, -2.0))
        );
        // under G61 the lines are exact: every sample of N110 and N120
        // (lines 11 and 12) on its line
        let mut w = 0.0f64;
        for x in s.iter().filter(|x| x.src.line == 11) {
            w = w.max(seg(
                x.pos,
                V3::new(60.0, 40.0, -2.0),
                V3::new(20.0, 40.0, -2.0),
            ));
        }
        for x in s.iter().filter(|x| x.src.line == 12) {
            w = w.max(seg(
                x.pos,
                V3::new(20.0, 40.0, -2.0),
                V3::new(20.0, 10.0, -2.0),
            ));
        }
        // (G61 is P 1 µm here; its 90° corner stops, and a line between
        // stops stays straight: 1.7e-11 mm of rounding)
        assert!(w < 1e-9, "{w} mm off a G61 line at {jerk}");
        // the spindle and the tool as programmed
        assert!(s[10..]
            .iter()
            .all(|x| x.spindle_rpm == 3000.0 && x.tool == 1));
    }
}

/// A polyline of 120 chords of R50, each turning by 0.5° (a CAM arc, 52
/// mm at F3000) under G61 at 50 m/s³: its fine kinks are passed within the
/// 1 µm an exact path may be off (`path_run::P_MIN`), not each at rest.
#[test]
fn under_g61_a_polyline_s_fine_kinks_are_passed_within_1_um() {
    let m = machine(5e4);
    let at = |k: usize| {
        let a = (k as f64 * 0.5).to_radians();
        V3::new(50.0 * a.cos(), 50.0 * a.sin(), 0.0)
    };
    let mut text = String::from("G17 G90 G94 G61\nG00 X50 Y0 Z0\nG01 F3000\n");
    for k in 1..=120 {
        let p = at(k);
        text += &format!("X{} Y{}\n", p.x, p.y);
    }
    text += "M30\n";
    let r = check(StrSource::new(&text), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(&text), Dialect::Cnc836, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    assert_eq!(s.last().unwrap().pos, at(120));
    within_limits(&s, &m, 5e4);
    let feed: Vec<&Sample> = s.iter().filter(|x| x.src.line >= 4).collect();
    let off = feed
        .iter()
        .map(|x| {
            (1..=120)
                .map(|k| seg(x.pos, at(k - 1), at(k)))
                .fold(f64::MAX, f64::min)
        })
        .fold(0.0, f64::max);
    assert!(off <= 0.001 + 1e-9, "{off} mm off the polyline");
    // at F3000 over the middle half, no stop at any vertex: 1.747 s with
    // the rapid (before, every vertex a stop: 8.639 s)
    let dt = m.dt();
    let mid = &feed[feed.len() / 4..3 * feed.len() / 4];
    let slowest = mid
        .windows(2)
        .map(|w| (w[1].pos - w[0].pos).norm() / dt)
        .fold(f64::MAX, f64::min);
    assert!(slowest > 49.9, "{slowest} mm/s");
    assert_eq!(r.ticks, 1747);
}

#[test]
fn at_50_m_s3_the_path_planner_is_faster_than_the_filters() {
    let path = run(&machine(5e4)).1;
    let mut m = machine(5e4);
    m.planner.method = PlanMethod::Filters;
    let r = check(StrSource::new(PROGRAM), Dialect::Cnc836, &m);
    assert!(r.ok());
    // (measured: 5.786 s against 6.054 s)
    assert!(path < r.ticks, "path {path} ticks, filters {}", r.ticks);
}

#[test]
fn a_feed_hold_brakes_the_path_planner_along_its_path_and_resume_goes_on() {
    let m = machine(5e4);
    let mut ex = Executor::new(StrSource::new(PROGRAM), Dialect::Cnc836, &m);
    let mut s: Vec<Sample> = Vec::new();
    // held from the start: nothing moves for 300 samples
    ex.set_feed_target(0.0);
    let mut held_at = Vec::new();
    while let Some(x) = ex.next_sample() {
        if s.len() == 300 {
            ex.set_feed_target(1.0);
        }
        // held again while moving, three times: the run brakes to rest on
        // its path within every limit, stands, and goes on when resumed
        for at in [1500, 2600, 4200] {
            if s.len() == at {
                assert!(x.path_speed > 1.0, "at {at}: {}", x.path_speed);
                held_at.push(at);
                ex.set_feed_target(0.0);
            }
            if s.len() == at + 800 {
                ex.set_feed_target(1.0);
            }
        }
        s.push(x);
        assert!(s.len() < 40_000, "no end");
    }
    assert_eq!(held_at.len(), 3);
    assert!(s[..300].iter().all(|x| x.pos == s[0].pos));
    // each hold: at rest within 300 samples, for the rest of the 800
    for at in [1500usize, 2600, 4200] {
        let still = (at..at + 800)
            .find(|&i| s[i].pos == s[i + 1].pos && s[i..at + 800].iter().all(|x| x.pos == s[i].pos))
            .unwrap_or_else(|| panic!("no stand after {at}"));
        assert!(still < at + 300, "at rest only at {still} after {at}");
    }
    within_limits(&s, &m, 5e4);
    let worst = off_path(&s);
    assert!(worst <= 0.01, "{worst}");
    assert_eq!(s.last().unwrap().pos, V3::new(20.0, 10.0, 5.0));
}

/// `m` run to its end, the feed override set (0: held) at the samples
/// `toggles` names, on the executor's thread or planned ahead on threads
/// of their own.
fn run_with_holds(
    m: &Machine,
    program: &str,
    toggles: &[(usize, f64)],
    ahead: bool,
) -> Vec<Sample> {
    let mut ex = Executor::new(StrSource::new(program), Dialect::Cnc836, m);
    if ahead {
        ex.plan_ahead(|| {});
    }
    let mut s: Vec<Sample> = Vec::new();
    while let Some(x) = ex.next_sample() {
        for &(at, target) in toggles {
            if s.len() == at {
                ex.set_feed_target(target);
            }
        }
        s.push(x);
        assert!(s.len() < 100_000, "no end");
    }
    assert_eq!(ex.fault(), None);
    s
}

/// A long smooth run (a polygon of 400 short lines round an R20 circle,
/// then tangent arcs) after the mixed program's moves.
fn long_program() -> String {
    let mut p = String::from("N1 G17 G90 G94 G64 P0.01\nN2 G00 X20 Y0 Z0\nN3 G01 F6000\n");
    for i in 1..=400 {
        let a = i as f64 * std::f64::consts::TAU / 400.0;
        p += &format!("X{:.4} Y{:.4}\n", 20.0 * a.cos(), 20.0 * a.sin());
    }
    p += "G02 X40 Y0 I10 J0\nG03 X60 Y0 I10 J0\nG01 X60 Y-10\nG00 Z5\nM30\n";
    p
}

#[test]
fn planned_ahead_on_its_own_threads_the_samples_are_the_same_feed_holds_included() {
    let m = machine(5e4);
    let long = long_program();
    // holds of every length (down to 1 sample: resumed while braking), at
    // run starts, in runs and near their ends, from a fixed sequence
    let mut toggles = Vec::new();
    let mut r: u64 = 12345;
    let mut at = 100;
    while at < 9000 {
        r = r
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let hold = 1 + (r >> 33) as usize % 400;
        toggles.push((at, 0.0));
        toggles.push((at + hold, 1.0));
        at += hold + 50 + (r >> 50) as usize % 700;
    }
    for (name, program) in [("mixed", PROGRAM), ("long", long.as_str())] {
        for holds in [&[][..], &toggles[..]] {
            let here = run_with_holds(&m, program, holds, false);
            let ahead = run_with_holds(&m, program, holds, true);
            assert_eq!(here.len(), ahead.len(), "{name}, {} toggles", holds.len());
            if let Some(i) = (0..here.len()).find(|&i| here[i].pos != ahead[i].pos) {
                panic!(
                    "{name}, {} toggles: sample {i} at {:?} ahead, {:?} here",
                    holds.len(),
                    ahead[i].pos,
                    here[i].pos
                );
            }
            assert_eq!(here.last().map(|x| x.k), ahead.last().map(|x| x.k));
        }
    }
    // (the holds did land while moving: the run is longer held than not)
    let free = run_with_holds(&m, &long, &[], true).len();
    let held = run_with_holds(&m, &long, &toggles, true).len();
    assert!(held > free + 1000, "{held} against {free}");
}

/// The path speed at sample `i`, mm/s.
fn speed(s: &[Sample], i: usize, dt: f64) -> f64 {
    (s[i].pos - s[i - 1].pos).norm() / dt
}

#[test]
fn the_feed_override_scales_the_path_planner_s_feed_from_0_1_s_on_within_every_limit() {
    let m = machine(5e4);
    let dt = m.dt();
    let long = long_program();
    let free = run_with_holds(&m, &long, &[], false);
    // 200 samples into the circle's cruise at F6000 (100 mm/s)
    let k0 = (1..free.len())
        .find(|&i| (4..=403).contains(&free[i].src.line) && speed(&free, i, dt) > 99.9)
        .expect("a cruise")
        + 200;
    let toggles = [(k0, 0.4), (k0 + 1500, 1.5), (k0 + 2500, 1.0)];
    let s = run_with_holds(&m, &long, &toggles, false);
    // not before 0.1 s; then down to 40 mm/s and steady
    assert_eq!(s[..k0 + 100], free[..k0 + 100]);
    assert!(speed(&s, k0 + 100, dt) > 99.9);
    for i in [k0 + 400, k0 + 800] {
        let v = speed(&s, i, dt);
        assert!((v - 40.0).abs() < 0.2, "{v} mm/s at {i}");
    }
    // every limit, the path within P, the end exact, and slower
    within_limits(&s, &m, 5e4);
    assert_eq!(s.last().unwrap().pos, V3::new(60.0, -10.0, 5.0));
    for x in s.iter().filter(|x| (4..=403).contains(&x.src.line)) {
        let r = x.pos.x.hypot(x.pos.y);
        assert!((r - 20.0).abs() < 0.01 + 0.0025, "r {r} at k={}", x.k);
    }
    assert!(
        s.len() > free.len() + 500,
        "{} against {}",
        s.len(),
        free.len()
    );
    // planned ahead: the same samples, with holds among the changes
    let mixed = [
        (k0, 0.4),
        (k0 + 300, 0.0),
        (k0 + 420, 0.7),
        (k0 + 460, 1.2),
        (k0 + 900, 0.0),
        (k0 + 901, 1.0),
    ];
    let here = run_with_holds(&m, &long, &mixed, false);
    let ahead = run_with_holds(&m, &long, &mixed, true);
    assert_eq!(here.len(), ahead.len());
    if let Some(i) = (0..here.len()).find(|&i| here[i].pos != ahead[i].pos) {
        panic!(
            "sample {i}: {:?} ahead, {:?} here",
            ahead[i].pos, here[i].pos
        );
    }
    within_limits(&here, &m, 5e4);
    // resumed from the hold at 70 %: at once, not 0.1 s later (until the
    // 120 % asked at k0 + 460 comes, 0.1 s after it)
    let fastest = (k0 + 421..k0 + 560)
        .map(|i| speed(&here, i, dt))
        .fold(0.0, f64::max);
    assert!(
        fastest <= 70.0 + 1e-6,
        "{fastest} mm/s after the resume at 70 %"
    );
    assert!(fastest > 50.0, "{fastest} mm/s: resumed");
}

/// `N30 G95 F0.2` at S600 on the bundled lathe (50 m/s³) with the path
/// planner, following an encoder that reads `rpm` throughout: the samples
/// (on the executor's thread, or planned ahead).
fn per_rev_run(rpm: f64, ahead: bool) -> Vec<Sample> {
    let mut m = Machine::builtin_lathe();
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = Some(5e4);
    }
    m.planner.method = PlanMethod::Path;
    let program = "N10 G00 X20 Z5\nN20 M03 S600\nN30 G95 G01 Z-3 F0.2\nN40 G00 X30\nN50 M30\n";
    let mut ex = Executor::new(StrSource::new(program), Dialect::Cnc836, &m);
    ex.attach_encoder();
    if ahead {
        ex.plan_ahead(|| {});
    }
    let dt = m.dt();
    let mut s: Vec<Sample> = Vec::new();
    loop {
        let t = s.len() as f64 * dt;
        ex.encoder(cnc_core::tracker::EncoderReading {
            t,
            count: (rpm / 60.0 * t * 4096.0) as i64,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: 0,
        });
        let Some(x) = ex.next_sample() else { break };
        s.push(x);
        assert!(s.len() < 60_000, "no end");
    }
    assert_eq!(ex.fault(), None);
    s
}

#[test]
fn under_g95_the_path_planner_follows_the_measured_spindle() {
    let dt = Machine::builtin_lathe().dt();
    for (rpm, want) in [(600.0, 2.0), (300.0, 1.0)] {
        let s = per_rev_run(rpm, false);
        let on: Vec<usize> = (1..s.len()).filter(|&i| s[i].src.line == 3).collect();
        let mid = on[on.len() / 2];
        let v = speed(&s, mid, dt);
        assert!(
            (v - want).abs() < 0.01 * want,
            "{v} mm/s at {rpm} rpm, {want} wanted"
        );
        // the middle half of the cut: the feed within the measured speed's
        // steps (0.5 %, `exec::PER_REV_STEP`) and no jerk that flips from
        // sample to sample (before the approach onto the cap and the
        // override's way down, 0.9708 mm/s of 1.0 at 300 rpm and 848 and
        // 1,544 flips over 10 m/s³ at 600 and 300 rpm)
        let half = &on[on.len() / 4..3 * on.len() / 4];
        let jerk = |k: usize| {
            let z = |i: usize| s[i].pos.z;
            (z(k) - 3.0 * z(k - 1) + 3.0 * z(k - 2) - z(k - 3)) / (dt * dt * dt)
        };
        for w in half.windows(2) {
            let v = speed(&s, w[1], dt);
            assert!((v - want).abs() <= 0.005 * want, "{v} mm/s at {rpm} rpm");
            let (j0, j1) = (jerk(w[0]), jerk(w[1]));
            assert!(
                !(j0 * j1 < 0.0 && j0.abs() > 1e4 && j1.abs() > 1e4),
                "jerk {j0} then {j1} mm/s³ at {rpm} rpm"
            );
        }
        let last = s.last().unwrap().pos;
        assert_eq!(last, V3::new(15.0, 0.0, -3.0), "X30 is a diameter");
    }
    // planned ahead: the same samples
    let (here, ahead) = (per_rev_run(300.0, false), per_rev_run(300.0, true));
    assert_eq!(here.len(), ahead.len());
    assert!(here.iter().zip(&ahead).all(|(a, b)| a.pos == b.pos));
}

/// A line, a half circle of R20.6 and a line, at 250 mm/s under G64
/// P0.001 on the bundled mill (2000 mm/s²) at 67.6 m/s³: the blends'
/// curvature ramps are a few tenths of a millimetre long, passed in two
/// samples. Every setpoint's jerk (third difference) stays within the
/// limit (the planner takes every `K'` a sample may pass; checked at the
/// samples alone it reached 74.4 m/s³) and within 1 µm of the path.
#[test]
fn at_p_0_001_a_fast_arc_s_curvature_ramps_keep_the_jerk() {
    let jerk = 6.76e4;
    let mut m = Machine::builtin_mill();
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = Some(jerk);
    }
    m.planner.method = PlanMethod::Path;
    let text = "N10 G17 G90 G00 X10 Y30 Z0\nN20 G64 P0.001\nN30 G01 X30 Y30 F15000\n\
                N40 G02 X71.2 Y30 I20.6 J0\nN50 G01 X91.2\nN60 M30\n";
    let r = check(StrSource::new(text), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    let dt = m.dt();
    let mut top = [0.0f64; 2];
    for w in s.windows(4) {
        for (i, t) in top.iter_mut().enumerate() {
            let p = [w[0].pos[i], w[1].pos[i], w[2].pos[i], w[3].pos[i]];
            let j = (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]) / (dt * dt * dt);
            *t = t.max(j.abs());
        }
    }
    for (i, t) in top.into_iter().enumerate() {
        assert!(t <= jerk * (1.0 + 1e-9), "axis {i}: {t} mm/s³");
        // (it goes up to the planner's own share of the limit)
        assert!(t >= 0.85 * jerk, "axis {i}: only {t} mm/s³");
    }
    let c = V3::new(50.6, 30.0, 0.0);
    let worst = s
        .iter()
        .filter(|x| (3..=5).contains(&x.src.line))
        .map(|x| {
            let on_arc = if x.pos.y >= 30.0 {
                ((x.pos - c).norm() - 20.6).abs()
            } else {
                f64::MAX
            };
            seg(x.pos, V3::new(10.0, 30.0, 0.0), V3::new(30.0, 30.0, 0.0))
                .min(seg(
                    x.pos,
                    V3::new(71.2, 30.0, 0.0),
                    V3::new(91.2, 30.0, 0.0),
                ))
                .min(on_arc)
        })
        .fold(0.0, f64::max);
    assert!(worst <= 0.001 + 1e-9, "{} µm off the path", worst * 1e3);
}
