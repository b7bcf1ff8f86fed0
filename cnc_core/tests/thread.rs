//! G33 thread cutting (`docs/dialects.md` §2.3): every block rule refused with its
//! line, the check-time run-in/deceleration fit, and, with the ideal
//! spindle (no encoder attached), exact geometry, chains in phase and the
//! estimate equal to the run.

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};

fn lathe() -> Machine {
    Machine::builtin_lathe()
}

fn errors_on(text: &str, m: &Machine) -> Vec<String> {
    let r = check(StrSource::new(text), Dialect::Cnc836, m);
    r.errors.iter().map(|e| e.to_string()).collect()
}

fn errors(text: &str) -> Vec<String> {
    errors_on(text, &lathe())
}

/// Exactly one error, at `line`, containing `what`.
#[track_caller]
fn refused(text: &str, line: u32, what: &str) {
    refused_on(text, &lathe(), line, what)
}

#[track_caller]
fn refused_on(text: &str, m: &Machine, line: u32, what: &str) {
    let e = errors_on(text, m);
    assert_eq!(e.len(), 1, "{e:#?}");
    assert!(
        e[0].starts_with(&format!("line {line}, ")) && e[0].contains(what),
        "{:?} (wanted line {line}: {what})",
        e[0]
    );
}

const PRE: &str = "N5 G00 X20 Z5\nN10 M03 S200\n";

#[test]
fn the_spec_examples_pass_the_check() {
    for p in [
        "N10 M03 S200\nN20 G33 Z-40 F1\n",
        "N10 M03 S200\nN20 G33 X12 Z-40 F2\n",
        "N10 M03 S200\nN20 G33 Z-43 F1 J3\nN30\nN40 X30 Z5\n",
    ] {
        assert_eq!(errors(&format!("N5 G00 X20 Z5\n{p}")), Vec::<String>::new());
    }
    let mill = Machine::builtin_mill();
    let p = "N5 G00 X50 Y40 Z10\nN10 M03 S200\nN20 G33 Y-30 F1.5 I180\n";
    assert_eq!(errors_on(p, &mill), Vec::<String>::new());
}

#[test]
fn every_block_rule_is_refused_with_its_line_and_column() {
    // pitch range and presence
    refused(
        &format!("{PRE}N20 G33 Z-40 F100\n"),
        3,
        "column 14: block N20: thread pitch F must be greater than 0 and at most 99.99 mm/rev, found F100",
    );
    refused(&format!("{PRE}N20 G33 Z-40 F0\n"), 3, "found F0");
    refused(
        &format!("{PRE}N20 G33 Z-40\n"),
        3,
        "column 5: block N20: G33 (thread) needs the pitch F in mm/rev",
    );
    // the spindle must turn
    refused(
        "N5 G00 X20 Z5\nN20 G33 Z-40 F1\n",
        2,
        "G33 (thread) needs the spindle turning: M03 or M04 with S greater than 0",
    );
    // end point
    refused(
        &format!("{PRE}N20 G33 F1\n"),
        3,
        "needs the thread's end point",
    );
    // start angle
    refused(
        &format!("{PRE}N20 G33 Z-40 F1 I360\n"),
        3,
        "start angle I must be at least 0 and less than 360 degrees, found I360",
    );
    refused(&format!("{PRE}N20 G33 Z-40 F1 I-5\n"), 3, "found I-5");
    refused(
        &format!("{PRE}N20 G33 Z-20 F1\nN30 G33 Z-40 I90\n"),
        4,
        "I (start angle) belongs to the first G33 block of a thread",
    );
    refused(
        &format!("{PRE}N20 G33 Z-20 F1\nN30 G33 Z-40 S300\n"),
        4,
        "S and M03/M04/M05 may only stand in the first G33 block",
    );
    // words that do not belong
    refused(
        &format!("{PRE}N20 G33 Z-40 F1 K2\n"),
        3,
        "K is not an address of G33",
    );
    refused(
        &format!("{PRE}N20 G01 G33 Z-40 F1\n"),
        3,
        "cannot share a block",
    );
    // runout
    refused(
        &format!("{PRE}N20 G33 Z-40 F1 J0\n"),
        3,
        "runout J must be greater than 0 mm, found J0",
    );
    refused(
        &format!("{PRE}N20 G33 Z-40 F1 J50\n"),
        3,
        "runout J50 is longer than the thread's Z travel of 45 mm",
    );
    refused(
        "N5 G00 X100 Z-10\nN10 M03 S200\nN20 G33 X40 F1 J3\n",
        3,
        "the runout axis X (machine constant 8) is this thread's lead axis",
    );
    refused_on(
        "N5 G00 X50 Y40 Z10\nN10 M03 S200\nN20 G33 Y-30 F1 J3\n",
        &Machine::builtin_mill(),
        3,
        "runout J needs machine constant 8",
    );
    refused(
        &format!("{PRE}N20 G33 Z-43 F1 J3\nN30 G00 X30\nN40 X30 Z5\n"),
        4,
        "the block after a G33 block with runout J must be an empty block",
    );
    refused(
        &format!("{PRE}N20 G33 Z-43 F1 J3\nN30\nN40 Z5\n"),
        5,
        "this block must program every axis (X Z): X missing",
    );
    // a comment-only line is an empty block too
    assert_eq!(
        errors(&format!(
            "{PRE}N20 G33 Z-43 F1 J3\n\" out of the thread\nN40 X30 Z5\n"
        )),
        Vec::<String>::new()
    );
    // chained blocks must continue smoothly
    refused(
        &format!("{PRE}N20 G33 Z-20 F1\nN30 G33 X40 Z-30\n"),
        4,
        "chained G33 blocks must continue the thread smoothly: axis X's speed would jump",
    );
    refused(
        &format!("{PRE}N20 G33 Z-20 F1\nN30 G33 Z-30 F2\n"),
        4,
        "axis Z's speed would jump by",
    );
    // and the dialect: HEIDENHAIN has no G33
    let e = {
        let r = check(
            StrSource::new("G33 Z-40 F1\n"),
            Dialect::Heidenhain,
            &Machine::builtin_mill(),
        );
        r.message()
    };
    assert!(
        e.contains("unsupported G code G33 in the heidenhain dialect"),
        "{e}"
    );
}

#[test]
fn speed_run_in_and_deceleration_that_do_not_fit_say_what_they_need() {
    // 5 mm/rev at 4000 rpm: 350 mm/s with the 5 % margin, Z allows 300
    refused(
        "N5 G00 X20 Z5\nN10 M03 S4000\nN20 G33 Z-40 F5\n",
        3,
        "G33 at S4000 with pitch F5: axis Z would move at 350 mm/s in the thread with the spindle 5 % over S (as the at-speed check allows), over its 300 mm/s; lower S to at most 3428",
    );
    // 4 mm/rev at 4000 rpm = 280 mm/s: the run-in at 80 % of 2500 mm/s²
    // and, since the tracker's noise on a 4 mm pitch at 4096 counts (342
    // m/s³) leaves nothing of 200 m/s³, at a quarter of it
    // (`shares::THREAD_JERK_FLOOR`), is an S-curve of 280/2000 +
    // 2000/50000 = 0.18 s, 280 · 0.18 / 2 = 25.2 mm of Z travel (21.35
    // mm at 80 % of the jerk)
    refused(
        "N5 G00 X20 Z5\nN10 M03 S4000\nN20 G33 Z-5 F4\n",
        3,
        "G33: the run-in needs 25.2 mm of Z travel at S4000 (pitch F4) to reach the thread's speed; the block has 10 mm: start the thread 15.2 mm earlier or lower S",
    );
    // without a jerk limit a parabola: 280²/(2·2000) = 19.6 mm
    let mut no_jerk = lathe();
    for a in &mut no_jerk.axes {
        a.max_jerk_mm_s3 = None;
    }
    refused_on(
        "N5 G00 X20 Z5\nN10 M03 S4000\nN20 G33 Z-5 F4\n",
        &no_jerk,
        3,
        "G33: the run-in needs 19.6 mm of Z travel at S4000 (pitch F4) to reach the thread's speed; the block has 10 mm: start the thread 9.6 mm earlier or lower S",
    );
    // a chain: the run-in fits in the first block, the deceleration must
    // fit in the last; the error names the last block
    refused(
        "N5 G00 X20 Z5\nN10 M03 S4000\nN20 G33 Z-30 F4\nN30 G33 Z-35\nN40 G00 X30\n",
        4,
        "G33: the thread's end needs 25.2 mm of Z travel at S4000 (pitch F4) to decelerate from the thread's speed; the block has 5 mm: make it 20.2 mm longer or lower S",
    );
    // a single block needs both
    refused(
        "N5 G00 X20 Z5\nN10 M03 S4000\nN20 G33 Z-30 F4\n",
        3,
        "to decelerate from the thread's speed, after 25.2 mm of run-in; the block has 35 mm: make it 15.4 mm longer",
    );
    // the runout's rounded kink needs room too
    refused(
        "N5 G00 X20 Z5\nN10 M03 S3000\nN20 G33 Z-200 F4 J0.5\nN30\nN40 X30 Z5\n",
        3,
        "runout J0.5 is too short to leave the thread at S3000",
    );
    // a runout as tiny as J0.000001 is named as written (it read "J0")
    refused(
        "N5 G00 X20 Z5\nN10 M03 S300\nN20 G33 Z-40 F1.5 J0.000001\nN30\nN40 X30 Z5\n",
        3,
        "runout J0.000001 is too short to leave the thread at S300",
    );
    // a runout as long as the whole travel leaves none for the run-in (it
    // read "the block has -0.0594 mm before the runout")
    refused(
        "N5 G00 X20 Z5\nN10 M03 S300\nN20 G33 Z-40 F1.5 J45\nN30\nN40 X30 Z5\n",
        3,
        "the block has 0 mm before the runout: start the thread 0.142 mm earlier or lower S",
    );
    // the same programs at a lower speed are fine
    assert!(errors("N5 G00 X20 Z5\nN10 M03 S500\nN20 G33 Z-5 F4\n").is_empty());
}

fn run(text: &str, m: &Machine) -> Vec<Sample> {
    let r = check(StrSource::new(text), Dialect::Cnc836, m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks, "estimate = run");
    s
}

#[test]
fn with_the_ideal_spindle_a_chain_stays_on_one_thread_line_and_the_estimate_is_exact() {
    let m = lathe();
    // two chained blocks (a straight thread, then a taper continuing it
    // with almost the same direction), then a second pass with I90
    let p = "N5 G00 X20 Z5\nN10 M03 S600\nN20 G33 Z-20 F1.5\nN30 G33 X20.02 Z-35\nN40 G00 X30\nN50 Z5\nN60 X20\nN70 G33 Z-20 F1.5 I90\nN80 G00 X30\n";
    let s = run(p, &m);
    let mut phases = Vec::new();
    for line in [3, 4, 8] {
        let on: Vec<_> = s
            .iter()
            .filter(|x| x.src.line == line && x.sync.is_some_and(|y| y.on_line))
            .collect();
        assert!(on.len() > 100, "line {line}");
        for x in &on {
            let y = x.sync.unwrap();
            // along the line: total lead travel from the chain's start
            let travel = 5.0 - x.pos[2];
            let ph = (travel / 1.5 - y.theta).rem_euclid(1.0) * 360.0;
            phases.push((line, ph));
        }
    }
    let p3 = phases.iter().find(|p| p.0 == 3).unwrap().1;
    for (line, ph) in &phases {
        let want = if *line == 8 { 360.0 - 90.0 } else { 0.0 };
        let d = (ph - want).rem_euclid(360.0);
        let d = d.min(360.0 - d);
        assert!(d < 1e-6, "line {line}: phase {ph} (first {p3})");
    }
    // no pause at the junction: the sample before N30's first is N20's
    let k = s.iter().position(|x| x.src.line == 4).unwrap();
    assert_eq!(s[k - 1].src.line, 3);
    assert!(s[k - 1].path_speed > 14.0 && s[k].path_speed > 14.0);
    // the chain ends exactly at its end point
    assert!(s.iter().any(|x| x.pos[2] == -35.0));
}

#[test]
fn after_a_spindle_reversal_a_thread_waits_for_the_next_index_only() {
    // with the ideal spindle (index pulses at whole revolutions) a pass
    // at M04, then M03 and a pass the other way round: counted in the new
    // direction the angle is below 0, and the thread used to wait for the
    // index at angle 0 (the estimate 4.3 s long per reversal), while the
    // run stopped at N70 with "the spindle encoder's last index pulse is
    // 16 revolutions ahead of its count"
    let m = lathe();
    let p = "N5 G00 X100 Z5\nN10 M04 S180\nN20 G33 Z-50 F9\nN30 G00 X120\nN40 Z5\nN50 X100\nN60 M03\nN70 G33 Z-50\nN80 G00 X120\n";
    let s = run(p, &m);
    // the second pass's run-in begins within a revolution (1/3 s at
    // S180) after the spindle command
    // (N60 is line 7, N70 line 8)
    let ready = s.iter().rposition(|x| x.src.line <= 7).unwrap();
    let moving = s
        .iter()
        .position(|x| x.src.line == 8 && x.pos[2] < 5.0)
        .unwrap();
    let wait = (moving - ready) as f64 * m.dt();
    assert!(wait < 1.0 / 3.0, "{wait} s");
    // (50 ms here; the whole run 5.779 s, 5.746 before the run-ins left
    // room for the tracker's noise)
    assert_eq!(s.len(), 5779 + 1);
    // and it reaches its end point
    assert!(s.iter().any(|x| x.src.line == 8 && x.pos[2] == -50.0));
}

#[test]
fn a_loop_of_thread_passes_checks_and_runs_as_estimated() {
    let m = lathe();
    // five passes of a G73 loop (G91 infeed from X22 each time)
    let p = "N5 G00 X22 Z5\nN10 M03 S800\nN20 G91 G00 X-0.2\nN30 G90 G33 Z-30 F1\nN40 G00 X30\nN50 Z5\nN60 X22\nN70 G73 L20 Q4\n";
    let s = run(p, &m);
    let passes = s
        .windows(2)
        .filter(|w| w[0].src.line != 4 && w[1].src.line == 4)
        .count();
    assert_eq!(passes, 5);
}

#[test]
fn the_encoder_timeout_is_a_machine_setting() {
    let text = include_str!("../../config/lathe.toml").replace(
        "encoder_counts_per_rev = 4096",
        "encoder_counts_per_rev = 4096\nencoder_timeout_ms = 0.5",
    );
    let e = Machine::from_toml(&text).unwrap_err();
    assert_eq!(
        e.0,
        "machine file: key `spindle.encoder_timeout_ms`: must be between 1 and 1000"
    );
    let ok = text.replace("encoder_timeout_ms = 0.5", "encoder_timeout_ms = 40");
    let m = Machine::from_toml(&ok).unwrap();
    assert_eq!(m.spindle.unwrap().encoder_timeout_ms, Some(40.0));
}
