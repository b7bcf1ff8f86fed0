//! What the property tests of `props.rs` and `wild.rs` share: the number
//! of cases, the programs' rounding, a heading's turn, a feed hold or
//! override for a while, and a run under it.
#![allow(dead_code)]

use cnc_core::exec::{Executor, Sample};
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine};
use proptest::prelude::*;

/// Cases to run: `default`, or `PROPTEST_CASES` from the environment (for
/// long runs: `PROPTEST_CASES=3000 cargo test --release --test props`).
pub fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A programmed coordinate: rounded to 0.1 µm.
pub fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Turns the heading `d` by `a` rad in the plane of its components `i`
/// and `j` (from `i` towards `j`).
pub fn turn_in(d: &mut [f64], i: usize, j: usize, a: f64) {
    let (c, sn) = (a.cos(), a.sin());
    let (x, y) = (d[i], d[j]);
    d[i] = x * c - y * sn;
    d[j] = x * sn + y * c;
}

/// A feed hold or override for a while (from sample, for samples, to
/// level), or none.
pub fn hold() -> impl Strategy<Value = Option<(usize, usize, f64)>> {
    prop::option::of((
        10usize..3000,
        1usize..3000,
        prop_oneof![Just(0.0), 0.05..1.0f64, 1.0..2.0f64, Just(2.0)],
    ))
}

/// The samples of `text` (cnc836) on `m` with `hold` (a feed hold or an
/// override for a while, as the executor's live feed target); a run of
/// more than twice the check's `ticks` and 10,000 fails (a run that never
/// ends fails here instead of filling memory).
pub fn samples_with_hold(
    m: &Machine,
    text: &str,
    ticks: u64,
    hold: Option<(usize, usize, f64)>,
) -> Result<Vec<Sample>, TestCaseError> {
    let mut ex = Executor::new(StrSource::new(text), Dialect::Cnc836, m);
    let mut s: Vec<Sample> = Vec::new();
    while let Some(x) = ex.next_sample() {
        if let Some((at, len, level)) = hold {
            if s.len() == at {
                ex.set_feed_target(level);
            } else if s.len() == at + len {
                ex.set_feed_target(1.0);
            }
        }
        s.push(x);
        prop_assert!(
            s.len() as u64 <= 2 * ticks + 10_000,
            "no end after {} samples\n{}",
            s.len(),
            text
        );
    }
    Ok(s)
}
