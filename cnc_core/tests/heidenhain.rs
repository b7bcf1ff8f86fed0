//! The heidenhain dialect's polar coordinates (`docs/dialects.md` §3): the pole,
//! polar lines G10/G11, polar arcs G12/G13/G15, R and H.

use cnc_core::canon::Event;
use cnc_core::exec::{Executor, Sample};
use cnc_core::geom::Geom;
use cnc_core::interp::Interpreter;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};

mod common;

const EXAMPLE: &str = include_str!("../../examples/heidenhain_polar.h");

fn moves(text: &str, m: &Machine) -> Vec<Geom> {
    let r = check(StrSource::new(text), Dialect::Heidenhain, m);
    assert!(r.ok(), "{}", r.message());
    Interpreter::new(StrSource::new(text), Dialect::Heidenhain, m)
        .filter_map(|e| match e {
            Event::Move { geom, .. } => Some(geom),
            _ => None,
        })
        .collect()
}

fn errors(text: &str) -> Vec<String> {
    let r = check(
        StrSource::new(text),
        Dialect::Heidenhain,
        &Machine::builtin_mill(),
    );
    r.errors.iter().map(|e| e.to_string()).collect()
}

fn near(a: V3, b: V3) -> bool {
    (a - b).norm() < 1e-9
}

#[test]
fn the_seed_examples_reach_the_named_points() {
    let m = Machine::builtin_mill();
    let g = moves(EXAMPLE, &m);
    let s3 = 3f64.sqrt();
    // N130..N160 about (45, 45): (75, 45), R30 at 60, 120, 180 degrees
    assert!(near(g[1].end(), V3::new(75.0, 45.0, 2.0)), "{}", g[1].end());
    assert!(
        near(g[2].end(), V3::new(60.0, 45.0 + 15.0 * s3, 2.0)),
        "{}",
        g[2].end()
    );
    assert!(
        near(g[3].end(), V3::new(30.0, 45.0 + 15.0 * s3, 2.0)),
        "{}",
        g[3].end()
    );
    assert!(near(g[4].end(), V3::new(15.0, 45.0, 2.0)), "{}", g[4].end());
    // straight lines
    assert!(matches!(g[2], Geom::Line { .. }));
    // N170 rapid to R40 at 270 degrees
    assert!(near(g[5].end(), V3::new(45.0, 5.0, 2.0)), "{}", g[5].end());
    // N200: the CCW half circle about (25, 25) from (45, 25) to (5, 25)
    let Geom::Arc(a) = g[7] else {
        panic!("N200 is an arc")
    };
    assert!(near(a.start, V3::new(45.0, 25.0, 2.0)) && near(a.end, V3::new(5.0, 25.0, 2.0)));
    assert!((a.sweep - std::f64::consts::PI).abs() < 1e-12 && (a.radius - 20.0).abs() < 1e-12);
    // it passes (25, 45), not (25, 5)
    let mid = g[7].eval(g[7].length() / 2.0);
    assert!(near(mid, V3::new(25.0, 45.0, 2.0)), "{mid}");
}

#[test]
fn a_multi_turn_polar_helix_ends_3_mm_lower_after_exactly_three_turns() {
    let m = Machine::builtin_mill();
    let g = moves(EXAMPLE, &m);
    let Geom::Arc(h) = g[8] else {
        panic!("N210 is an arc")
    };
    assert_eq!(h.sweep, 3.0 * std::f64::consts::TAU);
    assert_eq!(
        (h.end.x, h.end.y),
        (h.start.x, h.start.y),
        "back where it started"
    );
    assert_eq!(h.end.z, h.start.z - 3.0);
    assert_eq!(h.end, V3::new(5.0, 25.0, -1.0));
}

#[test]
fn every_sample_of_a_polar_arc_is_on_its_circle() {
    let m = Machine::builtin_mill();
    let r = check(StrSource::new(EXAMPLE), Dialect::Heidenhain, &m);
    let s: Vec<Sample> = Executor::new(StrSource::new(EXAMPLE), Dialect::Heidenhain, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    // the XYZ jerk filter (M samples) pulls a sample at speed v inside the
    // circle by v²(M²−1)dt²/(24 r): never outside, never further in (the
    // first samples of the block trail in the line before, which is
    // outside: both filters' windows)
    let mf = m.jerk_budget().m_f as f64;
    assert_eq!(mf, 6.0);
    let lag = common::filter_lag(&m);
    let mut n = 0;
    let mut worst: f64 = 0.0;
    let on = |x: &Sample| x.src.line == 16 || x.src.line == 17;
    for (i, x) in s
        .iter()
        .enumerate()
        .filter(|&(i, x)| on(x) && i >= lag && s[i - lag..i].iter().all(on))
    {
        let d = ((x.pos.x - 25.0).powi(2) + (x.pos.y - 25.0).powi(2)).sqrt();
        let inside = common::filter_shrink(&m, &s, i, 20.0);
        assert!(
            d <= 20.0 + 1e-9 && 20.0 - d <= inside,
            "line {}: off the circle by {:e} (filter: {inside:e})",
            x.src.line,
            d - 20.0
        );
        worst = worst.max(20.0 - d);
        n += 1;
    }
    // F2500 = 41.67 mm/s, M = 6: 41.67²·35·1e-6/480 = 1.266e-4 mm
    let v: f64 = 2500.0 / 60.0;
    let expect = v * v * (mf * mf - 1.0) * 1e-6 / 480.0;
    assert!((1.265e-4..1.267e-4).contains(&expect), "{expect:e}");
    assert!(
        worst > expect * 0.995 && worst < expect * 1.005,
        "{worst:e} against {expect:e}"
    );
    assert!(n > 5000, "{n}");
    // the helix: Z falls linearly with the turned angle
    // the stop after it is sampled exactly: the next block starts there
    let after = s.iter().find(|x| x.src.line == 18).unwrap();
    assert_eq!(after.pos, V3::new(5.0, 25.0, -1.0));
}

#[test]
fn r_and_h_are_modal_and_incremental_under_g91() {
    let m = Machine::builtin_mill();
    let g = moves(
        "N1 I+50 J+50 *\nN2 G11 R+10 H+0 F1000 *\nN3 G91 R+5 *\nN4 H+90 *\nN5 G90 H-90 *\n",
        &m,
    );
    assert!(
        near(g[1].end(), V3::new(65.0, 50.0, 0.0)),
        "R10 + 5: {}",
        g[1].end()
    );
    assert!(
        near(g[2].end(), V3::new(50.0, 65.0, 0.0)),
        "R15 at 90: {}",
        g[2].end()
    );
    assert!(
        near(g[3].end(), V3::new(50.0, 35.0, 0.0)),
        "R15 at -90: {}",
        g[3].end()
    );
    assert_eq!(
        g[3].end(),
        V3::new(50.0, 35.0, 0.0),
        "exact at multiples of 90 degrees"
    );
    // G29: the pole where the tool stands
    let g = moves("N1 G00 X20 Y20 *\nN2 G29 *\nN3 G11 R+5 H+90 F1000 *\n", &m);
    assert!(near(g[1].end(), V3::new(20.0, 25.0, 0.0)), "{}", g[1].end());
    // G15: the last direction; absolute H on an arc, clockwise the long way
    let g = moves(
        "N1 I+50 J+50 *\nN2 G11 R+10 H+0 F1000 *\nN3 G12 H+90 *\nN4 G15 H+0 *\n",
        &m,
    );
    let (Geom::Arc(a), Geom::Arc(b)) = (g[1], g[2]) else {
        panic!()
    };
    assert!(
        (a.sweep + 1.5 * std::f64::consts::PI).abs() < 1e-12,
        "{}",
        a.sweep
    );
    assert!(
        (b.sweep + 0.5 * std::f64::consts::PI).abs() < 1e-12,
        "{}",
        b.sweep
    );
}

#[test]
fn polar_in_g18_and_g19_and_on_the_lathe() {
    let m = Machine::builtin_mill();
    // G18: angles from +Z towards +X; the pole is I (X) and K (Z)
    let g = moves(
        "N1 G18 *\nN2 I+50 K+10 *\nN3 G11 R+10 H+90 F1000 *\nN4 G13 H+180 *\n",
        &m,
    );
    assert!(near(g[0].end(), V3::new(60.0, 0.0, 10.0)), "{}", g[0].end());
    assert!(near(g[1].end(), V3::new(50.0, 0.0, 0.0)), "{}", g[1].end());
    // G19: angles from +Y towards +Z; the pole is J (Y) and K (Z)
    let g = moves("N1 G19 *\nN2 J+50 K+10 *\nN3 G11 R+10 H+90 F1000 *\n", &m);
    assert!(near(g[0].end(), V3::new(0.0, 50.0, 20.0)), "{}", g[0].end());
    // lathe (G18, X a diameter: the pole's I too)
    let l = Machine::builtin_lathe();
    let g = moves(
        "N1 I+40 K-10 *\nN2 G11 R+5 H+180 F300 *\nN3 G12 H+90 *\n",
        &l,
    );
    assert!(
        near(g[0].end(), V3::new(20.0, 0.0, -15.0)),
        "{}",
        g[0].end()
    );
    assert!(
        near(g[1].end(), V3::new(25.0, 0.0, -10.0)),
        "{}",
        g[1].end()
    );
}

#[test]
fn a_polar_move_along_an_axis_the_lathe_does_not_have_is_refused() {
    // G17 and G19 name the lathe's missing Y; a Y word is refused by
    // itself, and so now is a polar block (or its compensated path) that
    // moves along Y. Before, the check passed them and reckoned the Y
    // travel at no cost (0.054 s for the second program), while a run
    // moved the missing axis for 0.265 s.
    let l = Machine::builtin_lathe();
    let errs = |text: &str| -> Vec<String> {
        check(StrSource::new(text), Dialect::Heidenhain, &l)
            .errors
            .iter()
            .map(|e| e.to_string())
            .collect()
    };
    assert_eq!(
        errs("N10 G17 *\nN20 I5 J5 *\nN30 G10 R10 H45 *\n"),
        ["line 3, column 5: block N30: travel limit: the move ends at Y 12.0711, an axis this machine does not have"]
    );
    assert_eq!(
        errs("N10 T2 G41 G19 *\nN30 J-255.55 G00 *\nN40 G10 R166.2 *\nN50 R26 *\n"),
        [
            "line 4, column 1: block N50: travel limit: with radius compensation the path of block N40 reaches Y -89.35, an axis this machine does not have",
            "line 4, column 1: block N50: travel limit: with radius compensation the path of block N50 reaches Y -229.55, an axis this machine does not have",
        ]
    );
    // in G18 a polar move stays on the lathe's axes
    assert!(errs("N1 I+40 K-10 *\nN2 G11 R+5 H+180 F300 *\n").is_empty());
}

#[test]
fn polar_rule_errors() {
    assert_eq!(
        errors("N1 G11 R+10 H+0 F100 *\n"),
        ["line 1, column 4: block N1: a polar block needs a pole: a block with I and J (or G29) before it"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+400 F100 *\n"),
        ["line 2, column 13: block N2: polar angle H400 is outside -360..+360 degrees for a line"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G13 H+5500 *\n"),
        ["line 3, column 8: block N3: polar angle H5500 is outside -5400..+5400 degrees for an arc"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G91 G12 H+90 *\n"),
        ["line 3, column 12: block N3: incremental H90 turns counter-clockwise but G12 turns clockwise: the sign must match the direction (+ for G13, - for G12)"]
    );
    // H0 has no direction: it turns nothing
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G91 G13 H+0 *\n"),
        ["line 3, column 12: block N3: incremental H0 turns nothing: G13 needs the angle it turns, + for G13, - for G12 (a whole circle is H+360 or H-360)"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G15 H+90 *\n"),
        ["line 3, column 4: block N3: G15 (polar arc, last direction) needs a G12 or G13 before it"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R+10 H+0 F100 *\nN3 G13 R+5 H+90 *\n"),
        ["line 3, column 8: block N3: a polar arc takes no R: its radius is the distance from the start point to the pole"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 R-10 H+0 F100 *\n"),
        ["line 2, column 8: block N2: polar radius R must be greater than 0, it is -10"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 *\nN2 G11 X10 H+0 F100 *\n"),
        ["line 2, column 8: block N2: X is an axis of the G17 plane: a polar block gives its end point by R and H"]
    );
    assert_eq!(
        errors("N1 I+50 J+50 K+3 *\n"),
        ["line 1, column 14: block N1: K is no pole coordinate in G17: the pole is I and J"]
    );
    assert_eq!(
        errors("N1 G01 X10 H+5 F100 *\n"),
        ["line 1, column 12: block N1: H is a polar coordinate: it needs G10, G11, G12, G13 or G15"]
    );
    // the polar words are heidenhain's only
    let r = check(
        StrSource::new("N1 G11 R10 H0\n"),
        Dialect::Cnc836,
        &Machine::builtin_mill(),
    );
    assert_eq!(
        r.errors[0].to_string(),
        "line 1, column 4: block N1: unsupported G code G11 in the cnc836 dialect"
    );
}

/// A pole block's other words count: its feed, spindle and plane (the
/// pole is read in the plane the block selects) and its end. Before, they
/// were dropped: `I+50 J+50 F500` lost the F ("missing feed" at the next
/// block) and `G18 I.. K..` read the pole in G17.
#[test]
fn a_pole_blocks_other_words_count() {
    let m = Machine::builtin_mill();
    assert_eq!(
        errors("N1 I+50 J+50 F500 *\nN2 G11 R+10 H+0 *\nN3 M30 *\n"),
        Vec::<String>::new()
    );
    let g = moves("N1 I+50 J+50 F500 *\nN2 G11 R+10 H+90 *\n", &m);
    assert_eq!(g.len(), 1);
    assert!(
        near(g[0].end(), V3::new(50.0, 60.0, 0.0)),
        "{:?}",
        g[0].end()
    );
    // G18: the pole is K (Z) and I (X)
    let g = moves(
        "N1 G00 Z5 *\nN2 G18 I+10 K+5 F300 *\nN3 G11 R+4 H+0 *\n",
        &m,
    );
    assert!(
        near(g.last().unwrap().end(), V3::new(10.0, 0.0, 9.0)),
        "{:?}",
        g.last().unwrap().end()
    );
    // the pole block ends the program
    let r = check(
        StrSource::new("N1 I+50 J+50 M30 *\nN2 G11 R+10 H+0 F100 *\n"),
        Dialect::Heidenhain,
        &m,
    );
    assert!(r.ok(), "{}", r.message());
    assert_eq!(r.moves, 0);
}
