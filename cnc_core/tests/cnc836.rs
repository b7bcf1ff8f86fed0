//! The cnc836 dialect (`docs/dialects.md` §2.1, §2.2): helix G09/G10/G98 and jumps
//! with repetition G73, with their block rules.

use cnc_core::canon::Event;
use cnc_core::exec::{Executor, Sample};
use cnc_core::interp::Interpreter;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};

const SEED: &str = include_str!("../../examples/cnc836_helix.nc");

fn mill() -> Machine {
    Machine::builtin_mill()
}

fn errors(text: &str) -> Vec<String> {
    let r = check(StrSource::new(text), Dialect::Cnc836, &mill());
    r.errors.iter().map(|e| e.to_string()).collect()
}

/// End points of every move the interpreter makes.
fn ends(text: &str, m: &Machine) -> Vec<V3> {
    Interpreter::new(StrSource::new(text), Dialect::Cnc836, m)
        .filter_map(|e| match e {
            Event::Move { geom, .. } => Some(geom.end()),
            _ => None,
        })
        .collect()
}

#[test]
fn the_seed_helix_runs_21_and_a_half_turns_to_z_22_575() {
    let m = mill();
    let r = check(StrSource::new(SEED), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(SEED), Dialect::Cnc836, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    // end of N60: (200, 0) and Z = 1.05 * 21.5
    let e = ends(SEED, &m);
    assert_eq!(e.len(), 23, "21 circles, a half circle, the last line");
    for (i, p) in e.iter().take(21).enumerate() {
        assert_eq!((p.x, p.y), (0.0, 0.0));
        assert!(
            (p.z - 1.05 * (i + 1) as f64).abs() < 1e-12,
            "turn {}: {}",
            i + 1,
            p.z
        );
    }
    assert_eq!((e[21].x, e[21].y), (200.0, 0.0));
    assert!((e[21].z - 22.575).abs() < 1e-9, "{}", e[21].z);
    assert_eq!(e[22], V3::new(10.0, 10.0, 30.0));
    // every sample of N50 and N60 on the helix: on the circle, and Z the
    // pitch times the turns made (clockwise from the start at angle pi).
    // The XYZ jerk filter (M = 6 samples; the path filter keeps the
    // samples on the helix) pulls a 50 mm/s arc of r = 100 inside by
    // v²(M²−1)dt²/(24 r) = 2500·35·1e-6/2400 mm = 36.5 nm, everywhere on
    // it: 37 nm allowed.
    assert_eq!(m.jerk_budget().m_f, 6);
    let mut unwrapped = std::f64::consts::PI;
    let mut prev = std::f64::consts::PI;
    let mut n = 0;
    for x in s.iter().filter(|x| x.src.line == 7 || x.src.line == 8) {
        let r = ((x.pos.x - 100.0).powi(2) + x.pos.y.powi(2)).sqrt();
        assert!(
            (r - 100.0).abs() < 3.7e-5,
            "off the circle by {}",
            r - 100.0
        );
        let a = x.pos.y.atan2(x.pos.x - 100.0);
        let mut d = a - prev;
        while d > std::f64::consts::PI {
            d -= std::f64::consts::TAU;
        }
        while d < -std::f64::consts::PI {
            d += std::f64::consts::TAU;
        }
        unwrapped += d;
        prev = a;
        let turns = (std::f64::consts::PI - unwrapped) / std::f64::consts::TAU;
        assert!(
            (x.pos.z - 1.05 * turns).abs() < 1e-5,
            "z {} at {turns} turns",
            x.pos.z
        );
        n += 1;
    }
    assert!(n > 200_000, "{n} samples");
    // F is the speed in the plane: 3000 mm/min = 50 mm/s on the circle
    let mid = s.iter().find(|x| x.src.line == 7 && x.t > 100.0).unwrap();
    let next = &s[mid.k as usize + 1];
    let plane =
        ((next.pos.x - mid.pos.x).powi(2) + (next.pos.y - mid.pos.y).powi(2)).sqrt() / m.dt();
    assert!((plane - 50.0).abs() < 1e-3, "{plane} mm/s in the plane");
}

#[test]
fn no_drift_after_9999_turns() {
    let mut m = mill();
    m.axes[2].max_mm = 20_000.0;
    let prog = "N1 G00 X100 Y100 Z0\nN2 F3000\nN3 Z1.05 G10\nN10 G09 G03 X100 Y100 I5 G73 L10 Q9998\nN20 G98\n";
    let e = ends(prog, &m);
    assert_eq!(e.len(), 1 + 9999);
    let want = 1.05 * 9999.0;
    assert!((e[9999].z - want).abs() < 1e-9, "{} vs {want}", e[9999].z);
    // and every turn ends on pitch x its count
    for (n, p) in e.iter().enumerate().skip(1) {
        assert!((p.z - 1.05 * n as f64).abs() < 1e-9, "turn {n}: {}", p.z);
    }
}

#[test]
fn helix_in_other_planes_and_negative_pitch() {
    let m = mill();
    // G18: Y is dragged; pitch -2 per turn: two CCW half circles = one turn
    let prog = "N1 G00 X100 Y50 Z0\nN2 F2000 G18\nN3 Y-2 G10\nN4 G09 G03 X100 Z20 K10\nN5 X100 Z0 K-10\nN6 G98\n";
    let e = ends(prog, &m);
    assert!(
        (e[1].y - 49.0).abs() < 1e-12 && (e[2].y - 48.0).abs() < 1e-12,
        "{e:?}"
    );
    // linear blocks in the plane do not move the dragged axis
    let prog =
        "N1 G00 X100 Y100 Z0\nN2 F2000\nN3 Z2 G10\nN4 G09 G01 X120\nN5 G02 X120 Y100 I10\nN6 G98\n";
    let e = ends(prog, &m);
    assert_eq!(e[1].z, 0.0);
    assert_eq!(e[2].z, 2.0);
}

#[test]
fn helix_rule_errors() {
    assert_eq!(
        errors("N1 G00 X100 Y100\nN2 G09 G02 X100 Y100 I5 F100\n"),
        ["line 2, column 4: block N2: G09 (helix on) needs a pitch programmed before it (a G10 block such as Z1.05 G10)"]
    );
    assert_eq!(
        errors("N1 X1 Z2 G10\n"),
        ["line 1, column 7: block N1: G10 (helix pitch) takes exactly one axis word, the dragged axis with its pitch; found 2"]
    );
    assert_eq!(
        errors("N1 G10\n"),
        ["line 1, column 4: block N1: G10 (helix pitch) takes exactly one axis word, the dragged axis with its pitch; found 0"]
    );
    assert_eq!(
        errors("N1 G17\nN2 X1 G10\n"),
        ["line 2, column 4: block N2: the dragged axis X is an axis of the G17 plane; the helix drags the third axis"]
    );
    assert_eq!(
        errors("N1 Z1 G10 F100\n"),
        ["line 1, column 11: block N1: a G10 block (helix pitch) holds only the pitch: one axis word, e.g. Z1.05 G10"]
    );
    assert_eq!(
        errors("N1 Z1 G10\nN2 G09\nN3 G98 X5 \" comment\n"),
        ["line 3, column 8: block N3: G98 (helix off) must stand alone in its block (an N number and a comment are allowed)"]
    );
    assert!(errors("N1 Z1 G10\nN2 G09\nN3 G98 \" fine\n").is_empty());
    assert_eq!(
        errors("N1 G00 X100 Y100\nN2 Z1 G10\nN3 G09 G02 X100 Y100 Z5 I5 F100\n"),
        ["line 3, column 22: block N3: axis Z is dragged by the helix (G09): it cannot be programmed until G98"]
    );
    // after G98 Z is free again
    assert!(errors(
        "N1 G00 X100 Y100\nN2 Z1 G10\nN3 G09 G02 X100 Y100 I5 F100\nN4 G98\nN5 G01 Z5\n"
    )
    .is_empty());
}

#[test]
fn loops_run_q_plus_one_times_nest_and_reset() {
    let m = mill();
    // inner loop (N20, twice) inside the outer (N10..N30, three times)
    let prog =
        "N1 G00 X0 Y0\nN2 F1000 G91\nN10 G01 X1\nN20 X1 G73 L20 Q1\nN30 Y1 G73 L10 Q2\nM30\n";
    let e = ends(prog, &m);
    assert_eq!(e.len(), 12, "3 x (N10 + 2 x N20 + N30)");
    assert_eq!(*e.last().unwrap(), V3::new(9.0, 3.0, 0.0));
    // Q0 runs once; an empty block and a comment-only line are fine targets
    let prog = "N1 G00 X0 Y0\nN2 F1000 G91\nN5\n\" a comment\nN10 X1 G73 L5 Q0\n";
    assert_eq!(ends(prog, &m).last().copied(), Some(V3::new(1.0, 0.0, 0.0)));
    let prog = "N1 G00 X0 Y0\nN2 F1000 G91\nN5\nN10 X1 G73 L5 Q9\n";
    assert_eq!(
        ends(prog, &m).last().copied(),
        Some(V3::new(10.0, 0.0, 0.0))
    );
    // the check runs the loops: the estimate equals the executed time
    let r = check(StrSource::new(prog), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    assert_eq!(r.moves, 10);
    assert_eq!(r.blocks, 4, "blocks are counted once, not per run");
    let s: Vec<Sample> = Executor::new(StrSource::new(prog), Dialect::Cnc836, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    assert_eq!(s.last().unwrap().pos, V3::new(10.0, 0.0, 0.0));
}

#[test]
fn a_jump_in_a_long_program_is_checked_like_on_one_thread() {
    // more than 512 moves first: the check runs as a pipeline, meets the
    // jump, and runs again on one thread
    let m = mill();
    let mut prog = String::from("N1 G00 X100 Y100\nN2 F6000 G91\n");
    for k in 0..700 {
        prog += &format!("N{} X{}\n", 10 + k, if k % 2 == 0 { 1 } else { -1 });
    }
    prog += "N5000 Y0.5\nN5001 Y-0.5 G73 L5000 Q49\n";
    let r = check(StrSource::new(&prog), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    assert_eq!(r.moves, 1 + 700 + 100);
    let s: Vec<Sample> = Executor::new(StrSource::new(&prog), Dialect::Cnc836, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    // a reader-backed source (a file) as well
    let r2 = check(
        cnc_core::source::ReaderSource::new(std::io::Cursor::new(prog.as_bytes()), 4096),
        Dialect::Cnc836,
        &m,
    );
    assert_eq!(r2, r);
}

#[test]
fn loop_rule_errors() {
    assert_eq!(
        errors("N10 G00 X1\nN20 G73 L30 Q1\nN30 X2\n"),
        ["line 2, column 9: block N20: jump target N30 is not a block at or before this one (G73 jumps back only)"]
    );
    assert_eq!(
        errors("N10 G00 X1\nN20 G73 L99 Q1\n"),
        ["line 2, column 9: block N20: jump target N99 is not a block at or before this one (G73 jumps back only)"]
    );
    assert_eq!(
        errors("N10 G00 X1 G73 L10 Q10000\n"),
        ["line 1, column 20: block N10: Q must be a whole number 0..9999, found Q10000"]
    );
    assert_eq!(
        errors("N10 G00 X1 G73 L10 Q2.5\n"),
        ["line 1, column 20: block N10: Q must be a whole number 0..9999, found Q2.5"]
    );
    assert_eq!(
        errors("N10 G00 X1 G73 Q2\n"),
        ["line 1, column 12: block N10: G73 needs the target block L<n> (and the repeat count Q)"]
    );
    assert_eq!(
        errors("N10 G00 X1 L10\n"),
        ["line 1, column 12: block N10: address L is only used with G73 (jump)"]
    );
    // an error inside a loop is reported once, not per run
    let e = errors("N1 G00 X1 F100\nN10 G01 X2 R5 G73 L10 Q3\n");
    assert_eq!(e.len(), 1, "{e:?}");
    // the words belong to cnc836 only
    let r = check(
        StrSource::new("N10 G00 X1 G73 L10 Q2\n"),
        Dialect::Heidenhain,
        &mill(),
    );
    assert_eq!(
        r.errors[0].to_string(),
        "line 1, column 12: block N10: unsupported G code G73 in the heidenhain dialect"
    );
}

/// Two nested loops: N20..N30 runs 100 times (2 blocks a pass) inside
/// N20..N40, which runs 10 times (201 blocks a pass): N10, 10 × 201, and
/// N50 execute 2012 blocks.
const NESTED: &str = "N10 G00 X1 Y1 Z0
N20 G91 G01 X0.5 F1000
N30 X-0.5 G73 L20 Q99
N40 G73 L20 Q9
N50 G90 M30
";

fn mill_with_max_blocks(n: u64) -> Machine {
    let mut m = mill();
    m.limits.max_executed_blocks = n;
    m
}

#[test]
fn executed_blocks_are_bounded_by_the_machine_file() {
    let check_with = |n: u64| {
        check(
            StrSource::new(NESTED),
            Dialect::Cnc836,
            &mill_with_max_blocks(n),
        )
    };
    // the loops end after 2011 blocks (N50 needs no jump)
    let r = check_with(2011);
    assert!(r.ok(), "{}", r.message());
    assert_eq!(r.moves, 2001);
    // one block less: the check adds the loops up before their first jump
    // (N10 + 10 × (N20 + 100 × 2)) and refuses at the outermost G73,
    // before any motion
    let r = check_with(2010);
    assert_eq!(r.error_count, 1, "{}", r.message());
    assert_eq!(
        r.errors[0].to_string(),
        "line 4, column 5: block N40: with its loops the program would run 2011 blocks or more, over the machine's limit of 2010 (limits.max_executed_blocks; loops are executed, not expanded: fewer repetitions, or fewer nested loops)"
    );
    // the inner loop alone is over 200: still named at the outermost loop
    // around it (what it adds up to when it passes the limit)
    let r = check_with(200);
    assert_eq!(r.error_count, 1, "{}", r.message());
    assert_eq!(
        r.errors[0].to_string(),
        "line 4, column 5: block N40: with its loops the program would run 2002 blocks or more, over the machine's limit of 200 (limits.max_executed_blocks; loops are executed, not expanded: fewer repetitions, or fewer nested loops)"
    );
    // an executor (which does not add up first) stops at the inner loop's
    // second pass, when it knows a pass: nothing runs past the limit
    let m = mill_with_max_blocks(200);
    let s: Vec<Sample> = Executor::new(StrSource::new(NESTED), Dialect::Cnc836, &m).collect();
    assert!(s.len() < 1000, "{} samples", s.len());
    let r = check_with(2);
    assert_eq!(
        r.errors[0].to_string(),
        "line 4, column 5: block N40: with its loops the program would run 2002 blocks or more, over the machine's limit of 2 (limits.max_executed_blocks; loops are executed, not expanded: fewer repetitions, or fewer nested loops)"
    );
}

#[test]
fn loops_that_would_never_end_in_practice_are_refused_in_bounded_time() {
    // 10^4 × 10^4 × 10^4 × 2 blocks (2e12): the check adds the loops up
    // before the first jump and refuses at the outermost G73
    let text = "N10 G00 X1 Y1 Z0
N20 G91 G01 X0.001 F1000
N30 X-0.001 G73 L20 Q9999
N40 G73 L20 Q9999
N50 G73 L20 Q9999
N60 G90 M30
";
    let r = check(
        StrSource::new(text),
        Dialect::Cnc836,
        &mill_with_max_blocks(1_000_000),
    );
    assert_eq!(r.error_count, 1, "{}", r.message());
    assert!(
        r.errors[0].to_string().starts_with(
            "line 5, column 5: block N50: with its loops the program would run 2000000000003 blocks or more, over the machine's limit of 1000000 (limits.max_executed_blocks"
        ),
        "{}",
        r.errors[0]
    );
    assert_eq!(mill().limits.max_executed_blocks, 1_000_000_000);
    let e = Machine::from_toml(&include_str!("../../config/mill.toml").replace(
        "max_executed_blocks = 1000000000",
        "max_executed_blocks = 0",
    ))
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("key `limits.max_executed_blocks`: must be at least 1"),
        "{e}"
    );
}

#[test]
fn loops_that_would_run_too_many_blocks_are_refused_before_they_run() {
    let max = mill().limits.max_executed_blocks;
    // three loops of Q9999 nested: 10^12 runs of N30, refused at once (a
    // check that ran them would take years), at the outermost G73
    let prog = "N1 G00 X100 Y100\nN2 F60000 G91\nN10 G01 X0.5\nN20 X0.5\nN30 X0.5\n\
                N31 X-0.5 G73 L30 Q9999\nN32 X-0.5 G73 L20 Q9999\nN33 X-0.5 G73 L10 Q9999\n";
    let t = std::time::Instant::now();
    let e = errors(prog);
    assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        e[0].starts_with("line 8, column 11: block N33: with its loops the program would run ")
            && e[0].contains(&format!(
                "blocks or more, over the machine's limit of {max} (limits.max_executed_blocks"
            )),
        "{}",
        e[0]
    );
    // 40 loops of Q1 nested: 2^40 runs of the innermost block
    let mut deep = String::from("N1 G00 X100 Y100\nN2 F60000 G91\n");
    for i in 0..40 {
        deep += &format!("N{} G01 X0.5\n", 10 + i);
    }
    for i in (0..40).rev() {
        deep += &format!("N{} X-0.5 G73 L{} Q1\n", 100 + i, 10 + i);
    }
    let e = errors(&deep);
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        e[0].starts_with("line 82, column 12: block N100: with its loops"),
        "{}",
        e[0]
    );
    // loops in sequence add up, they do not multiply: accepted and run
    let prog = "N1 G00 X100 Y100\nN2 F60000 G91\nN10 G01 X0.5\nN11 X-0.5 G73 L10 Q999\n\
                N20 X0.5\nN21 X-0.5 G73 L20 Q999\n";
    let r = check(StrSource::new(prog), Dialect::Cnc836, &mill());
    assert!(r.ok(), "{}", r.message());
    assert_eq!(r.moves, 1 + 4000);
}

/// A new S while the spindle turns changes the commanded speed (alone or
/// with M03): before, the command was compared after S was applied, so a
/// new speed with the spindle already on was never commanded.
#[test]
fn a_new_speed_while_the_spindle_turns_is_commanded() {
    let m = mill();
    let text = "N10 G90 M03 S1200\nN20 G01 X10 F600\nN30 S800\nN40 G01 X20\nN50 M03 S500\nN60 G01 X30\nN70 M30\n";
    let r = check(StrSource::new(text), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, &m).collect();
    let rpm_at = |line: u32| s.iter().find(|x| x.src.line == line).map(|x| x.spindle_rpm);
    assert_eq!(rpm_at(2), Some(1200.0));
    assert_eq!(rpm_at(4), Some(800.0));
    assert_eq!(rpm_at(6), Some(500.0));
    let spindle: Vec<f64> = Interpreter::new(StrSource::new(text), Dialect::Cnc836, &m)
        .filter_map(|e| match e {
            Event::Spindle { rpm, .. } => Some(rpm),
            _ => None,
        })
        .collect();
    assert_eq!(spindle, vec![1200.0, 800.0, 500.0]);
}
