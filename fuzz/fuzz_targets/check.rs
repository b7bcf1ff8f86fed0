#![no_main]
//! Arbitrary bytes as a program through `check`: never panics, and the
//! report keeps at most `max_errors` errors.

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
    common::check_props(dialect, machine, text);
});
