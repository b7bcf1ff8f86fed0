#![no_main]
//! Programs the check accepts (and that are short) run through the
//! executor to the end: no panic, the last sample is at `report.ticks`,
//! every position finite.

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
    let report = common::check_props(dialect, machine, text);
    common::exec_props(dialect, machine, text, &report, MAX_TICKS);
});
