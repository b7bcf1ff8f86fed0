#![no_main]
//! Structure-aware variant of `exec`: the bytes choose well-formed words
//! (letters valid in the dialect, small values), so far more programs pass
//! the check and reach the executor than from raw bytes. Same properties
//! as `exec`, on the bundled machines at jerk limits from 20 to 1000 m/s³
//! (or none) and look-aheads of 4 and 200 blocks, and every sample's
//! velocity, acceleration and jerk within the machine's limits.

use libfuzzer_sys::fuzz_target;
use std::fmt::Write;

#[path = "common.rs"]
mod common;

const MAX_TICKS: u64 = 20_000;
const LOOP_BUDGET: u64 = 200_000;

const CNC836: &[&str] = &[
    "G00", "G01", "G02", "G03", "G04", "G09", "G10", "G17", "G18", "G19", "G73", "G90", "G91",
    "G94", "G95", "G98", "G33", "G40", "G41", "G42", "G61", "G64", "X", "Y", "Z", "I", "J", "K", "F", "S", "T", "P", "L", "Q", "M03", "M04",
    "M05", "M30", "X-", "Y-", "Z-", "I-", "J-", "K-",
];
const HEIDENHAIN: &[&str] = &[
    "G00", "G01", "G02", "G03", "G10", "G11", "G12", "G13", "G15", "G29", "G17", "G18", "G19",
    "G90", "G91", "G94", "G95", "G04", "G40", "G41", "G42", "G61", "G64", "X", "Y", "Z", "I", "J", "K", "R", "H", "F", "S", "T", "P",
    "M3", "M5", "M30", "X-", "Y-", "Z-", "I-", "J-", "H-", "R-",
];

fn program(d: cnc_core::Dialect, data: &[u8]) -> String {
    let words = if d == cnc_core::Dialect::Cnc836 {
        CNC836
    } else {
        HEIDENHAIN
    };
    let heid = d == cnc_core::Dialect::Heidenhain;
    let mut s = String::new();
    let mut line = 1;
    let _ = write!(s, "N{} ", line * 10);
    let mut it = data.iter();
    while let Some(&b) = it.next() {
        if b % 6 == 0 {
            if heid {
                s.push_str(" *");
            }
            line += 1;
            let _ = write!(s, "\nN{} ", line * 10);
            continue;
        }
        let w = words[(b as usize / 6) % words.len()];
        s.push_str(w);
        if !w.starts_with('G') && !w.starts_with('M') {
            let v = it.next().copied().unwrap_or(0);
            let frac = it.next().copied().unwrap_or(0);
            match w.as_bytes()[0] {
                // block numbers and counts: whole and small
                b'L' => {
                    let _ = write!(s, "{}", (v as u32 % line.max(1) + 1) * 10);
                }
                b'Q' | b'T' => {
                    let _ = write!(s, "{}", v % 4);
                }
                b'S' => {
                    let _ = write!(s, "{}", v as u32 * 20);
                }
                _ if frac % 4 == 0 => {
                    let _ = write!(s, "{v}");
                }
                _ => {
                    let _ = write!(s, "{v}.{}", frac % 100);
                }
            }
        }
        s.push(' ');
    }
    if heid {
        s.push_str(" *");
    }
    s.push('\n');
    s
}

fuzz_target!(|data: &[u8]| {
    let Some((dialect, machine, rest)) = common::split_jerk(data) else {
        return;
    };
    if rest.len() > 512 {
        return;
    }
    let text = program(dialect, rest);
    let text = text.as_bytes();
    if common::g73_count(text) > 1 || common::loops_too_long(text, LOOP_BUDGET) {
        return;
    }
    let report = common::check_props(dialect, &machine, text);
    let pos = common::exec_props(dialect, &machine, text, &report, MAX_TICKS);
    if let Some(what) = common::over_a_limit(&machine, &pos, true) {
        panic!("{what}");
    }
});
