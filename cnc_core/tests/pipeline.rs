//! End-to-end tests of the core pipeline: text -> samples. Values in mm.

use cnc_core::exec::{Executor, Sample};
use cnc_core::jerk::ArcPart;
use cnc_core::machine::PlanMethod;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};

mod common;

fn mill() -> Machine {
    Machine::builtin_mill()
}

fn run(text: &str, m: &Machine) -> Vec<Sample> {
    let r = check(StrSource::new(text), Dialect::Cnc836, m);
    assert!(r.ok(), "program refused: {}", r.message());
    let samples: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, m).collect();
    // the check's estimate is the executed cycle time, to the tick
    let last = samples.last().unwrap();
    assert!(last.last);
    assert_eq!(
        last.k, r.ticks,
        "estimate {} ticks, executed {}",
        r.ticks, last.k
    );
    for (i, s) in samples.iter().enumerate() {
        assert_eq!(s.k, i as u64);
        assert_eq!(s.t, i as f64 * m.dt(), "t = k*dt exactly");
    }
    samples
}

/// Largest per-axis |velocity| / limit and |acceleration| / limit over all
/// samples, from finite differences of the positions.
fn limit_ratios(samples: &[Sample], m: &Machine) -> (f64, f64) {
    let dt = m.dt();
    let (vmax, amax) = (m.vmax(), m.amax());
    let mut rv: f64 = 0.0;
    let mut ra: f64 = 0.0;
    let vel: Vec<V3> = samples
        .windows(2)
        .map(|w| (w[1].pos - w[0].pos) / dt)
        .collect();
    for v in &vel {
        for i in 0..3 {
            rv = rv.max(v[i].abs() / vmax[i]);
        }
    }
    for w in vel.windows(2) {
        let a = (w[1] - w[0]) / dt;
        for i in 0..3 {
            ra = ra.max(a[i].abs() / amax[i]);
        }
    }
    (rv, ra)
}

/// bench/motion's machine (jerk.sh) at 50 m/s³: X/Y/Z 100 mm/s, 1000
/// mm/s².
fn bench_mill_50() -> Machine {
    bench_mill(5e4)
}

/// bench/motion's machine (jerk.sh) at `jerk` mm/s³.
fn bench_mill(jerk: f64) -> Machine {
    let mut m = mill();
    for a in &mut m.axes {
        a.max_velocity_mm_s = 100.0;
        a.max_acceleration_mm_s2 = 1000.0;
        a.max_jerk_mm_s3 = Some(jerk);
    }
    // (the filters at any jerk: "auto" would take the path planner under
    // 200 m/s³)
    m.planner.method = PlanMethod::Filters;
    m
}

/// Largest |jerk| of any axis over the samples, mm/s³ (third
/// differences).
fn largest_jerk(s: &[Sample], dt: f64) -> f64 {
    (0..3)
        .map(|i| {
            s.windows(4)
                .map(|w| {
                    ((w[3].pos[i] - 3.0 * w[2].pos[i] + 3.0 * w[1].pos[i] - w[0].pos[i])
                        / (dt * dt * dt))
                        .abs()
                })
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn on_line(samples: &[Sample], line: u32) -> Vec<&Sample> {
    samples.iter().filter(|s| s.src.line == line).collect()
}

/// Checks that every sample of `line` lies on the circle (centre, radius) of
/// the plane `(p, q)` and that the normal axis `n` does not move. The XYZ
/// jerk filter (M samples) pulls a sample at speed v inside by
/// v²(M²−1)dt²/(24 r); the first samples of the block trail in the move
/// before (both filters' windows).
fn assert_on_circle(
    m: &Machine,
    samples: &[Sample],
    line: u32,
    c: (f64, f64),
    r: f64,
    (p, q, n): (usize, usize, usize),
    nval: f64,
) -> usize {
    let pts = on_line(samples, line);
    assert!(pts.len() > 50, "line {line}: {} samples", pts.len());
    let mm = common::filter_lag(m);
    for (i, s) in pts.iter().enumerate().skip(mm - 1) {
        let d = ((s.pos[p] - c.0).powi(2) + (s.pos[q] - c.1).powi(2)).sqrt();
        let inside = common::filter_shrink(m, &pts, i, r);
        assert!(
            d <= r + 1e-9 && r - d <= inside,
            "line {line} t={} off the circle by {:e} mm (filter: {inside:e})",
            s.t,
            d - r
        );
        assert_eq!(s.pos[n], nval, "normal axis moved");
    }
    pts.len()
}

#[test]
fn arcs_in_every_plane_and_direction_lie_on_their_circle() {
    let m = mill();
    // full circles, then half circles, in G17, G18 and G19, CW and CCW
    let prog = "\
N10 G00 X100 Y100 Z0
N20 G17 G02 I20 J0 F2000
N30 G03 I20
N40 G02 X140 Y100 I20
N50 G03 X100 Y100 I-20
N60 G18 G02 I0 K20
N70 G03 I0 K20
N80 G02 X100 Z40 K20
N90 G03 X100 Z0 K-20
N100 G19 G02 J0 K30
N110 G03 J30 K0
N120 G02 Y160 Z0 J30
N130 G03 Y100 Z0 J-30
N140 M30
";
    let s = run(prog, &m);
    // G17: centre (120, 100), normal Z = 0
    let xy = (0, 1, 2);
    assert_on_circle(&m, &s, 2, (120.0, 100.0), 20.0, xy, 0.0);
    assert_on_circle(&m, &s, 3, (120.0, 100.0), 20.0, xy, 0.0);
    assert_on_circle(&m, &s, 4, (120.0, 100.0), 20.0, xy, 0.0);
    assert_on_circle(&m, &s, 5, (120.0, 100.0), 20.0, xy, 100.0_f64.min(0.0));
    // G18: plane (Z, X), centre z=20, x=100, normal Y = 100
    let zx = (2, 0, 1);
    assert_on_circle(&m, &s, 6, (20.0, 100.0), 20.0, zx, 100.0);
    assert_on_circle(&m, &s, 7, (20.0, 100.0), 20.0, zx, 100.0);
    assert_on_circle(&m, &s, 8, (20.0, 100.0), 20.0, zx, 100.0);
    assert_on_circle(&m, &s, 9, (20.0, 100.0), 20.0, zx, 100.0);
    // G19: plane (Y, Z), centre y=100, z=30 for N100; y=130, z=0 for N110..
    let yz = (1, 2, 0);
    assert_on_circle(&m, &s, 10, (100.0, 30.0), 30.0, yz, 100.0);
    assert_on_circle(&m, &s, 11, (130.0, 0.0), 30.0, yz, 100.0);
    assert_on_circle(&m, &s, 12, (130.0, 0.0), 30.0, yz, 100.0);
    assert_on_circle(&m, &s, 13, (130.0, 0.0), 30.0, yz, 100.0);
    // direction: N20 is clockwise seen from +Z: from (100,100) it goes to +Y first
    let n20 = on_line(&s, 2);
    assert!(
        n20[20].pos[1] > 100.0 && n20[20].pos[0] > 100.0,
        "{:?}",
        n20[20].pos
    );
    let n30 = on_line(&s, 3);
    assert!(
        n30[20].pos[1] < 100.0,
        "G03 from (100,100) about (120,100) goes to -Y first"
    );
    // G18 CW seen from +Y (Z right, X up): from (x=100,z=0) about
    // (x=100,z=20) it runs to +X first
    let n60 = on_line(&s, 6);
    assert!(n60[20].pos[0] > 100.0, "{:?}", n60[20].pos);
    let n70 = on_line(&s, 7);
    assert!(n70[20].pos[0] < 100.0, "{:?}", n70[20].pos);
    // the programmed end is exact
    assert_eq!(s.last().unwrap().pos, V3::new(100.0, 100.0, 0.0));
}

#[test]
fn block_ends_are_exact_and_the_last_sample_is_the_end_point() {
    let m = mill();
    let prog = "N1 G00 X10.001 Y20.002 Z-3.003\nN2 G01 X123.456 F1234\nN3 Y77.777\nN4 G03 X133.456 Y67.777 I10 J0\n";
    let s = run(prog, &m);
    // every block ends at rest (90° corners), so its end point is sampled exactly
    for want in [
        V3::new(10.001, 20.002, -3.003),
        V3::new(123.456, 20.002, -3.003),
        V3::new(123.456, 77.777, -3.003),
    ] {
        assert!(
            s.iter().any(|x| x.pos == want),
            "end point {want} never sampled exactly"
        );
    }
    assert_eq!(s.last().unwrap().pos, V3::new(133.456, 67.777, -3.003));
}

#[test]
fn no_sample_exceeds_a_velocity_or_acceleration_limit() {
    let m = mill();
    // rapids at the axis limits, feeds, arcs with large centripetal demand,
    // nearly tangent kinks and reversals
    let prog = "\
G00 X400 Y300 Z50
G00 X10 Y10 Z-50
G01 X200 Y10 F30000
G01 X400 Y12 F30000
G01 X420 Y14
G03 X420 Y54 I0 J20 F20000
G02 X420 Y94 I0 J20
G01 X100 Y94.5 Z20
G18 G02 X100 Z60 K20 F9000
G17 G01 X100.1 Y94.5 F600
G00 X0 Y0 Z0
";
    let s = run(prog, &m);
    let (rv, ra) = limit_ratios(&s, &m);
    assert!(rv <= 1.0 + 1e-9, "velocity at {rv} of the limit");
    assert!(ra <= 1.0 + 1e-6, "acceleration at {ra} of the limit");
    // the rapids really run at the limit of the leading axis
    assert!(rv > 0.999, "rapid reached only {rv} of the velocity limit");
}

#[test]
fn a_tangent_line_arc_line_path_keeps_its_speed() {
    let m = mill();
    // 50 mm/s; line +X, CCW quarter arc R50 tangent to it, line +Y tangent
    let prog = "G00 X0 Y0\nG01 X50 Y0 F3000\nG03 X100 Y50 I0 J50\nG01 X100 Y150\n";
    let s = run(prog, &m);
    let dt = m.dt();
    // speed from positions over the junction region (both junctions and the arc)
    let mid: Vec<&Sample> = s
        .iter()
        .filter(|x| x.pos[0] > 30.0 && x.pos[1] < 130.0 && x.pos[1] >= 0.0 && x.k > 0)
        .collect();
    assert!(mid.len() > 2000);
    let mut lo = f64::INFINITY;
    let mut hi: f64 = 0.0;
    for w in mid.windows(2) {
        if w[1].k != w[0].k + 1 {
            continue;
        }
        let v = (w[1].pos - w[0].pos).norm() / dt;
        lo = lo.min(v);
        hi = hi.max(v);
    }
    assert!(
        lo > 49.999 && hi < 50.000_001,
        "speed through the junctions {lo}..{hi} mm/s"
    );
}

#[test]
fn a_nearly_tangent_junction_does_not_stop_but_a_corner_does() {
    let m = mill();
    // 0.5° kink at X50: no stop; 90° corner at X100: exact stop
    let prog = "G00 X0 Y0\nG01 X50 Y0 F600\nG01 X100 Y0.436\nG01 X100 Y50\n";
    let s = run(prog, &m);
    let speed_at = |x: f64| {
        s.iter()
            .filter(|p| (p.pos[0] - x).abs() < 0.2 && p.path_speed > 0.0)
            .map(|p| p.path_speed)
            .fold(f64::INFINITY, f64::min)
    };
    assert!(
        speed_at(50.0) > 5.0,
        "slowed to {} at the 0.5° kink",
        speed_at(50.0)
    );
    // at the corner the path speed goes to zero and the corner is sampled exactly
    assert!(s.iter().any(|p| p.pos == V3::new(100.0, 0.436, 0.0)));
}

#[test]
fn under_a_jerk_limit_a_sharp_corner_stops_where_its_blend_would_be_slower() {
    // bench/motion's square (its cam program) on X/Y/Z 100 mm/s, 1000
    // mm/s², 50 m/s³: a blend of P 0.01 at a right angle has r = 24 µm
    // and a speed cap of 1.6 mm/s, which the path filter holds over a
    // stretch of either line; each corner blended cost 6.972 s in all,
    // each an exact stop 5.812 s (5.273 s once a line from rest to rest
    // had a path filter of its own, 5.079 s with that filter sized for
    // steps of a)
    let m = bench_mill_50();
    let prog = |mode: &str| {
        format!(
            "G17 G90 G94\n{mode}\nG00 Z5\nG00 X20 Y20\nG01 Z-1 F600\nG01 X60 F6000\nG01 Y60\n\
             G01 X20\nG01 Y20\nG01 X60 Y60\nG01 X20\nG01 Y20\nG00 Z5\nM30\n"
        )
    };
    let blended = run(&prog("G64 P0.01"), &m);
    let exact = run(&prog("G61"), &m);
    assert_eq!(blended.len(), 5080);
    assert_eq!(blended.len(), exact.len());
    // the same samples: every corner passed exactly, at rest
    for (a, b) in blended.iter().zip(&exact) {
        assert_eq!(a.pos, b.pos, "sample {}", a.k);
    }
    for corner in [(60.0, 20.0), (60.0, 60.0), (20.0, 60.0), (20.0, 20.0)] {
        let at = V3::new(corner.0, corner.1, -1.0);
        assert!(blended.iter().any(|s| s.pos == at), "{at:?} not passed");
    }
}

#[test]
fn a_chain_of_corners_stops_at_each_where_lines_from_rest_to_rest_are_faster() {
    // the bundled mill (200 m/s³): a 100 mm square at F4000 within P 0.5.
    // Each corner alone is a little faster blended (r 0.6 mm, passed at
    // 29.9 mm/s) than stopped with the machine filters' 44-tick hold, so
    // corner by corner the blender blended all three (6.316 s); stopped
    // at every corner, each side runs from rest to rest with its own
    // 10-sample path filter, a tick's wait and a 10-tick hold: 6.180 s,
    // the time of G61
    let m = mill();
    let square = |mode: &str| {
        format!("G00 X0 Y0 Z0\n{mode}\nG01 X100 F4000\nG01 Y100\nG01 X0\nG01 Y0\nM30\n")
    };
    let blended = run(&square("G64 P0.5"), &m);
    let exact = run(&square("G61"), &m);
    assert_eq!(exact.len(), 6180 + 1);
    assert_eq!(blended.len(), exact.len());
    for (a, b) in blended.iter().zip(&exact) {
        assert_eq!(a.pos, b.pos, "sample {}", a.k);
    }
    // (a program of 20 repeats of `body(i)` from the origin under `mode`)
    let repeated = |mode: &str, body: &dyn Fn(i32) -> String| {
        let moves: String = (1..=20).map(body).collect();
        format!("G00 X0 Y0 Z0\n{mode}\n{moves}M30\n")
    };
    // a zigzag of 5 mm steps and 10 mm rises at F2000, the same
    let zigzag = |i: i32| format!("G01 X{} Y{} F2000\n", 5 * i, 10 * (i % 2));
    let blended = run(&repeated("G64 P0.5", &zigzag), &m);
    let exact = run(&repeated("G61", &zigzag), &m);
    assert_eq!(exact.len(), 7240 + 1);
    assert_eq!(blended.len(), exact.len());
    // steps of 3 mm at F4000: blending every corner takes 3.769 s;
    // stopped at each they took 3.920 s while the lines' own filters were
    // sized for steps of 2a, and take 3.600 s now: the chain stops at each
    let stairs = |mode: &str, d: i32| {
        let step = |i: i32| {
            format!(
                "G01 X{} Y{} F4000\nG01 X{} Y{}\n",
                d * i,
                d * (i - 1),
                d * i,
                d * i
            )
        };
        repeated(mode, &step)
    };
    assert_eq!(
        (
            run(&stairs("G64 P0.5", 3), &m).len(),
            run(&stairs("G61", 3), &m).len()
        ),
        (3600 + 1, 3600 + 1)
    );
    // steps of 1 mm: too short to gain from their own filter, blending
    // every corner stays faster (1.315 s against 2.320 s stopped)
    assert_eq!(
        (
            run(&stairs("G64 P0.5", 1), &m).len(),
            run(&stairs("G61", 1), &m).len()
        ),
        (1315 + 1, 2320 + 1)
    );
}

#[test]
fn a_line_from_rest_to_rest_runs_with_a_path_filter_of_its_own() {
    // the bundled mill: X 2000 mm/s², 200 m/s³; its path filter is 40
    // samples and its XYZ filter 6, a 44-tick hold after each stop. A line
    // from rest to rest needs neither the normal-acceleration share nor
    // the XYZ filter: a path filter of ⌈a/(j·dt)⌉ = 10 samples of its own
    // keeps its jerk (its profile, and a feed hold or override, step by
    // a at most within its window); it waits a tick and holds 10
    let m = mill();
    let b = m.jerk_budget();
    assert_eq!((b.m_s, b.m_f, b.hold_ticks()), (40, 6, 44));
    let s = run("G01 X100 F6000\n", &m);
    // 100 mm at 100 mm/s, 50 ms to speed up and to stop: 1050 ticks, the
    // wait and the hold
    assert_eq!(s.len(), 1 + 1050 + 10 + 1);
    assert_eq!(s.last().unwrap().pos, V3::new(100.0, 0.0, 0.0));
    // the S-curve: the trapezoid's steps of 2000 mm/s² over 10 ms, 200
    // m/s³, the limit (the machine's two filters gave 2000 / 40 ms = 50
    // m/s³ at most)
    let x: Vec<f64> = s.iter().map(|p| p.pos[0]).collect();
    let dt = m.dt();
    let j = x
        .windows(4)
        .map(|w| ((w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]) / (dt * dt * dt)).abs())
        .fold(0.0, f64::max);
    assert!((j - 2.0e5).abs() < 1.0, "{j} mm/s³");
}

#[test]
fn a_short_line_from_rest_to_rest_peaks_where_its_cruise_outlasts_its_filter() {
    // the bundled mill's X (2000 mm/s², 200 m/s³): a 1 mm line at F6000
    // would peak at √(a·L) = 44.7 mm/s, a triangle whose +a and −a the
    // line's own 10-sample filter would see in one window (twice the
    // jerk). It peaks where its cruise lasts 10 + 2 samples: v²/a + v·T
    // = L, T = 12 ms: v = 1000·(√(0.012² + 0.002) − 0.012) = 34.30 mm/s
    let m = mill();
    let s = run(
        "G01 X1 F6000
",
        &m,
    );
    let dt = m.dt();
    let v: Vec<f64> = s
        .windows(2)
        .map(|w| (w[1].pos[0] - w[0].pos[0]) / dt)
        .collect();
    let top = v.iter().cloned().fold(0.0, f64::max);
    let want = 1000.0 * ((0.012f64 * 0.012 + 0.002).sqrt() - 0.012);
    assert!((top - want).abs() < 1e-6, "{top} mm/s against {want}");
    assert!(largest_jerk(&s, dt) <= 2e5 * (1.0 + 1e-6));
    // a tick's wait, 2·34.30/2000 + 0.012 s of motion (46.3 ms: 47
    // ticks), the hold of 10
    assert_eq!(s.len(), 1 + 47 + 10 + 1);
    assert_eq!(s.last().unwrap().pos, V3::new(1.0, 0.0, 0.0));
}

#[test]
fn an_arc_from_rest_to_rest_runs_on_its_circle_with_a_path_filter_of_its_own() {
    // the bundled mill (200 m/s³): a full circle R10 at F3000 between
    // stops. Its normal acceleration starts and ends at 0, so it needs no
    // XYZ filter: a path filter of ⌈a/(0.5·j·dt)⌉ = 20 samples of its own
    // (a 1984 mm/s² along the path, what the centripetal 250 mm/s²
    // leaves), and every setpoint lies on the circle (the XYZ filter
    // pulled them inside by up to 0.5 µm). 3·v·a·κ + v³·κ², the normal
    // acceleration's growth and turn, is 0.16 of j at 50 mm/s (the
    // other half of j allows 130 mm/s)
    let m = mill();
    let s = run("G00 X10 Y0\nG02 X10 Y0 I10 J0 F3000\n", &m);
    let dt = m.dt();
    let on: Vec<&Sample> = s.iter().filter(|p| p.src.line == 2).collect();
    assert!(on.len() > 1000);
    for p in &on {
        let r = ((p.pos[0] - 20.0).powi(2) + p.pos[1].powi(2)).sqrt();
        assert!((r - 10.0).abs() < 1e-9, "{} mm off the circle", r - 10.0);
    }
    assert!(largest_jerk(&s, dt) <= 2e5 * (1.0 + 1e-6));
    // the circle's samples: a tick's wait, 62.83 mm at 50 mm/s and 25 ms
    // of speeding up and slowing down (1282 ticks), the hold of 20 (44
    // with the machine's filters) and the program's last sample
    assert_eq!(on.len(), 1 + 1282 + 20 + 1);
    assert_eq!(s.last().unwrap().pos, V3::new(10.0, 0.0, 0.0));
}

#[test]
fn runs_at_ten_kilohertz() {
    let mut m = mill();
    m.interpolation.rate_hz = 10_000.0;
    let s = run("G00 X10 Y10\nG02 X10 Y10 I5 F1200\n", &m);
    assert_on_circle(&m, &s, 2, (15.0, 10.0), 5.0, (0, 1, 2), 0.0);
    assert_eq!(s[1].t, 1e-4);
    let (rv, ra) = limit_ratios(&s, &m);
    assert!(rv <= 1.0 + 1e-9 && ra <= 1.0 + 1e-6, "{rv} {ra}");
}

#[test]
fn lathe_diameter_mode_and_default_plane() {
    let m = Machine::builtin_lathe();
    // X in diameter: X60 is slide position 30; G18 is the default plane;
    // I is a radius offset
    let prog = "N10 G00 X60 Z5\nN20 G01 Z-20 F300\nN30 G02 X80 Z-30 I10 K0\nN40 G00 X200 Z20\n";
    let r = check(StrSource::new(prog), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m).collect();
    // N20 -> N30 is a tangent junction (both run in -Z): passed at speed
    assert!(s
        .iter()
        .any(|p| (p.pos - V3::new(30.0, 0.0, -20.0)).norm() < 0.006));
    assert!(
        s.iter().any(|p| p.pos == V3::new(30.0, 0.0, 5.0)),
        "X60 is slide position 30"
    );
    // N30: arc about (x=40, z=-20) radius 10 in the ZX plane
    assert_on_circle(&m, &s, 3, (-20.0, 40.0), 10.0, (2, 0, 1), 0.0);
    assert_eq!(s.last().unwrap().pos, V3::new(100.0, 0.0, 20.0));
}

#[test]
fn the_xyz_filter_takes_half_of_the_path_tolerance_and_changes_at_a_stop() {
    // bench/motion's R5 slot end on X/Y/Z 100 mm/s, 1000 mm/s², 50 m/s³:
    // under G61 (and any P up to 2 µm) the XYZ filter keeps within 1 µm,
    // 10 samples, and caps the normal acceleration where the lines meet
    // the arc at 99 mm/s²; under P 0.01 it may take 5 µm, 16 samples
    // and 160 mm/s², and the blends the other 5 µm
    let m = bench_mill_50();
    let exact = m.jerk_budget();
    let loose = exact.for_tolerance(0.01);
    assert_eq!((exact.m_f, loose.m_f), (10, 16));
    assert_eq!((exact.a_n.round(), loose.a_n.round()), (99.0, 160.0));
    assert!(exact.error_mm() <= 0.001 + 1e-12 && loose.error_mm() <= 0.005 + 1e-12);
    assert_eq!(exact.for_tolerance(0.002), exact);
    // lines 4-6: the slot's end; line 5 is the arc
    let prog = |mode: &str, mode2: &str| {
        format!(
            "G17 G90 G94\n{mode}\nG00 X200 Y20\nG01 X240 F6000\n{mode2}G03 X240 Y30 I0 J5\nG01 X200\nM30\n"
        )
    };
    let off_path = |s: &[Sample]| {
        s.iter()
            .filter(|p| (4..=7).contains(&p.src.line))
            .map(|p| {
                let (x, y) = (p.pos[0], p.pos[1]);
                if x <= 240.0 {
                    (y - 20.0).abs().min((y - 30.0).abs())
                } else {
                    ((x - 240.0).hypot(y - 25.0) - 5.0).abs()
                }
            })
            .fold(0.0, f64::max)
    };
    let g61 = run(&prog("G61", ""), &m);
    let p2 = run(&prog("G64 P0.002", ""), &m);
    let p10 = run(&prog("G64 P0.01", ""), &m);
    assert_eq!(g61.len(), p2.len());
    assert_eq!((p2.len(), p10.len()), (3799, 3640));
    assert!(off_path(&g61) <= 0.001, "{} mm", off_path(&g61));
    let d10 = off_path(&p10);
    assert!(d10 > 0.002 && d10 <= 0.01, "{d10} mm");
    // a tolerance that changes the filter stops the path where it
    // changes: the line's end is reached at rest (its own path filter
    // settled there), and the arc runs with G61's filters from there
    let mixed = run(&prog("G64 P0.01", "G61\n"), &m);
    let corner = V3::new(240.0, 20.0, 0.0);
    let slowest_near_corner = |s: &[Sample]| {
        s.windows(2)
            .filter(|w| (w[0].pos - corner).norm() < 0.5)
            .map(|w| (w[1].pos - w[0].pos).norm() / m.dt())
            .fold(f64::MAX, f64::min)
    };
    assert!(
        slowest_near_corner(&mixed) < 1e-3,
        "{} mm/s",
        slowest_near_corner(&mixed)
    );
    assert!(mixed.iter().any(|s| s.pos == corner));
    assert!(
        slowest_near_corner(&p10) > 20.0,
        "{} mm/s",
        slowest_near_corner(&p10)
    );
    assert_eq!(mixed.len(), 3793);
    assert!(off_path(&mixed) <= 0.005, "{} mm", off_path(&mixed));
}

#[test]
fn on_a_high_jerk_machine_g61_keeps_the_path_within_1_um() {
    // the bundled mill at 1000 m/s³ (2000 mm/s²): one XYZ moving average
    // of 4 samples alone would limit the jerk, but it cuts an arc by up to
    // 2.2 µm; under G61 (and P 0.001) the path may be off by 1 µm, so
    // there the path filter, the short XYZ filter and the caps run, and
    // the average again under P 0.01
    let mut m = mill();
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = Some(1.0e6);
    }
    assert!((m.single_average_error_mm() - 0.00217).abs() < 1e-5);
    let b = m.jerk_budget();
    assert!(b.limited() && b.error_mm() <= 0.001 + 1e-12);
    assert_eq!(b.for_tolerance(0.01).m_f, 4);
    // an R5 slot end and an R2 circle at F6000
    let prog = |mode: &str| {
        format!(
            "G17 G90 G94\n{mode}\nG00 X200 Y20\nG01 X240 F6000\nG03 X240 Y30 I0 J5\n\
             G01 X200\nG02 X200 Y30 I0 J2\nM30\n"
        )
    };
    let off_path = |s: &[Sample]| {
        s.iter()
            .filter(|p| (4..=7).contains(&p.src.line))
            .map(|p| {
                let (x, y) = (p.pos[0], p.pos[1]);
                let line = (y - 20.0).abs().min((y - 30.0).abs());
                let slot = ((x - 240.0).hypot(y - 25.0) - 5.0).abs();
                let circle = ((x - 200.0).hypot(y - 32.0) - 2.0).abs();
                let line = if (200.0..=240.0).contains(&x) {
                    line
                } else {
                    f64::MAX
                };
                line.min(slot).min(circle)
            })
            .fold(0.0, f64::max)
    };
    let g61 = run(&prog("G61"), &m);
    let p1 = run(&prog("G64 P0.001"), &m);
    let p10 = run(&prog("G64 P0.01"), &m);
    let (d61, d1, d10) = (off_path(&g61), off_path(&p1), off_path(&p10));
    // (before, every run was the average's: 1.082 µm off, 2,174 samples)
    assert!(d61 <= 0.001 && d1 <= 0.001, "{d61} {d1} mm");
    assert!(d10 > 0.001 && d10 <= 0.005, "{d10} mm");
    assert_eq!((g61.len(), p1.len(), p10.len()), (2219, 2219, 2174));
}

#[test]
fn an_arc_beside_tangent_lines_takes_the_whole_normal_step() {
    // the R5 slot end at 50 m/s³ under G61: where only a long tangent
    // line (or a stop) meets an arc, the XYZ filter's window across the
    // junction holds the arc and normal accelerations of 0, so the arc's
    // ends may take the whole step budget b_step (and a_dev, and the turn
    // within a quarter of b_step) instead of a_n = b_step/2, which any
    // neighbour allows: 22.2 → 31.6 mm/s at R5 (G61: b_step 198 mm/s²)
    let m = bench_mill_50();
    let b = m.jerk_budget();
    let kappa = 0.2;
    let (end, _) = b.arc_caps(kappa, ArcPart::End);
    let (beside, _) = b.arc_caps(kappa, ArcPart::Beside);
    assert_eq!((end * 10.0).round(), 222.0);
    assert_eq!((beside * 10.0).round(), 316.0);
    let s = run(
        "G17 G90 G94\nG00 X200 Y20\nG01 X240 F6000\nG03 X240 Y30 I0 J5\nG01 X200\nM30\n",
        &m,
    );
    // the speed where the line meets the arc, as the setpoints move
    let dt = m.dt();
    let junction = V3::new(240.0, 20.0, 0.0);
    let k = (0..s.len() - 1)
        .min_by(|&a, &b| {
            let d = |i: usize| (s[i].pos - junction).norm();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let v = (s[k + 1].pos - s[k].pos).norm() / dt;
    assert!(
        v > end * 1.3 && v <= beside * 1.001,
        "{v} mm/s at the junction"
    );
    // jerk at every sample within the limit on every axis
    let j_max = largest_jerk(&s, dt);
    assert!(j_max <= 5e4 * (1.0 + 1e-6), "{j_max} mm/s³");
    assert_eq!(s.len(), 3799);
}

#[test]
fn a_rounded_cam_circle_runs_as_one_curve_under_a_cap_on_its_junctions() {
    // bench/motion's polyline helix flat: R10, 3° per line, vertices
    // rounded to 1 µm, G64 P0.01 at 20 m/s³. Its blend arcs' curvatures
    // differ by the rounding, more than the XYZ filter's step budget
    // allows at the top speed (100 mm/s), so each arc was an end of its
    // own, at √(a_n/κ); under a cap on each junction (the speed at which
    // the step is within a quarter of the budget) they run as one curve
    // with the caps of an arc's inside
    let m = bench_mill(2e4);
    let b = m.jerk_budget().for_tolerance(0.01);
    let (end, _) = b.arc_caps(0.1, ArcPart::End);
    let (inside, _) = b.arc_caps(0.1, ArcPart::Inside);
    assert_eq!(
        ((end * 10.0).round(), (inside * 10.0).round()),
        (297.0, 498.0)
    );
    let mut text = String::from("G17 G90 G64 P0.01\nG00 X110 Y100\nG01 Z-1 F6000\n");
    for k in 1..=240 {
        let a = (3.0 * k as f64).to_radians();
        text += &format!(
            "G01 X{:.3} Y{:.3}\n",
            100.0 + 10.0 * a.cos(),
            100.0 + 10.0 * a.sin()
        );
    }
    let s = run(&text, &m);
    let dt = m.dt();
    // the speed over the second turn
    let speeds: Vec<f64> = s
        .windows(2)
        .filter(|w| w[0].src.line > 4 + 130 && w[0].src.line < 4 + 200)
        .map(|w| (w[1].pos - w[0].pos).norm() / dt)
        .collect();
    let slowest = speeds.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        slowest > 1.3 * end && slowest <= inside * 1.001,
        "{slowest} mm/s"
    );
    assert!(largest_jerk(&s, dt) <= 2e4 * (1.0 + 1e-6));
    assert_eq!(s.len(), 4454);
}
