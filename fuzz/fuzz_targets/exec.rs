#![no_main]
//! Programs the check accepts (and that are short) run through the
//! executor to the end: no panic, the last sample is at `report.ticks`,
//! every position finite.

use cnc_core::exec::Executor;
use cnc_core::source::StrSource;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

/// Longest estimated run executed, ticks.
const MAX_TICKS: u64 = 20_000;

/// Upper bound on lines read with G73 loops (see `common::loops_too_long`).
const LOOP_BUDGET: u64 = 200_000;

fuzz_target!(|data: &[u8]| {
    let Some((dialect, machine, text)) = common::split(data) else {
        return;
    };
    // nested G73 loops are legitimately slow (Q9999 * Q9999): not a hang
    if common::g73_count(text) > 1 || common::loops_too_long(text, LOOP_BUDGET) {
        return;
    }
    let report = cnc_core::check(StrSource::from_bytes(text), dialect, machine);
    assert!(report.errors.len() <= machine.limits.max_errors);
    if !report.ok() || report.ticks > MAX_TICKS {
        return;
    }
    let mut last = None;
    let mut n: u64 = 0;
    for s in Executor::new(StrSource::from_bytes(text), dialect, machine) {
        assert_eq!(s.k, n, "sample index");
        assert!(
            s.pos.iter().all(|c| c.is_finite()),
            "non-finite position {:?} at k={}",
            s.pos,
            s.k
        );
        assert!(s.t.is_finite());
        n += 1;
        // far beyond the estimate: the executor disagrees with the check
        assert!(
            s.k <= report.ticks + 1,
            "executor passed the estimate: k={} ticks={}",
            s.k,
            report.ticks
        );
        last = Some(s);
    }
    let last = last.expect("the executor yields at least the last sample");
    assert!(last.last);
    assert_eq!(
        last.k, report.ticks,
        "check estimated {} ticks, executor ended at {}",
        report.ticks, last.k
    );
});
