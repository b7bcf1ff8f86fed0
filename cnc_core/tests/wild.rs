//! Property tests: random programs in all three planes, dense 3D
//! polylines and rapids, lathe programs with feed per revolution, and
//! compensated chains keep every axis limit at every sample.
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
use cnc_core::machine::PlanMethod;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use proptest::prelude::*;
#[path = "../../fuzz/fuzz_targets/common.rs"]
mod common;
mod runs;
use runs::{cases, hold, r4, samples_with_hold, turn_in};

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
                    turn_in(&mut d, 0, 1, a);
                    turn_in(&mut d, 1, 2, b);
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
                turn_in(&mut d, i, j, k);
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

/// Jerk limits: none, or 20 to 1000 m/s³.
fn jerk() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![Just(None), (2.0e4..1.0e6f64).prop_map(Some)]
}

/// Checks `text` on the mill at `jerk` (a program the check refuses is
/// rejected), runs it with `hold`, and asserts every axis within its
/// limits at every sample, the end at `end` (if given) and, without a
/// hold, on the check's tick.
fn run_keeps_every_limit(
    text: &str,
    end: Option<[f64; 3]>,
    jerk: Option<f64>,
    hold: Option<(usize, usize, f64)>,
) -> Result<(), TestCaseError> {
    run_on_keeps_every_limit(Machine::builtin_mill(), text, end, jerk, hold)
}

/// [`run_keeps_every_limit`] on machine `m`.
fn run_on_keeps_every_limit(
    mut m: Machine,
    text: &str,
    end: Option<[f64; 3]>,
    jerk: Option<f64>,
    hold: Option<(usize, usize, f64)>,
) -> Result<(), TestCaseError> {
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = jerk;
    }
    // (the look-ahead and its filters at any jerk; the path planner's
    // property tests are in props.rs)
    m.planner.method = PlanMethod::Filters;
    let r = check(StrSource::new(text), Dialect::Cnc836, &m);
    if !r.ok() {
        return Err(TestCaseError::reject("not accepted"));
    }
    let s = samples_with_hold(&m, text, r.ticks, hold)?;
    let last = s.last().unwrap();
    if let Some(end) = end {
        prop_assert_eq!([last.pos.x, last.pos.y, last.pos.z], end);
    }
    if hold.is_none() {
        prop_assert_eq!(last.k, r.ticks);
    }
    let pos: Vec<[f64; 3]> = s.iter().map(|x| [x.pos.x, x.pos.y, x.pos.z]).collect();
    let o = common::over_a_limit(&m, &pos, true);
    prop_assert!(o.is_none(), "{}\n{}", o.unwrap_or_default(), text);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: cases(256),
        max_global_rejects: 1_000_000,
        ..ProptestConfig::default()
    })]

    /// (positions outside the mill's travel are refused by the check and
    /// skipped)
    #[test]
    fn programs_in_every_plane_keep_every_limit(
        sts in prop::collection::vec(st(), 1..10),
        feed in 50.0..20000.0f64,
        jerk in jerk(),
        hold in hold(),
    ) {
        let (text, end) = prog(&sts, feed);
        run_keeps_every_limit(&text, Some(end), jerk, hold)?;
    }
}

/// An arc in a plane from `p`, leaving along heading `d` turned by `k`
/// rad, of radius `r` and sweep `sweep` rad (`ccw`: to the left): its
/// centre (rounded), its end (rounded) and the heading at its end.
fn arc2(
    p: [f64; 2],
    mut d: [f64; 2],
    r: f64,
    sweep: f64,
    ccw: bool,
    k: f64,
) -> ([f64; 2], [f64; 2], [f64; 2]) {
    turn_in(&mut d, 0, 1, k);
    let (nx, ny) = if ccw { (-d[1], d[0]) } else { (d[1], -d[0]) };
    let c = [r4(p[0] + r * nx), r4(p[1] + r * ny)];
    let a0 = (p[1] - c[1]).atan2(p[0] - c[0]);
    let a1 = if ccw { a0 + sweep } else { a0 - sweep };
    let e = [r4(c[0] + r * a1.cos()), r4(c[1] + r * a1.sin())];
    let (ex, ey) = (e[0] - c[0], e[1] - c[1]);
    let rn = ex.hypot(ey).max(1e-12);
    let t = if ccw {
        [-ey / rn, ex / rn]
    } else {
        [ey / rn, -ex / rn]
    };
    (c, e, t)
}

/// One step of a lathe program: runs of lines in XZ (some rapids), arcs
/// met tangent or at a kink, feed per revolution or per minute, spindle
/// speed.
#[derive(Clone, Debug)]
enum Ls {
    Poly {
        n: usize,
        len: f64,
        a: f64,
        zig: bool,
        rapid: bool,
    },
    Arc {
        r: f64,
        sweep: f64,
        ccw: bool,
        k: f64,
    },
    Fpr {
        f: f64,
    },
    Fpm {
        f: f64,
    },
    S {
        s: f64,
    },
}
fn ls() -> impl Strategy<Value = Ls> {
    prop_oneof![
        3 => (1usize..60, prop_oneof![0.001..0.05f64, 0.05..2.0f64, 2.0..20.0f64], prop_oneof![-0.03..0.03f64, -0.5..0.5f64], any::<bool>(), prop::bool::weighted(0.1)).prop_map(|(n, len, a, zig, rapid)| Ls::Poly { n, len, a, zig, rapid }),
        2 => (prop_oneof![0.05..2.0f64, 2.0..20.0f64], 0.05..3.0f64, any::<bool>(), prop_oneof![Just(0.0), -0.3..0.3f64]).prop_map(|(r, sweep, ccw, k)| Ls::Arc { r, sweep, ccw, k }),
        1 => (0.01..0.5f64).prop_map(|f| Ls::Fpr { f }),
        1 => (50.0..10000.0f64).prop_map(|f| Ls::Fpm { f }),
        1 => (50.0..3000.0f64).prop_map(|s| Ls::S { s }),
    ]
}
/// The lathe program of `sts` in path tolerance `tol` (0: G64 P0),
/// from X60 Z0 heading −Z; the geometry in radius coordinates (x, z), X
/// written as a diameter.
fn lathe_prog(sts: &[Ls], tol: f64) -> String {
    let mut p = [30.0f64, 0.0];
    let mut d = [0.0f64, -1.0];
    let mut s = format!(
        "G18 G90 G64 P{} M03 S1000\nG00 X60 Z0\nG94 F1000\n",
        r4(tol)
    );
    for st in sts {
        match *st {
            Ls::Poly {
                n,
                len,
                a,
                zig,
                rapid,
            } => {
                for i in 0..n {
                    turn_in(&mut d, 0, 1, if zig && i % 2 == 1 { -a } else { a });
                    let e = [
                        r4((p[0] + len * d[0]).clamp(1.0, 140.0)),
                        r4((p[1] + len * d[1]).clamp(-290.0, 40.0)),
                    ];
                    if e == p {
                        continue;
                    }
                    s += &format!(
                        "{} X{} Z{}\n",
                        if rapid { "G00" } else { "G01" },
                        r4(2.0 * e[0]),
                        e[1]
                    );
                    p = e;
                }
            }
            Ls::Arc { r, sweep, ccw, k } => {
                let (c, e, t) = arc2(p, d, r, sweep, ccw, k);
                if e == p || e[0] < 1.0 || e[0] > 140.0 || e[1] < -290.0 || e[1] > 40.0 {
                    continue;
                }
                s += &format!(
                    "{} X{} Z{} I{} K{}\n",
                    if ccw { "G03" } else { "G02" },
                    r4(2.0 * e[0]),
                    e[1],
                    r4(c[0] - p[0]),
                    r4(c[1] - p[1])
                );
                d = t;
                p = e;
            }
            Ls::Fpr { f } => s += &format!("G95 F{}\n", r4(f)),
            Ls::Fpm { f } => s += &format!("G94 F{}\n", r4(f)),
            Ls::S { s: sp } => s += &format!("S{}\n", sp.round()),
        }
    }
    s += "M30\n";
    s
}

/// One step of a compensated program.
#[derive(Clone, Debug)]
enum Cs {
    Poly {
        n: usize,
        len: f64,
        a: f64,
        zig: bool,
    },
    Arc {
        r: f64,
        sweep: f64,
        ccw: bool,
        k: f64,
    },
}
fn cs() -> impl Strategy<Value = Cs> {
    prop_oneof![
        (
            1usize..60,
            prop_oneof![0.001..0.05f64, 0.05..2.0f64, 2.0..20.0f64],
            prop_oneof![-0.03..0.03f64, -0.5..0.5f64],
            any::<bool>()
        )
            .prop_map(|(n, len, a, zig)| Cs::Poly { n, len, a, zig }),
        (
            prop_oneof![0.05..2.0f64, 2.0..20.0f64],
            0.05..3.0f64,
            any::<bool>(),
            prop_oneof![Just(0.0), -0.3..0.3f64]
        )
            .prop_map(|(r, sweep, ccw, k)| Cs::Arc { r, sweep, ccw, k }),
    ]
}
/// A compensated program of `sts` (tool `tool`, G41 if `left`, else G42)
/// from X260 Y250 heading +X; compensation ends 10 mm on along the last
/// heading.
fn comp_prog(sts: &[Cs], feed: f64, tol: f64, tool: u32, left: bool) -> String {
    let mut d = [1.0f64, 0.0];
    let mut s = format!(
        "G17 G90 G64 P{} T{tool}\nG00 X250 Y250 Z0\nF{}\n{} G01 X260 Y250\n",
        r4(tol),
        r4(feed),
        if left { "G41" } else { "G42" }
    );
    let mut p = [260.0f64, 250.0];
    for st in sts {
        match *st {
            Cs::Poly { n, len, a, zig } => {
                for i in 0..n {
                    turn_in(&mut d, 0, 1, if zig && i % 2 == 1 { -a } else { a });
                    let e = [r4(p[0] + len * d[0]), r4(p[1] + len * d[1])];
                    if e == p {
                        continue;
                    }
                    s += &format!("G01 X{} Y{}\n", e[0], e[1]);
                    p = e;
                }
            }
            Cs::Arc { r, sweep, ccw, k } => {
                let (c, e, t) = arc2(p, d, r, sweep, ccw, k);
                if e == p {
                    continue;
                }
                s += &format!(
                    "{} X{} Y{} I{} J{}\n",
                    if ccw { "G03" } else { "G02" },
                    e[0],
                    e[1],
                    r4(c[0] - p[0]),
                    r4(c[1] - p[1])
                );
                d = t;
                p = e;
            }
        }
    }
    s += &format!(
        "G40 G01 X{} Y{}\nM30\n",
        r4(p[0] + 10.0 * d[0]),
        r4(p[1] + 10.0 * d[1])
    );
    s
}
proptest! {
    #![proptest_config(ProptestConfig {
        cases: cases(128),
        max_global_rejects: 1_000_000,
        ..ProptestConfig::default()
    })]

    /// Tool radius compensation (G41/G42 with the mill's tools of R 5, 3
    /// and 1 mm) of CAM polylines (1 µm to 20 mm lines, kinks, zigzags)
    /// and arcs of R 0.05 to 20 mm, met tangent or at a kink: the offset
    /// path's corner arcs and trimmed lines keep every axis within its
    /// limits at every sample, without a jerk limit or at 20 to 1000
    /// m/s³, with a feed hold or override for a while somewhere, and run
    /// as estimated (programs the compensation refuses, as too short for
    /// the radius or cutting into the contour, are skipped: about two in
    /// three). 20,000 accepted cases pass. It found the kink behind a move
    /// shorter than a sample:
    /// `a_kink_behind_a_move_shorter_than_a_sample_keeps_the_limit`.
    #[test]
    fn compensated_chains_keep_every_limit(
        sts in prop::collection::vec(cs(), 1..8),
        feed in 50.0..20000.0f64,
        tol in prop_oneof![Just(0.0), 0.001..0.1f64],
        tool in 1u32..4,
        left in any::<bool>(),
        jerk in jerk(),
        hold in hold(),
    ) {
        let text = comp_prog(&sts, feed, tol, tool, left);
        run_keeps_every_limit(&text, None, jerk, hold)?;
    }

    /// The bundled lathe (X as a diameter): CAM polylines in XZ of 1 µm
    /// to 20 mm lines (kinks, zigzags, some rapids), arcs of R 0.05 to 20
    /// mm, G95 feed per revolution and G94 feed per minute, spindle speed
    /// changes, G64 P0 or a tolerance, without a jerk limit or at 20 to
    /// 1000 m/s³: every axis within its limits at every sample, and the
    /// run as estimated. 20,000 cases pass (`PROPTEST_CASES=20000 cargo
    /// test --release -p cnc_core --test wild lathe`, under 2 min).
    #[test]
    fn lathe_programs_keep_every_limit(
        sts in prop::collection::vec(ls(), 1..10),
        tol in prop_oneof![Just(0.0), 0.001..0.1f64],
        jerk in jerk(),
    ) {
        let text = lathe_prog(&sts, tol);
        run_on_keeps_every_limit(Machine::builtin_lathe(), &text, None, jerk, None)?;
    }
}

/// Without a jerk limit, a kink whose move before it is shorter than a
/// sample's path. Here the compensation of a zigzag of 9.6 µm lines makes
/// collinear lines, the last of them 7.5 µm long, and a kink of 0.004 rad
/// into an arc at 63.5 mm/s. The kink reserved 15 % of the acceleration in
/// the two moves that meet there, but the sample around it also took in
/// the line before the short one, which ran at the whole acceleration: X
/// reached 2,000.095 mm/s² (limit 2,000; the property's case, with one
/// more polyline and a hold, 2,000.34). The moves within two samples' path
/// of a kink now keep its reserve, or the kink's speed is capped
/// (plan/turns.rs).
#[test]
fn a_kink_behind_a_move_shorter_than_a_sample_keeps_the_limit() {
    let sts = [
        Cs::Arc {
            r: 8.715023001126724,
            sweep: 2.470792042598107,
            ccw: false,
            k: 0.14037442249642199,
        },
        Cs::Arc {
            r: 1.0707604214395392,
            sweep: 1.319626315606895,
            ccw: true,
            k: 0.0,
        },
        Cs::Arc {
            r: 0.09940065184312817,
            sweep: 2.9514580038838356,
            ccw: false,
            k: 0.27650191926666023,
        },
        Cs::Poly {
            n: 54,
            len: 0.009608530518983577,
            a: -0.00896487935248491,
            zig: true,
        },
        Cs::Arc {
            r: 11.859668705773155,
            sweep: 2.9155215739734697,
            ccw: false,
            k: 0.0,
        },
    ];
    let text = comp_prog(&sts, 18745.608217249788, 0.0, 3, true);
    let r = run_keeps_every_limit(&text, None, None, None);
    assert!(r.is_ok(), "{r:?}");
}
