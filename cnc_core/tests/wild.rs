//! Property test: random programs in all three planes, dense 3D
//! polylines and rapids keep every axis limit at every sample.
//!
//! `props.rs` draws its programs in XY (Z only on its random lines). Here
//! a program is runs of lines turning about Z and about a horizontal axis
//! (1 µm to 10 mm long: dense CAM polylines in space, polyline helices,
//! zigzags; some as rapids), arcs in G17, G18 or G19 of R 0.02 to 10 mm met
//! tangent or at a kink, and changes of feed and of path tolerance (G61,
//! G64 P), on the mill without a jerk limit or at 20 to 1000 m/s³, with a
//! feed hold or override for a while somewhere. Against the planner before
//! kinks counted their spacing (5d6b721) it fails after about 130 cases (Z
//! at 1,516 mm/s² against 1,500, a dense polyline in space); 60,000 cases
//! pass (`PROPTEST_CASES=60000 cargo test --release -p cnc_core --test
//! wild`, about a minute).
use cnc_core::exec::{Executor, Sample};
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use proptest::prelude::*;
#[path = "../../fuzz/fuzz_targets/common.rs"]
mod common;

fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Cases to run: `default`, or `PROPTEST_CASES` from the environment.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// One step of a program.
#[derive(Clone, Debug)]
enum St {
    /// `n` lines of `len` mm, the heading turned before each by `a` about
    /// Z and by `b` about X (rad)
    Poly {
        n: usize,
        len: f64,
        a: f64,
        b: f64,
        rapid: bool,
    },
    /// an arc in G`p` (17, 18, 19) of radius `r` and sweep `sweep` (rad),
    /// the heading turned by `k` in that plane before it (0: tangent)
    Arc {
        p: u8,
        r: f64,
        sweep: f64,
        ccw: bool,
        k: f64,
    },
    Feed {
        f: f64,
    },
    Tol {
        t: f64,
    },
}

fn st() -> impl Strategy<Value = St> {
    prop_oneof![
        3 => (1usize..80, prop_oneof![0.001..0.03f64, 0.03..1.0f64, 1.0..10.0f64], prop_oneof![-0.05..0.05f64, -0.6..0.6f64], prop_oneof![Just(0.0), -0.05..0.05f64, -0.5..0.5f64], prop::bool::weighted(0.15))
            .prop_map(|(n, len, a, b, rapid)| St::Poly { n, len, a, b, rapid }),
        2 => (17u8..20, prop_oneof![0.02..0.5f64, 0.5..10.0f64], 0.05..6.3f64, any::<bool>(), prop_oneof![Just(0.0), -0.3..0.3f64])
            .prop_map(|(p, r, sweep, ccw, k)| St::Arc { p, r, sweep, ccw, k }),
        1 => (50.0..20000.0f64).prop_map(|f| St::Feed { f }),
        1 => prop_oneof![Just(0.0), 0.001..0.1f64].prop_map(|t| St::Tol { t }),
    ]
}

/// The program of `sts` from X250 Y250 Z0 heading +X, and its end.
fn prog(sts: &[St], feed: f64) -> (String, [f64; 3]) {
    let mut p = [250.0f64, 250.0, 0.0];
    let mut d = [1.0f64, 0.0, 0.0];
    let mut s = format!("G17 G90 G64 P0\nG00 X250 Y250 Z0\nF{}\n", r4(feed));
    let rot = |d: &mut [f64; 3], i: usize, j: usize, a: f64| {
        let (c, sn) = (a.cos(), a.sin());
        let (x, y) = (d[i], d[j]);
        d[i] = x * c - y * sn;
        d[j] = x * sn + y * c;
    };
    for st in sts {
        match *st {
            St::Poly {
                n,
                len,
                a,
                b,
                rapid,
            } => {
                for _ in 0..n {
                    rot(&mut d, 0, 1, a);
                    rot(&mut d, 1, 2, b);
                    let nn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    for x in d.iter_mut() {
                        *x /= nn;
                    }
                    let e = [
                        r4(p[0] + len * d[0]),
                        r4(p[1] + len * d[1]),
                        r4((p[2] + len * d[2]).clamp(-80.0, 80.0)),
                    ];
                    if e == p {
                        continue;
                    }
                    s += &format!(
                        "{} X{} Y{} Z{}\n",
                        if rapid { "G00" } else { "G01" },
                        e[0],
                        e[1],
                        e[2]
                    );
                    p = e;
                }
            }
            St::Arc {
                p: pl,
                r,
                sweep,
                ccw,
                k,
            } => {
                let (i, j, g) = match pl {
                    17 => (0, 1, "G17"),
                    18 => (2, 0, "G18"),
                    _ => (1, 2, "G19"),
                };
                rot(&mut d, i, j, k);
                // tangent in plane: project d
                let (ti, tj) = (d[i], d[j]);
                let n = ti.hypot(tj);
                let (ti, tj) = if n < 1e-6 {
                    (1.0, 0.0)
                } else {
                    (ti / n, tj / n)
                };
                let (ni, nj) = if ccw { (-tj, ti) } else { (tj, -ti) };
                let c = [p[i] + r * ni, p[j] + r * nj];
                let a0 = (p[j] - c[1]).atan2(p[i] - c[0]);
                let a1 = if ccw { a0 + sweep } else { a0 - sweep };
                let mut e = p;
                e[i] = r4(c[0] + r * a1.cos());
                e[j] = r4(c[1] + r * a1.sin());
                if (e[0] - p[0]).abs() + (e[1] - p[1]).abs() + (e[2] - p[2]).abs() < 1e-4 {
                    continue;
                }
                let off = |k: usize, cc: f64| r4(cc - p[k]);
                let letter = ["I", "J", "K"];
                s += &format!(
                    "{g} {} X{} Y{} Z{} {}{} {}{}\n",
                    if ccw { "G03" } else { "G02" },
                    e[0],
                    e[1],
                    e[2],
                    letter[i],
                    off(i, c[0]),
                    letter[j],
                    off(j, c[1])
                );
                // end tangent
                let mut t = [0.0; 3];
                let (ei, ej) = (e[i] - c[0], e[j] - c[1]);
                let rn = ei.hypot(ej).max(1e-12);
                if ccw {
                    t[i] = -ej / rn;
                    t[j] = ei / rn;
                } else {
                    t[i] = ej / rn;
                    t[j] = -ei / rn;
                }
                d = t;
                p = e;
            }
            St::Feed { f } => s += &format!("F{}\n", r4(f)),
            St::Tol { t } => {
                s += &if t == 0.0 {
                    "G61\n".to_string()
                } else {
                    format!("G64 P{}\n", r4(t))
                }
            }
        }
    }
    (s, p)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), max_global_rejects: 1_000_000, ..ProptestConfig::default() })]
    /// (positions outside the mill's travel are refused by the check and
    /// skipped)
    #[test]
    fn programs_in_every_plane_keep_every_limit(sts in prop::collection::vec(st(), 1..10), feed in 50.0..20000.0f64,
            jerk in prop_oneof![Just(None), (2.0e4..1.0e6f64).prop_map(Some)],
                        hold in prop::option::of((10usize..3000, 1usize..3000, prop_oneof![Just(0.0), 0.05..1.0f64, 1.0..2.0f64, Just(2.0)]))) {
        let mut m = Machine::builtin_mill();
        for a in &mut m.axes { a.max_jerk_mm_s3 = jerk; }
        let (text, end) = prog(&sts, feed);
        let r = check(StrSource::new(&text), Dialect::Cnc836, &m);
        prop_assume!(r.ok());
        let mut ex = Executor::new(StrSource::new(&text), Dialect::Cnc836, &m);
        let mut s: Vec<Sample> = Vec::new();
        while let Some(x) = ex.next_sample() {
            if let Some((at, len, level)) = hold {
                if s.len() == at { ex.set_feed_target(level); } else if s.len() == at + len { ex.set_feed_target(1.0); }
            }
            s.push(x);
            prop_assert!(s.len() as u64 <= 2 * r.ticks + 10_000, "no end\n{}", text);
        }
        let last = s.last().unwrap();
        prop_assert_eq!([last.pos.x, last.pos.y, last.pos.z], end);
        if hold.is_none() { prop_assert_eq!(last.k, r.ticks); }
        let pos: Vec<[f64; 3]> = s.iter().map(|x| [x.pos.x, x.pos.y, x.pos.z]).collect();
        let o = common::over_a_limit(&m, &pos, true);
        prop_assert!(o.is_none(), "{}\n{}", o.unwrap_or_default(), text);
    }
}
