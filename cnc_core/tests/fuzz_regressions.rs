//! Inputs from fuzzing (`fuzz/`, cargo-fuzz targets `check` and `exec`)
//! and the properties those targets assert: no panic on any bytes, at most
//! `max_errors` errors kept, and for accepted short programs the executor's
//! last sample at exactly the check's tick count, every position finite.
//!
//! Input format (as in `fuzz/fuzz_targets/common.rs`): byte 0 bit 0 picks
//! the dialect (0 cnc836, 1 heidenhain), bit 1 the machine (0 mill,
//! 1 lathe); the rest is the program text.

use cnc_core::source::StrSource;
use cnc_core::{check, CheckReport, Dialect, Machine};

/// The fuzz targets' input decoding and properties, shared as they are.
#[path = "../../fuzz/fuzz_targets/common.rs"]
mod common;

/// Both fuzz targets' properties for one input; the check's report.
fn props(data: &[u8]) -> Option<CheckReport> {
    let (d, m, text) = common::split(data)?;
    let r = common::check_props(d, m, text);
    common::exec_props(d, m, text, &r, 20_000);
    Some(r)
}

/// Edge inputs the fuzzers' dictionary aims at: bytes that are no UTF-8,
/// NUL, numbers at and past the limits, leading zeros on G73, empty lines.
#[test]
fn edge_inputs_do_not_panic() {
    let inputs: &[&[u8]] = &[
        b"",
        b"0",
        b"1",
        b"0\n\n\n",
        b"0\xff\xfe\x00\n",
        b"0N10 G01 X\x8f\n",
        b"1N10 G00 X10 * ;\xc3\n",
        b"0G01 X99999999999999999999999 F1\n",
        b"0G01 X1e308 F1\n",
        b"0G01 X-0 Y-0. Z+0 F0.000000000000000000001\n",
        b"0N1 G00 X1\nN2 X2 G073 L1 Q3\n",
        b"0N1 G00 X1\nN2 X2 G+73 L+1 Q0003\n",
        b"0N1 G00 X1\nN2 X2 G73 L1 Q10000\n",
        b"0N1 G00 X1\nN2 X2 G73 L3 Q1\n",
        b"0N5 X0 Y0 Z0 G00\nN10 Z1.05 G10\nN50 G09 G02 X0 Y0 I100 G73 L50 Q0\nN70 G98\n",
        b"1N10 I+25 J+25 *\nN20 G11 R+20 H+0 F250 M3 *\nN30 G13 G91 H+5400 *\n",
        b"1N10 I+25 J+25 *\nN20 G11 R+20 H+0 F250 M3 *\nN30 G13 G91 H+0.000000001 *\n",
        b"1G15 H10 *\n",
        b"3G33 Z-40 F1 J3\n",
        b"2N10 M03 S200\nN20 G33 Z-43 F1 J3\nN30\nN40 X30 Z5\n",
        b"0G04 P99999999\n",
        b"0G04 P-1\n",
    ];
    for data in inputs {
        props(data);
    }
}

/// More errors than `max_errors`: the report keeps exactly `max_errors`
/// and counts the rest.
#[test]
fn errors_capped_at_max_errors() {
    let m = Machine::builtin_mill();
    let text = "W1\n".repeat(m.limits.max_errors + 5);
    let r = check(StrSource::new(&text), Dialect::Cnc836, &m);
    assert_eq!(r.errors.len(), m.limits.max_errors);
    assert_eq!(r.error_count, m.limits.max_errors + 5);
    assert!(
        r.message().ends_with("... and 5 more errors"),
        "{}",
        r.message()
    );
}

/// Replays every file of the fuzz corpora and artifacts, if present
/// (`cargo test -p cnc_core --test fuzz_regressions -- --ignored`).
#[test]
#[ignore = "replays the whole fuzz corpus (minutes in a debug build)"]
fn replay_fuzz_corpus() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let (mut n, mut ok) = (0, 0);
    for dir in [
        "corpus/check",
        "corpus/exec",
        "artifacts/check",
        "artifacts/exec",
    ] {
        let Ok(rd) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        for e in rd.flatten() {
            let data = std::fs::read(e.path()).unwrap();
            if data.len() > 4096 {
                continue;
            }
            if common::loops_too_long(&data[1.min(data.len())..], 20_000) {
                continue;
            }
            n += 1;
            if props(&data).is_some_and(|r| r.ok()) {
                ok += 1;
            }
        }
    }
    eprintln!("{n} inputs replayed, {ok} accepted by the check");
}

/// The structure-aware target's machines (`common::split_jerk`): the
/// selector byte's bits 2-4 set a jerk limit on every axis, bit 5 a
/// look-ahead of 4 blocks; runs on them end where the check said and keep
/// every axis's velocity, acceleration and jerk at every sample.
#[test]
fn jerk_selected_machines_keep_every_limit() {
    let mill = "G17 G90 G64 P0.001\nG00 X0 Y0 Z0\nF3000\nG01 X10\nY5\nG02 X20 Y5 I5 J0\nG01 X30 Y0\nG61 X40\nG00 Z20\n";
    let thread = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/lathe_thread.nc"),
    )
    .unwrap();
    // (selector, program, the jerk limit it must select, look-ahead)
    let cases: [(u8, &str, Option<f64>, usize); 5] = [
        (2 << 2, mill, Some(2.0e4), 200),
        (3 << 2 | 0x20, mill, Some(5.0e4), 4),
        (5 << 2, mill, Some(1.0e6), 200),
        (6 << 2 | 2, &thread, None, 200),
        (3 << 2 | 2, &thread, Some(5.0e4), 200),
    ];
    for (sel, text, jerk, look) in cases {
        let mut data = vec![sel];
        data.extend_from_slice(text.as_bytes());
        let (d, m, text) = common::split_jerk(&data).unwrap();
        assert_eq!(m.jerk_limit(), jerk, "selector {sel:#x}");
        assert_eq!(m.planner.lookahead_blocks, look, "selector {sel:#x}");
        let r = common::check_props(d, &m, text);
        assert!(r.ok(), "selector {sel:#x}: {}", r.message());
        let pos = common::exec_props(d, &m, text, &r, 100_000);
        assert_eq!(pos.len() as u64, r.ticks + 1, "selector {sel:#x}");
        assert_eq!(
            common::over_a_limit(&m, &pos, true),
            None,
            "selector {sel:#x}"
        );
    }
    // the bundled machines as they are (bits 2-4 = 0 or 1)
    let (_, m, _) = common::split_jerk(&[1 << 2 | 2]).unwrap();
    assert_eq!(m, Machine::builtin_lathe());
}

/// The limit check sees a sampled jerk over the limit (a step of
/// acceleration) and says which axis and sample.
#[test]
fn the_limit_check_finds_a_step_of_acceleration() {
    let m = Machine::builtin_mill();
    let j = m.axis(0).and_then(|a| a.max_jerk_mm_s3).unwrap();
    let dt = m.dt();
    // x = a/2·t² from sample 1 on: the sampled acceleration steps from 0
    // to a/2 to a, a jerk of a/(2·dt) = 2·j at sample 3
    let a = 4.0 * j * dt;
    let pos: Vec<[f64; 3]> = (0..6)
        .map(|k| {
            let t = (k as f64 - 1.0).max(0.0) * dt;
            [0.5 * a * t * t, 0.0, 0.0]
        })
        .collect();
    let what = common::over_a_limit(&m, &pos, true).unwrap();
    assert!(what.starts_with("j[0] = "), "{what}");
    assert!(what.ends_with(&format!("> {j} at sample 3")), "{what}");
}
