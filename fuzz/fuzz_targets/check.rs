#![no_main]
//! Arbitrary bytes as a program through `check`: never panics, and the
//! report keeps at most `max_errors` errors.

use cnc_core::source::StrSource;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

/// Upper bound on lines read with G73 loops (see `common::loops_too_long`).
const LOOP_BUDGET: u64 = 200_000;

fuzz_target!(|data: &[u8]| {
    let Some((dialect, machine, text)) = common::split(data) else {
        return;
    };
    if common::loops_too_long(text, LOOP_BUDGET) {
        return;
    }
    let report = cnc_core::check(StrSource::from_bytes(text), dialect, machine);
    assert!(
        report.errors.len() <= machine.limits.max_errors,
        "{} errors kept, max_errors {}",
        report.errors.len(),
        machine.limits.max_errors
    );
    assert!(report.error_count >= report.errors.len());
    assert_eq!(report.ok(), report.errors.is_empty());
    // rendering the report must not panic either
    let _ = report.message();
});
