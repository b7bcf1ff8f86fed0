use super::*;

const DT: f64 = 0.001;

fn lim(v: f64, a: f64, j: f64) -> AxisLimits {
    AxisLimits {
        v: [v; 3],
        a: [a; 3],
        j: [j; 3],
    }
}

/// Stations `h` apart over `len`, from a shape function of `s`.
fn path(len: f64, h: f64, shape: impl Fn(f64) -> Station) -> Path {
    let n = (len / h).ceil() as usize + 1;
    let st = (0..n).map(|i| shape((i as f64 * h).min(len))).collect();
    Path::new(h, len, st).expect("a valid path")
}

fn line_x(feed: f64) -> impl Fn(f64) -> Station {
    move |_| Station {
        t: [1.0, 0.0, 0.0],
        k: [0.0; 3],
        kd: [0.0; 3],
        feed,
    }
}

fn circle(r: f64, feed: f64) -> impl Fn(f64) -> Station {
    move |s| {
        let th = s / r;
        let (sn, cs) = th.sin_cos();
        Station {
            t: [-sn, cs, 0.0],
            k: [-cs / r, -sn / r, 0.0],
            kd: [sn / (r * r), -cs / (r * r), 0.0],
            feed,
        }
    }
}

/// The whole run of `p` under `l`: the path position at every sample.
fn run(p: Path, l: AxisLimits) -> Vec<f64> {
    Planner::new(p, l, DT).unwrap().run(200_000).unwrap()
}

/// The largest |first|, |second|, |third| finite difference of `x` over
/// the sample time.
fn diffs(x: &[f64]) -> [f64; 3] {
    let d1: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let d2: Vec<f64> = d1.windows(2).map(|w| w[1] - w[0]).collect();
    let d3: Vec<f64> = d2.windows(2).map(|w| w[1] - w[0]).collect();
    let m = |d: &[f64]| d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    [m(&d1) / DT, m(&d2) / (DT * DT), m(&d3) / (DT * DT * DT)]
}

#[test]
fn a_line_takes_the_rest_to_rest_s_curve_time_and_ends_on_its_end() {
    // 0 -> 100 mm/s at 1000 mm/s², 50 m/s³: 0.12 s and 6 mm each way,
    // 38 mm at 100 mm/s: 0.62 s in all
    let p = path(50.0, 0.05, line_x(100.0));
    let s = run(p, lim(100.0, 1000.0, 5e4));
    assert_eq!(s[0], 0.0);
    assert_eq!(*s.last().unwrap(), 50.0);
    let ticks = s.len() - 1;
    assert!((620..=624).contains(&ticks), "{ticks} samples");
    let [v, a, j] = diffs(&s);
    assert!(v <= 100.0 + 1e-6 && v > 99.9, "v {v}");
    assert!(a <= 1000.0 * (1.0 + 1e-6) && a > 990.0, "a {a}");
    assert!(j <= 5e4 * 1.001, "j {j}");
    assert!(s.windows(2).all(|w| w[1] >= w[0]), "never backwards");
}

#[test]
fn a_short_line_is_run_on_the_jerk_alone() {
    // rest to rest on the jerk alone: t = (32 L / J)^(1/3) = 40 ms
    let p = path(0.1, 0.005, line_x(100.0));
    let s = run(p, lim(100.0, 1000.0, 5e4));
    let ticks = s.len() - 1;
    assert!((40..=43).contains(&ticks), "{ticks} samples");
    assert_eq!(*s.last().unwrap(), 0.1);
    let [_, a, j] = diffs(&s);
    assert!(a < 1000.0 && j <= 5e4 * 1.001, "a {a} j {j}");
}

#[test]
fn on_a_circle_the_jerk_of_the_axes_sets_the_speed() {
    // R 2 mm at 50 m/s³: v³/R² <= J gives 58.48 mm/s (the acceleration
    // would allow 63.2 at 2000 mm/s²)
    let r = 2.0;
    let len = 5.0 * std::f64::consts::TAU * r;
    let p = path(len, 0.01, circle(r, 100.0));
    let s = run(p, lim(100.0, 2000.0, 5e4));
    assert_eq!(*s.last().unwrap(), len);
    let xy: Vec<[f64; 2]> = s
        .iter()
        .map(|s| [r * (s / r).cos(), r * (s / r).sin()])
        .collect();
    for ax in 0..2 {
        let x: Vec<f64> = xy.iter().map(|p| p[ax]).collect();
        let [v, a, j] = diffs(&x);
        assert!(v <= 100.0 && a <= 2000.0 * 1.001, "axis {ax}: v {v} a {a}");
        assert!(j <= 5e4 * 1.02 && j > 5e4 * 0.9, "axis {ax}: j {j}");
    }
    let mid = &s[s.len() / 3..2 * s.len() / 3];
    let speeds: Vec<f64> = mid.windows(2).map(|w| (w[1] - w[0]) / DT).collect();
    let (lo, hi) = speeds
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), v| (l.min(*v), h.max(*v)));
    // at a constant speed the bound is 58.48; a speed that swings with
    // the angle keeps each axis's jerk with a little more (here about 60.2)
    let bound = (5e4 * r * r).cbrt();
    assert!(
        lo > 1.01 * bound && hi <= bound * 1.05,
        "speed {lo}..{hi}, bound {bound}"
    );
}

#[test]
fn random_feeds_and_jerks_keep_every_limit_and_end_exactly() {
    // a linear congruential generator (Knuth's MMIX constants), fixed seed
    let mut seed = 0x5eed_u64;
    for case in 0..12 {
        let mut r = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let jerk = 2e4 + r() * 1.8e5;
        let len = 0.2 + r() * 30.0;
        let (f1, f2, p1, p2) = (0.5 + 3.0 * r(), 2.0 + 9.0 * r(), r() * 6.3, r() * 6.3);
        let feed = move |s: f64| {
            let x = s / len;
            60.0 + 30.0 * (f1 * x * 6.3 + p1).sin() + 20.0 * (f2 * x * 6.3 + p2).sin()
        };
        let h = 0.01;
        let n = (len / h).ceil() as usize + 1;
        let st = (0..n)
            .map(|i| Station {
                t: [0.6, 0.8, 0.0],
                k: [0.0; 3],
                kd: [0.0; 3],
                feed: feed((i as f64 * h).min(len)),
            })
            .collect();
        let p = Path::new(h, len, st).unwrap();
        let s = run(p.clone(), lim(100.0, 1000.0, jerk));
        assert_eq!(*s.last().unwrap(), len, "case {case}");
        for (ax, dir) in [0.6, 0.8].into_iter().enumerate() {
            let x: Vec<f64> = s.iter().map(|s| s * dir).collect();
            let [v, a, j] = diffs(&x);
            assert!(v <= 100.0 * (1.0 + 1e-6), "case {case} axis {ax}: v {v}");
            assert!(a <= 1000.0 * (1.0 + 1e-6), "case {case} axis {ax}: a {a}");
            assert!(
                j <= jerk * 1.001,
                "case {case} axis {ax}: j {j} over {jerk}"
            );
        }
        // the path speed keeps the feed (as the stations give it) at every sample
        for w in s.windows(2) {
            let v = (w[1] - w[0]) / DT;
            let f = |s: f64| p.at(s).feed;
            let f = f(w[0]).max(f(w[1])).max(f(0.5 * (w[0] + w[1])));
            assert!(v <= f * 1.001, "case {case}: {v} over {f} at {}", w[0]);
        }
    }
}

#[test]
fn a_growing_path_refuses_what_a_run_cannot_be() {
    let st = Station {
        t: [1.0, 0.0, 0.0],
        k: [0.0; 3],
        kd: [0.0; 3],
        feed: 10.0,
    };
    let mut p = Path::open(0.1).unwrap();
    assert_eq!(p.shape_at(0.0), None);
    p.push(st).unwrap();
    let e = p.finish(0.1).err().unwrap();
    assert_eq!(e.to_string(), "path: fewer than two stations");
    p.push(st).unwrap();
    assert_eq!(p.len(), None);
    let e = p.finish(0.25).err().unwrap();
    assert_eq!(
        e.to_string(),
        "path: the last station is not within one spacing of the one before"
    );
    p.finish(0.08).unwrap();
    assert_eq!(p.len(), Some(0.08));
    let e = p.push(st).err().unwrap();
    assert_eq!(e.to_string(), "path: a station after the run's end");
    assert!(Path::open(0.0).is_err());
    // a planner on it runs the 0.08 mm and ends there
    let s = run(p, lim(100.0, 1000.0, 5e4));
    assert_eq!((s[0], *s.last().unwrap()), (0.0, 0.08));
}

#[test]
fn bad_paths_and_limits_are_refused() {
    let st = Station {
        t: [1.0, 0.0, 0.0],
        k: [0.0; 3],
        kd: [0.0; 3],
        feed: 10.0,
    };
    assert!(matches!(
        Path::new(0.1, 0.1, vec![st]),
        Err(SpeedError::BadPath(_))
    ));
    assert!(matches!(
        Path::new(0.1, 0.5, vec![st, st]),
        Err(SpeedError::BadPath(_))
    ));
    let nan = Station {
        feed: f64::NAN,
        ..st
    };
    assert!(matches!(
        Path::new(0.1, 0.1, vec![st, nan]),
        Err(SpeedError::BadPath(_))
    ));
    let p = Path::new(0.1, 0.1, vec![st, st]).unwrap();
    let e = Planner::new(p.clone(), lim(100.0, 0.0, 5e4), DT)
        .err()
        .unwrap();
    assert_eq!(
        e.to_string(),
        "every axis limit must be positive and finite"
    );
    let e = Planner::new(p.clone(), lim(100.0, 1000.0, 5e4), DT)
        .unwrap()
        .run(3)
        .err()
        .unwrap();
    assert!(
        e.to_string()
            .starts_with("the run did not reach its end in 4 samples"),
        "{e}"
    );
}

/// A smooth space curve `P(u)` (sums of sines, a climb in Z), given at
/// stations `h` apart in its arc length, and its points at any arc length.
struct Curve {
    coef: [f64; 7],
    /// (arc length, u) every `DU`
    table: Vec<(f64, f64)>,
}

const DU: f64 = 2e-4;

impl Curve {
    fn new(coef: [f64; 7], u_end: f64) -> Curve {
        let mut table = vec![(0.0, 0.0)];
        let mut s = 0.0;
        let n = (u_end / DU) as usize;
        for i in 1..=n {
            let u = i as f64 * DU;
            // Simpson's rule on |P'| over [u - DU, u]
            let d = |u: f64| norm(Curve::d1(&coef, u));
            s += DU / 6.0 * (d(u - DU) + 4.0 * d(u - DU / 2.0) + d(u));
            table.push((s, u));
        }
        Curve { coef, table }
    }

    fn p(c: &[f64; 7], u: f64) -> [f64; 3] {
        [
            c[0] * u.sin() + c[1] * (3.0 * u + c[2]).sin(),
            c[3] * u.cos() + c[4] * (2.0 * u + c[5]).cos(),
            c[6] * u,
        ]
    }

    fn d1(c: &[f64; 7], u: f64) -> [f64; 3] {
        [
            c[0] * u.cos() + 3.0 * c[1] * (3.0 * u + c[2]).cos(),
            -c[3] * u.sin() - 2.0 * c[4] * (2.0 * u + c[5]).sin(),
            c[6],
        ]
    }

    fn d2(c: &[f64; 7], u: f64) -> [f64; 3] {
        [
            -c[0] * u.sin() - 9.0 * c[1] * (3.0 * u + c[2]).sin(),
            -c[3] * u.cos() - 4.0 * c[4] * (2.0 * u + c[5]).cos(),
            0.0,
        ]
    }

    fn len(&self) -> f64 {
        self.table.last().map_or(0.0, |t| t.0)
    }

    fn u_at(&self, s: f64) -> f64 {
        let i = self
            .table
            .partition_point(|t| t.0 < s)
            .clamp(1, self.table.len() - 1);
        let ((s0, u0), (s1, u1)) = (self.table[i - 1], self.table[i]);
        u0 + (s - s0) / (s1 - s0) * (u1 - u0)
    }

    fn at(&self, s: f64) -> [f64; 3] {
        Curve::p(&self.coef, self.u_at(s))
    }

    /// Tangent and curvature vector at arc length `s`.
    fn shape(&self, s: f64) -> ([f64; 3], [f64; 3]) {
        let u = self.u_at(s);
        let (d1, d2) = (Curve::d1(&self.coef, u), Curve::d2(&self.coef, u));
        let n = norm(d1);
        let t = d1.map(|x| x / n);
        let along = (0..3).map(|i| t[i] * d2[i]).sum::<f64>();
        let k = [0, 1, 2].map(|i| (d2[i] - t[i] * along) / (n * n));
        (t, k)
    }
}

fn norm(x: [f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

#[test]
fn random_curves_and_jerks_from_20_to_1000_keep_every_axis_limit() {
    let mut seed = 0xc0ffee_u64;
    let mut r = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for case in 0..10 {
        let coef = [
            3.0 + 12.0 * r(),
            0.3 * r(),
            6.3 * r(),
            3.0 + 12.0 * r(),
            0.5 * r(),
            6.3 * r(),
            2.0 * r() - 1.0,
        ];
        let curve = Curve::new(coef, 1.0 + 1.5 * r());
        // log-uniform over 20..1000 m/s³
        let jerk = 2e4 * 50f64.powf(r());
        let (vmax, amax, feed) = (60.0 + 140.0 * r(), 500.0 + 2500.0 * r(), 20.0 + 130.0 * r());
        let (h, len) = (0.01, curve.len());
        let n = (len / h).ceil() as usize + 1;
        let at = |i: usize| (i as f64 * h).min(len);
        let shapes: Vec<([f64; 3], [f64; 3])> = (0..n).map(|i| curve.shape(at(i))).collect();
        let st = (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let ds = at(b) - at(a);
                let kd = [0, 1, 2].map(|k| (shapes[b].1[k] - shapes[a].1[k]) / ds);
                Station {
                    t: shapes[i].0,
                    k: shapes[i].1,
                    kd,
                    feed,
                }
            })
            .collect();
        let p = Path::new(h, len, st).unwrap();
        // the planner keeps 0.98 of the jerk and 0.999 of the acceleration,
        // as the bench does, for what sampling adds
        let plan = lim(vmax, 0.999 * amax, 0.98 * jerk);
        let s = run(p, plan);
        assert_eq!(*s.last().unwrap(), len, "case {case}");
        assert!(
            s.windows(2).all(|w| w[1] >= w[0]),
            "case {case}: never backwards"
        );
        let pts: Vec<[f64; 3]> = s.iter().map(|s| curve.at(*s)).collect();
        for ax in 0..3 {
            let x: Vec<f64> = pts.iter().map(|p| p[ax]).collect();
            let [v, a, j] = diffs(&x);
            let what = format!("case {case} axis {ax} (jerk {jerk:.0}, acc {amax:.0}, vel {vmax:.0}, feed {feed:.0})");
            assert!(v <= vmax * 1.001 && v <= feed * 1.001, "{what}: v {v}");
            assert!(a <= amax * 1.001, "{what}: a {a}");
            assert!(j <= jerk * 1.001, "{what}: j {j}");
        }
        // and it keeps moving: at least half the feed on average
        let mean = len / ((s.len() - 1) as f64 * DT);
        assert!(
            mean > 0.3 * feed.min(vmax),
            "case {case}: mean speed {mean} for feed {feed}"
        );
    }
}

#[test]
fn stations_given_as_they_come_give_the_same_samples_bit_for_bit_in_bounded_memory() {
    // 80 mm of line, a circle of R 4 mm, 80 mm of line again
    let (r, l) = (4.0, 80.0);
    let arc = std::f64::consts::TAU * r;
    let len = 2.0 * l + arc;
    let h = 0.01;
    let shape = move |s: f64| {
        if s < l {
            Station {
                t: [1.0, 0.0, 0.0],
                k: [0.0; 3],
                kd: [0.0; 3],
                feed: 100.0,
            }
        } else if s < l + arc {
            let mut st = circle(r, 100.0)(s - l);
            // the circle starts heading +X
            let (t, k, kd) = (st.t, st.k, st.kd);
            st.t = [t[1], -t[0], 0.0];
            st.k = [k[1], -k[0], 0.0];
            st.kd = [kd[1], -kd[0], 0.0];
            st
        } else {
            Station {
                t: [1.0, 0.0, 0.0],
                k: [0.0; 3],
                kd: [0.0; 3],
                feed: 60.0,
            }
        }
    };
    let n = (len / h).ceil() as usize + 1;
    let all: Vec<Station> = (0..n).map(|i| shape((i as f64 * h).min(len))).collect();
    let limits = lim(100.0, 1000.0, 5e4);
    let batch = run(Path::new(h, len, all.clone()).unwrap(), limits);
    // the same stations in chunks of 1 to 400, each given only when the
    // planner asks for more
    let mut seed = 7u64;
    let mut p = Planner::new(Path::open(h).unwrap(), limits, DT).unwrap();
    let (mut given, mut got, mut most) = (0, Vec::new(), 0);
    loop {
        match p.next_sample().unwrap() {
            Some(s) => got.push(s),
            None if p.arrived() => break,
            None if given < n => {
                seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                let chunk = 1 + (seed >> 33) as usize % 400;
                for st in &all[given..(given + chunk).min(n)] {
                    p.push(*st).unwrap();
                }
                given = (given + chunk).min(n);
                if given == n {
                    p.finish(len).unwrap();
                }
            }
            None => panic!("asks for more with every station given"),
        }
        most = most.max(p.path().kept());
    }
    assert_eq!(got.len(), batch.len());
    assert!(
        got.iter()
            .zip(&batch)
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "samples differ"
    );
    assert_eq!(*got.last().unwrap(), len);
    // what the planner keeps is its look-ahead (a braking from 100 mm/s
    // takes 6 mm), the last chunk and the path of the samples decided but
    // not handed out (a feed hold brakes from the last one handed out: 5
    // mm at 100 mm/s), not the 24,000 stations of the run
    assert!(most < 3000, "{most} stations kept");
}

/// How often the path jerk changes sign between two samples with both
/// over `share` of `j` (a jerk that chatters), from the path positions.
fn jerk_flips(x: &[f64], j: f64, share: f64) -> usize {
    let d3: Vec<f64> = x
        .windows(4)
        .map(|w| (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]) / (DT * DT * DT))
        .collect();
    d3.windows(2)
        .filter(|w| w[0] * w[1] < 0.0 && w[0].abs() > share * j && w[1].abs() > share * j)
        .count()
}

/// At a speed cap the jerk does not flip from sample to sample: the
/// approach onto the cap (`approach.rs`) lands on it and stays. Before
/// it, the greedy choice overshot and braked in turn: on this line at a
/// feed of 60 mm/s, 1,544 sign changes of the jerk over a fifth of its
/// limit and the speed down to 59.984 mm/s between them; on the
/// diagonal at the axes' 100 mm/s each (141.42 mm/s), 783 and 141.399.
#[test]
fn at_a_speed_cap_the_jerk_does_not_chatter() {
    let l = lim(100.0, 1000.0, 5e4);
    let r = std::f64::consts::FRAC_1_SQRT_2;
    let diag = move |_s: f64| Station {
        t: [r, r, 0.0],
        k: [0.0; 3],
        kd: [0.0; 3],
        feed: 200.0,
    };
    // (each with its tangent's largest component: the axes' differences
    // are the path's times that)
    for (s, cap, t) in [
        (run(path(200.0, 0.004, line_x(60.0)), l), 60.0, 1.0),
        (run(path(200.0, 0.004, diag), l), 100.0 / r, r),
    ] {
        assert_eq!(jerk_flips(&s, 5e4, 0.2), 0, "cap {cap}");
        // the middle half at the cap, to a nanometre a second
        let mid = &s[s.len() / 4..3 * s.len() / 4];
        for w in mid.windows(2) {
            let v = (w[1] - w[0]) / DT;
            assert!((v - cap).abs() < 1e-6, "{v} mm/s at cap {cap}");
        }
        let [v, a, j] = diffs(&s).map(|d| d * t);
        // (the third difference of positions near 100 mm rounds to 1e-6)
        assert!(
            v <= 100.0 * (1.0 + 1e-9) && a <= 1000.0 && j <= 5e4 * (1.0 + 1e-6),
            "{v} {a} {j}"
        );
    }
}
