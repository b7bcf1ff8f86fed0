//! Bad programs are refused with line, column, block number and a message
//! saying what was expected. All errors come in one report.

use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};

fn errors(text: &str, d: Dialect, m: &Machine) -> Vec<String> {
    let r = check(StrSource::new(text), d, m);
    assert_eq!(r.error_count, r.errors.len());
    r.errors.iter().map(|e| e.to_string()).collect()
}

fn mill_errors(text: &str) -> Vec<String> {
    errors(text, Dialect::Cnc836, &Machine::builtin_mill())
}

#[test]
fn unknown_word() {
    let e = mill_errors("N10 G00 X10\nN20 G01 X20 W5 F100\n");
    assert_eq!(
        e,
        vec!["line 2, column 13: block N20: unknown address 'W' in the cnc836 dialect: expected one of N G M X Y Z I J K F S T P L Q"]
    );
    let e = errors(
        "N10 G00 Y10 *\n",
        Dialect::Heidenhain,
        &Machine::builtin_lathe(),
    );
    assert_eq!(
        e,
        vec!["line 1, column 9: block N10: axis Y is not on this machine"]
    );
    let e = mill_errors("G07 X1\nM99\n");
    assert_eq!(
        e,
        vec![
            "line 1, column 1: unsupported G code G07 in the cnc836 dialect",
            "line 2, column 1: unsupported M code M99: expected M02, M03, M04, M05, M06, M08, M09 or M30"
        ]
    );
}

#[test]
fn arc_radius_mismatch_over_two_micrometres() {
    // start radius 10 about (20,10); end (20,20.0025) is 10.0025 away
    let e = mill_errors("N1 G00 X10 Y10\nN2 G02 X20 Y20.0025 I10 J0 F500\n");
    assert_eq!(
        e,
        vec!["line 2, column 4: block N2: arc radius mismatch: start radius 10 mm, end radius 10.0025 mm (difference 0.0025 mm, at most 0.002 mm)"]
    );
    // 0.0015 mm is accepted
    assert!(mill_errors("N1 G00 X10 Y10\nN2 G02 X20 Y20.0015 I10 J0 F500\n").is_empty());
}

#[test]
fn travel_limit_along_the_whole_path() {
    // both ends inside, but the CW half circle bulges to X -3
    let e = mill_errors("N1 G00 X2 Y250\nN2 G02 X2 Y260 I0 J5 F500\nN3 G01 X600\nN4 X1\n");
    assert_eq!(
        e,
        vec![
            "line 2, column 8: block N2: travel limit: the arc reaches X -3, outside the axis range 0..500",
            "line 3, column 8: block N3: travel limit: the move ends at X 600, outside the axis range 0..500",
        ]
    );
    // the CCW one bulges to +X and stays inside
    assert!(mill_errors("N1 G00 X2 Y250\nN2 G03 X2 Y260 I0 J5 F500\n").is_empty());
    // lathe: X limits are reported in diameter
    let e = errors(
        "N1 G00 X400 Z0\n",
        Dialect::Cnc836,
        &Machine::builtin_lathe(),
    );
    assert_eq!(
        e,
        vec!["line 1, column 8: block N1: travel limit: the move ends at X (diameter) 400, outside the axis range -10..300"]
    );
}

#[test]
fn missing_feed() {
    let e = mill_errors("N1 G00 X10\nN2 G01 X20\n");
    assert_eq!(
        e,
        vec!["line 2, column 4: block N2: missing feed: G01 needs a feed F (mm/min) greater than 0, programmed in this block or before"]
    );
    // F0 is no feed either; once F is set it is modal
    let e = mill_errors("G01 X1 F0\nG01 X2 F100\nX3\n");
    assert_eq!(e.len(), 1);
    assert!(
        e[0].starts_with("line 1, column 8: missing feed"),
        "points at F0: {e:?}"
    );
    // G95 needs a turning spindle
    let e = mill_errors("G95 G01 X1 F0.1\n");
    assert_eq!(
        e,
        vec!["line 1, column 5: G95 feed per revolution needs the spindle turning (M03/M04 with S greater than 0)"]
    );
    assert!(mill_errors("M03 S1000\nG95 G01 X1 F0.1\n").is_empty());
}

/// A feed so small that the move would take longer than the sample count
/// holds (F1e-16: the estimate once wrapped to 0.018 s while the run never
/// ended) is refused: the smallest feed is 0.001 mm/min, for G94's F,
/// G95's F times S and a thread's pitch times S.
#[test]
fn feed_under_the_smallest_is_refused() {
    assert_eq!(
        mill_errors("G01 X10 F0.0000000000000001\n"),
        vec!["line 1, column 9: feed F0.0000000000000001 mm/min is under the smallest feed, 0.001 mm/min"]
    );
    assert!(mill_errors("G01 X10 F0.001\n").is_empty());
    assert_eq!(
        mill_errors("M03 S0.0000001\nG95 G01 X10 F0.1\n"),
        vec!["line 2, column 13: feed F0.1 mm/rev at S0.0000001 is under the smallest feed, 0.001 mm/min"]
    );
    // (the feed is judged where it moves: F set under G95 is mm/min after G94)
    assert_eq!(
        mill_errors("M03 S1000\nG95 G01 X10 F0.0005\nG94 X20\n"),
        vec!["line 3, column 5: feed F0.0005 mm/min is under the smallest feed, 0.001 mm/min"]
    );
    let lathe = Machine::builtin_lathe();
    assert_eq!(
        errors(
            "G00 X20 Z5\nM03 S0.000001\nG33 Z-10 F0.000000001\n",
            Dialect::Cnc836,
            &lathe
        ),
        vec!["line 3, column 10: thread pitch F0.000000001 mm/rev at S0.000001 leads under the smallest feed, 0.001 mm/min"]
    );
}

#[test]
fn every_error_in_one_report() {
    let prog = "N10 G00 X10\nN20 G01 X20\nN30 X1 #\nN40 G02 X30 I0 J0 F10\nN50 G01 X9999\nN60 G01 G00 X1\n";
    let e = mill_errors(prog);
    let lines: Vec<&str> = e
        .iter()
        .map(|s| s.split(':').next().unwrap_or(""))
        .collect();
    assert_eq!(
        lines,
        vec![
            "line 2, column 5",
            "line 3, column 8",
            "line 4, column 13",
            "line 5, column 9",
            "line 6, column 9"
        ],
        "{e:#?}"
    );
    assert!(e[1].contains("unexpected character '#'"));
    assert!(e[2].contains("arc radius is zero"));
    assert!(e[4].contains("a motion G code (G00-G03) programmed twice"));
}

#[test]
fn dialect_syntax_is_not_guessed() {
    // a heidenhain comment in a cnc836 program is an error, and vice versa
    let e = mill_errors("G00 X1 ; comment\n");
    assert_eq!(e, vec!["line 1, column 8: unexpected character ';': expected an address letter and a number; comments in cnc836 start with '\"'"]);
    let e = errors(
        "G00 X1 \" comment\n",
        Dialect::Heidenhain,
        &Machine::builtin_mill(),
    );
    assert_eq!(e.len(), 1);
    assert!(
        e[0].starts_with("line 1, column 8: unexpected character '\"'"),
        "{e:?}"
    );
    assert!(errors(
        "N10 G00 X1 * ; ok\n",
        Dialect::Heidenhain,
        &Machine::builtin_mill()
    )
    .is_empty());
    assert!(mill_errors("N10 G00 X1 \" ok\n").is_empty());
}

#[test]
fn good_program_summary() {
    let r = check(
        StrSource::new("N1 G00 X100 Y100\nN2 G02 X100 Y100 I20 J0 F1200\nN3 M30\nN4 G01 X9999\n"),
        Dialect::Cnc836,
        &Machine::builtin_mill(),
    );
    assert!(r.ok(), "text after M30 is not executed: {}", r.message());
    assert_eq!((r.blocks, r.moves), (3, 2));
    let (lo, hi) = r.bbox.unwrap();
    assert_eq!((lo[0], lo[1]), (0.0, 0.0));
    assert!((hi[0] - 140.0).abs() < 1e-12 && (hi[1] - 120.0).abs() < 1e-12);
    // rapid 141.42 mm between stops: both axes at 250 mm/s, path
    // 353.55 mm/s, path acceleration 2000*sqrt(2) (the whole of it: no
    // kink): 0.4 + 0.125 s; circle 125.66 mm at 20 mm/s, whose centripetal
    // 20 mm/s² leaves √(1 − 0.01²)·2000 mm/s² along the path: 6.2832 +
    // 0.0100 s; each rounded up to ticks. The rapid, a line from rest to
    // rest, runs with a path filter of its own, ⌈a·max|u_i|/(j·dt)⌉ =
    // 2828.4 · 0.7071 / (200 · 1) = 10 samples, and no XYZ filter: it
    // waits a tick at its start and holds 10 ticks (its cruise, 0.34 s,
    // is far over the 12 ticks it must last). So does the circle, from
    // rest to rest too, with ⌈a/(0.5·j·dt)⌉ = 20 samples (its normal
    // acceleration starts and ends at 0; 3·v·a·κ + v³·κ² is far within
    // the other half of the jerk at 20 mm/s): 1 + 20 ticks instead of the
    // machine filters' hold of 44 (M_s − 1 + M_f − 1 = 39 + 5)
    assert_eq!(Machine::builtin_mill().jerk_budget().hold_ticks(), 44);
    assert!((r.duration_s - 6.851).abs() < 0.0005, "{}", r.duration_s);
}

/// A code written with a point is named as written (its point is why it
/// is not a whole number), and coolant and tool change are one meaning
/// each: once per block, like the spindle's M03-M05.
#[test]
fn codes_are_named_as_written_and_coolant_is_one_meaning() {
    let e = mill_errors("N10 G1. X1 F100\nN20 M3.\nN30 T1.\nN40 G1.5 X2\n");
    assert_eq!(
        e,
        vec![
            "line 1, column 5: block N10: G code must be a whole number, found G1.",
            "line 2, column 5: block N20: M code must be a whole number, found M3.",
            "line 3, column 5: block N30: tool T must be a whole number 0..9999, found T1.",
            "line 4, column 5: block N40: G code must be a whole number, found G1.5",
        ]
    );
    let e = mill_errors("N10 M08 M09\nN20 M06 M06\nN30 M03 M08 S100\n");
    assert_eq!(
        e,
        vec![
            "line 1, column 9: block N10: a coolant M code (M08/M09) programmed twice in one block",
            "line 2, column 9: block N20: a tool change (M06) programmed twice in one block",
        ]
    );
}
