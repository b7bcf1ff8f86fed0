//! Property tests: random programs of lines and arcs never exceed an axis
//! limit at any sample, end exactly on their end point, and run exactly as
//! long as the check estimated.

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Mv {
    Line {
        dx: f64,
        dy: f64,
        dz: f64,
        rapid: bool,
    },
    Arc {
        r: f64,
        a0: f64,
        sweep: f64,
        ccw: bool,
    },
}

fn mv() -> impl Strategy<Value = Mv> {
    prop_oneof![
        (
            -30.0..30.0f64,
            -30.0..30.0f64,
            -5.0..5.0f64,
            prop::bool::weighted(0.2)
        )
            .prop_map(|(dx, dy, dz, rapid)| Mv::Line { dx, dy, dz, rapid }),
        (
            0.5..25.0f64,
            0.0..std::f64::consts::TAU,
            0.1..6.2f64,
            any::<bool>()
        )
            .prop_map(|(r, a0, sweep, ccw)| Mv::Arc { r, a0, sweep, ccw }),
    ]
}

fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Builds a program; positions stay inside the mill's travel.
fn program(moves: &[Mv], feed: f64) -> (String, V3) {
    let mut p = V3::new(250.0, 250.0, 0.0);
    let mut s = format!("G17 G90 G00 X{} Y{} Z{}\nF{}\n", p.x, p.y, p.z, r4(feed));
    for m in moves {
        match *m {
            Mv::Line { dx, dy, dz, rapid } => {
                let e = V3::new(
                    r4(p.x + dx),
                    r4(p.y + dy),
                    r4((p.z + dz).clamp(-50.0, 50.0)),
                );
                s += &format!(
                    "{} X{} Y{} Z{}\n",
                    if rapid { "G00" } else { "G01" },
                    e.x,
                    e.y,
                    e.z
                );
                p = e;
            }
            Mv::Arc { r, a0, sweep, ccw } => {
                // centre at distance r from the start, in direction a0 + pi
                let c = (p.x - r * a0.cos(), p.y - r * a0.sin());
                let a1 = if ccw { a0 + sweep } else { a0 - sweep };
                let e = (r4(c.0 + r * a1.cos()), r4(c.1 + r * a1.sin()));
                s += &format!(
                    "{} X{} Y{} I{} J{}\n",
                    if ccw { "G03" } else { "G02" },
                    e.0,
                    e.1,
                    r4(c.0 - p.x),
                    r4(c.1 - p.y)
                );
                p = V3::new(e.0, e.1, p.z);
            }
        }
    }
    (s, p)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_programs_respect_limits_and_end_exactly(
        moves in prop::collection::vec(mv(), 1..12),
        feed in 100.0..20000.0f64,
    ) {
        let m = Machine::builtin_mill();
        let (text, end) = program(&moves, feed);
        let r = check(StrSource::new(&text), Dialect::Cnc836, &m);
        // rounding of the centre can exceed the tolerance only for tiny radii; skip those
        prop_assume!(r.ok());
        let s: Vec<Sample> = Executor::new(StrSource::new(&text), Dialect::Cnc836, &m).collect();
        let last = s.last().unwrap();
        prop_assert_eq!(last.pos, end);
        prop_assert_eq!(last.k, r.ticks);
        let dt = m.dt();
        let (vmax, amax) = (m.vmax(), m.amax());
        let vel: Vec<V3> = s.windows(2).map(|w| (w[1].pos - w[0].pos) / dt).collect();
        for (k, v) in vel.iter().enumerate() {
            for i in 0..3 {
                prop_assert!(v[i].abs() <= vmax[i] * (1.0 + 1e-9), "v[{}] = {} at sample {}\n{}", i, v[i], k, text);
            }
        }
        for (k, w) in vel.windows(2).enumerate() {
            let a = (w[1] - w[0]) / dt;
            for i in 0..3 {
                prop_assert!(a[i].abs() <= amax[i] * (1.0 + 1e-6) + 1e-6, "a[{}] = {} at sample {}\n{}", i, a[i], k + 1, text);
            }
        }
    }
}

/// Distance from `p` to the segment `a`-`b`.
fn seg_dist(p: V3, a: V3, b: V3) -> f64 {
    let d = b - a;
    let l2 = d.norm_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(&d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + d * t)).norm()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// G64 P: corners blended within the tolerance, limits kept, the end
    /// exact, the estimate exact; polylines of short and long lines, some
    /// leaving the XY plane (not blended), at any feed.
    #[test]
    fn blended_polylines_stay_within_the_tolerance(
        steps in prop::collection::vec(
            (0.01..20.0f64, 0.0..std::f64::consts::TAU, prop::bool::weighted(0.15)),
            2..40,
        ),
        tol in 0.001..0.5f64,
        feed in 300.0..12000.0f64,
    ) {
        let m = Machine::builtin_mill();
        let mut p = V3::new(250.0, 250.0, 0.0);
        // (the first rapid comes from home)
        let mut pts = vec![m.home(), p];
        let mut text = format!("G17 G90 G64 P{}\nG00 X{} Y{} Z{}\nF{}\n", r4(tol), p.x, p.y, p.z, r4(feed));
        for &(len, ang, lift) in &steps {
            let e = V3::new(
                r4(p.x + len * ang.cos()),
                r4(p.y + len * ang.sin()),
                if lift { r4(p.z + 1.0) } else { p.z },
            );
            if e == p {
                continue;
            }
            text += &format!("G01 X{} Y{} Z{}\n", e.x, e.y, e.z);
            p = e;
            pts.push(p);
        }
        let r = check(StrSource::new(&text), Dialect::Cnc836, &m);
        prop_assert!(r.ok(), "{}", r.message());
        let s: Vec<Sample> = Executor::new(StrSource::new(&text), Dialect::Cnc836, &m).collect();
        let last = s.last().unwrap();
        prop_assert_eq!(last.pos, p);
        prop_assert_eq!(last.k, r.ticks);
        for x in &s {
            let d = pts.windows(2).map(|w| seg_dist(x.pos, w[0], w[1])).fold(f64::MAX, f64::min);
            prop_assert!(d <= r4(tol) + 1e-9, "{} mm off the path at k={} (P{})\n{}", d, x.k, r4(tol), text);
        }
        let dt = m.dt();
        let (vmax, amax) = (m.vmax(), m.amax());
        let vel: Vec<V3> = s.windows(2).map(|w| (w[1].pos - w[0].pos) / dt).collect();
        for v in &vel {
            for i in 0..3 {
                prop_assert!(v[i].abs() <= vmax[i] * (1.0 + 1e-9));
            }
        }
        for (k, w) in vel.windows(2).enumerate() {
            let a = (w[1] - w[0]) / dt;
            for i in 0..3 {
                prop_assert!(a[i].abs() <= amax[i] * (1.0 + 1e-6) + 1e-6, "a[{}] = {} at sample {}\n{}", i, a[i], k + 1, text);
            }
        }
    }
}
