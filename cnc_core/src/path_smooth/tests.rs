use super::*;

/// A polyline through `corners`, points at most `DS` apart, one feed.
fn polyline(corners: &[[f64; 3]], feed: f64) -> Polyline {
    let mut p = vec![corners[0]];
    for w in corners.windows(2) {
        let n = (dist(&w[0], &w[1]) / DS).ceil().max(1.0) as usize;
        for i in 1..=n {
            let f = i as f64 / n as f64;
            p.push([0, 1, 2].map(|k| w[0][k] + f * (w[1][k] - w[0][k])));
        }
    }
    let feed = vec![feed; p.len()];
    Polyline { p, feed }
}

/// Distance from `x` to the polyline through `corners`.
fn off(corners: &[[f64; 3]], x: &[f64; 3]) -> f64 {
    corners
        .windows(2)
        .map(|w| {
            let d = [0, 1, 2].map(|k| w[1][k] - w[0][k]);
            let r = [0, 1, 2].map(|k| x[k] - w[0][k]);
            let l2: f64 = d.iter().map(|c| c * c).sum();
            let f = (r.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>() / l2).clamp(0.0, 1.0);
            dist(x, &[0, 1, 2].map(|k| w[0][k] + f * d[k]))
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_square_corner_becomes_a_curve_within_the_tolerance_with_continuous_curvature() {
    let corners = [[0.0, 0.0, 0.0], [20.0, 0.0, 0.0], [20.0, 20.0, 0.0]];
    let sm = smooth(&polyline(&corners, 100.0), 0.01, false).unwrap();
    // every point within P (the rounds stop at 0.98 P), measured exactly
    let worst = sm.q.iter().map(|q| off(&corners, q)).fold(0.0, f64::max);
    assert!(worst <= 0.0098 + 1e-9 && worst > 0.009, "{worst}");
    assert!((sm.dev - worst).abs() < 1e-4, "{} vs {worst}", sm.dev);
    // the corner is cut: the path is shorter, by about what a blend of
    // the width there takes
    assert!(
        sm.len() < 40.0 - 0.005 && sm.len() > 40.0 - 0.1,
        "{}",
        sm.len()
    );
    // at the corner the average is about 54 µm wide: a blend about
    // 0.1 mm long whose curvature (up to about 48 /mm) rises and falls
    // over many grid points, never in a step
    let wmin = sm.w.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(wmin > 0.04 && wmin < 0.07, "{wmin}");
    let kmax = sm.k.iter().map(norm).fold(0.0, f64::max);
    assert!(kmax > 30.0 && kmax < 70.0, "{kmax}");
    let step =
        sm.k.windows(2)
            .map(|w| dist(&w[0], &w[1]))
            .fold(0.0, f64::max);
    assert!(step < kmax / 4.0, "curvature step {step} of {kmax}");
    let high = sm.k.iter().filter(|k| norm(k) > kmax / 2.0).count();
    assert!(high >= 8, "{high} points over half the peak");
    // far from the corner the width is the widest and the path straight
    assert_eq!(sm.w[0], W0);
    let mid = sm.q.len() / 4;
    assert!(
        norm(&sm.k[mid]) < 1e-6 && (sm.q[mid][1]).abs() < 1e-12,
        "{:?}",
        sm.q[mid]
    );
}

#[test]
fn a_straight_run_stays_itself() {
    let corners = [[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]];
    let sm = smooth(&polyline(&corners, 50.0), 0.001, true).unwrap();
    assert!((sm.len() - 5.0).abs() < 1e-9, "{}", sm.len());
    assert!(sm.dev < 1e-12, "{}", sm.dev);
    let p = sm.point(2.5);
    assert!(
        (p[0] - 1.5).abs() < 1e-9 && (p[1] - 2.0).abs() < 1e-9,
        "{p:?}"
    );
    let st = sm.stations(0.01);
    assert_eq!(st.len(), 501);
    // straight to rounding (path_speed's STRAIGHT is 1e-6 /mm)
    assert!(st
        .iter()
        .all(|s| (s.t[0] - 0.6).abs() < 1e-9 && norm(&s.k) < 1e-7 && s.feed == 50.0));
}

fn norm(x: &[f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

#[test]
fn bad_runs_are_refused() {
    let one = Polyline {
        p: vec![[0.0; 3]],
        feed: vec![1.0],
    };
    assert!(matches!(
        smooth(&one, 0.01, false),
        Err(SmoothError::BadRun(_))
    ));
    let nan = Polyline {
        p: vec![[0.0; 3], [f64::NAN, 0.0, 0.0]],
        feed: vec![1.0; 2],
    };
    assert!(matches!(
        smooth(&nan, 0.01, false),
        Err(SmoothError::BadRun(_))
    ));
    let same = Polyline {
        p: vec![[0.0; 3], [0.0; 3]],
        feed: vec![1.0; 2],
    };
    let e = smooth(&same, 0.01, false).err().unwrap();
    assert_eq!(e.to_string(), "run: no length, or two points in one place");
}

#[test]
fn the_sliding_minimum_is_the_plain_one() {
    let mut x = 0x9e37_79b9_u64;
    let v: Vec<f64> = (0..500)
        .map(|_| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (x >> 40) as f64
        })
        .collect();
    for r in [0, 1, 7, 30, 600] {
        let plain: Vec<f64> = (0..v.len())
            .map(|i| {
                v[i.saturating_sub(r)..=(i + r).min(v.len() - 1)]
                    .iter()
                    .cloned()
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        assert_eq!(sliding_min(&v, r), plain, "r {r}");
    }
}

#[test]
fn a_run_that_ends_on_an_arc_ends_on_its_end_point_with_no_curvature() {
    // a quarter circle of R 5 mm, points 4 µm apart
    let r = 5.0;
    let n = (std::f64::consts::FRAC_PI_2 * r / DS).ceil() as usize;
    let p: Vec<[f64; 3]> = (0..=n)
        .map(|i| {
            let a = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
            [r * a.cos(), r * a.sin(), 0.0]
        })
        .collect();
    let last = p[n];
    let sm = smooth(
        &Polyline {
            feed: vec![80.0; p.len()],
            p,
        },
        0.01,
        false,
    )
    .unwrap();
    assert!(dist(&sm.q[0], &[r, 0.0, 0.0]) < 1e-9, "{:?}", sm.q[0]);
    assert!(dist(&sm.q[sm.q.len() - 1], &last) < 1e-9);
    let k = |i: usize| norm(&sm.k[i]);
    let m = sm.q.len();
    // no curvature at the ends, the arc's 0.2 /mm in the middle
    assert!(k(0) < 0.01 && k(m - 1) < 0.01, "{} {}", k(0), k(m - 1));
    assert!((k(m / 2) - 1.0 / r).abs() < 0.01, "{}", k(m / 2));
    assert!(sm.dev <= 0.0098 + 1e-9, "{}", sm.dev);
}

#[test]
fn worked_out_20_mm_at_a_time_with_20_mm_either_side_the_path_is_the_whole_runs() {
    // a CAM-like polyline: a wave of 0.5 mm chords, and a square corner
    let mut corners: Vec<[f64; 3]> = (0..=160)
        .map(|i| {
            let x = i as f64 * 0.5;
            [x, 3.0 * (x / 7.0).sin(), 0.0]
        })
        .collect();
    let end = corners[160];
    corners.push([end[0], end[1] + 30.0, 0.0]);
    let run = polyline(&corners, 100.0);
    let whole = smooth(&run, 0.01, true).unwrap();
    let parts = smooth_chunked(&run, 0.01, true, 20.0, 20.0).unwrap();
    assert_eq!(whole.q.len(), parts.q.len());
    let apart = |a: &Smoothed, b: &Smoothed| {
        a.q.iter()
            .zip(&b.q)
            .map(|(a, b)| dist(a, b))
            .fold(0.0, f64::max)
    };
    // within a nanometre of the whole run's path
    let most = apart(&whole, &parts);
    assert!(most < 1e-6, "{most}");
    assert!(parts.dev <= 0.0098 + 1e-9, "{}", parts.dev);
    // with 5 mm either side the chunks' ends show
    let near = smooth_chunked(&run, 0.01, true, 20.0, 5.0).unwrap();
    assert!(apart(&whole, &near) > 1e-4, "{}", apart(&whole, &near));
}

/// A CAM-like run 200 mm long: a wave of 0.5 mm chords, then a square
/// corner and a straight.
fn long_wave() -> Polyline {
    let mut corners: Vec<[f64; 3]> = (0..=340)
        .map(|i| {
            let x = i as f64 * 0.5;
            [x, 3.0 * (x / 7.0).sin(), 0.1 * (x / 11.0).cos()]
        })
        .collect();
    let end = corners[340];
    corners.push([end[0], end[1] + 30.0, end[2]]);
    polyline(&corners, 100.0)
}

#[test]
fn streamed_point_by_point_the_stations_are_the_chunked_runs_and_the_window_stays_small() {
    let run = long_wave();
    let h = 0.05;
    let whole = smooth(&run, 0.01, true).unwrap();
    let chunked = smooth_chunked(&run, 0.01, true, 40.0, 20.0).unwrap();
    let want = chunked.stations(h);
    let mut st = Stream::new(0.01, true, 40.0, 20.0, h).unwrap();
    let mut got = Vec::new();
    let (mut most_kept, mut most_off, mut checked) = (0, 0.0f64, 0);
    for (i, (p, f)) in run.p.iter().zip(&run.feed).enumerate() {
        st.push(*p, *f).unwrap();
        if i % 100 == 99 {
            st.advance(&mut got).unwrap();
            // the samples lag 10 mm behind the stations
            let x = (got.len() as f64 * h - 10.0).max(0.0);
            if x > 0.0 {
                // where the samples are, the point is the whole run's
                let q = st.point(x).unwrap();
                most_off = most_off.max(dist(&q, &whole.point(x)));
                checked += 1;
            }
            st.forget_before(x);
            most_kept = most_kept.max(st.kept());
        }
    }
    st.finish().unwrap();
    st.advance(&mut got).unwrap();
    assert!(checked > 100, "{checked}");
    assert!(most_off < 1e-6, "{most_off} mm from the whole run's path");
    // the window: the chunk, its margins and the lag, not the run
    // (about 50 000 grid points)
    let total = whole.q.len();
    assert!(total > 49_000, "{total}");
    assert!(most_kept < total / 2, "{most_kept} of {total}");
    // the stations, bit for bit but for rounding
    assert_eq!(got.len(), want.len());
    let mut worst = 0.0f64;
    for (a, b) in got.iter().zip(&want) {
        worst = worst
            .max(dist(&a.t, &b.t))
            .max(dist(&a.k, &b.k) / 100.0)
            .max(dist(&a.kd, &b.kd) / 1e4)
            .max((a.feed - b.feed).abs() / 100.0);
    }
    assert!(worst < 1e-9, "{worst}");
    assert!((st.len().unwrap() - chunked.len()).abs() < 1e-9);
    assert!((st.dev() - chunked.dev).abs() < 1e-12 && st.dev() <= 0.0098 + 1e-9);
    // the last station is the path's end
    assert_eq!(got.len(), (chunked.len() / h).ceil() as usize + 1);
}

#[test]
fn a_stream_refuses_bad_points_and_a_run_too_short() {
    let err = |r: Result<(), SmoothError>| format!("{}", r.unwrap_err());
    assert!(Stream::new(0.0, false, 40.0, 20.0, 0.05).is_err());
    assert!(Stream::new(0.01, false, 40.0, 20.0, f64::NAN).is_err());
    let mut st = Stream::new(0.01, false, 40.0, 20.0, 0.05).unwrap();
    st.push([0.0; 3], 100.0).unwrap();
    assert!(err(st.finish()).contains("fewer than two points"));
    assert!(err(st.push([f64::NAN, 0.0, 0.0], 100.0)).contains("not finite"));
    assert!(err(st.push([1.0, 0.0, 0.0], 0.0)).contains("not positive"));
    assert!(err(st.push([0.0; 3], 100.0)).contains("two points in one place"));
    st.push([1.0, 0.0, 0.0], 100.0).unwrap();
    st.finish().unwrap();
    assert!(err(st.push([2.0, 0.0, 0.0], 100.0)).contains("after the run's end"));
    let mut out = Vec::new();
    st.advance(&mut out).unwrap();
    // a 1 mm straight: stations every 0.05 mm, the last on its end
    assert_eq!(out.len(), 21);
    assert!((st.len().unwrap() - 1.0).abs() < 1e-9);
    assert!(out
        .iter()
        .all(|s| (s.t[0] - 1.0).abs() < 1e-9 && s.feed == 100.0));
}

#[test]
fn at_a_small_tolerance_one_chunk_fades_into_the_next_with_no_seam() {
    // a 0.5 mm circle, then 236° of an 18 mm arc, points 4 µm apart; at
    // P = 1 µm the rounds narrow the whole arc, and a chunk's path differs
    // from the whole run's by about P far from the chunk's ends
    let mut p = Vec::new();
    let n1 = 800;
    for i in 0..n1 {
        let a = std::f64::consts::FRAC_PI_2 - std::f64::consts::TAU * i as f64 / n1 as f64;
        p.push([250.0 + 0.5 * a.cos(), 249.5 + 0.5 * a.sin(), 0.0]);
    }
    let (cx, cy, r) = (249.9135, 231.9608, 18.0394f64);
    let a0 = (250.0f64 - cy).atan2(250.0 - cx);
    let sweep = 236.5f64.to_radians();
    let n2 = 18600;
    for i in 0..=n2 {
        let a = a0 - sweep * i as f64 / n2 as f64;
        p.push([cx + r * a.cos(), cy + r * a.sin(), 0.0]);
    }
    let feed = vec![60.0; p.len()];
    let run = Polyline { p, feed };
    let whole = smooth(&run, 0.001, true).unwrap();
    let parts = smooth_chunked(&run, 0.001, true, 40.0, 30.0).unwrap();
    let most = whole
        .q
        .iter()
        .zip(&parts.q)
        .map(|(a, b)| dist(a, b))
        .fold(0.0, f64::max);
    assert!(most > 5e-4 && most < 1.5e-3, "{most}");
    assert!(parts.dev <= 0.00095 + 1e-9, "{}", parts.dev);
    // the seam at 40 mm does not show in the curvature's change (without
    // the fade: 595 /mm² there, against 40 at the circle)
    let kd = |s: &Smoothed| s.kd.iter().map(norm).fold(0.0, f64::max);
    assert!(
        kd(&parts) < 1.05 * kd(&whole),
        "{} vs {}",
        kd(&parts),
        kd(&whole)
    );
    // nor near it: 35 to 45 mm
    let near = |s: &Smoothed| s.kd[8750..11250].iter().map(norm).fold(0.0, f64::max);
    assert!(
        near(&parts) < 1.5 * near(&whole) + 0.05,
        "{} vs {} /mm² about the seam",
        near(&parts),
        near(&whole)
    );
}
