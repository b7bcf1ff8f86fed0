//! Shared input decoding: the first byte picks dialect and machine, the
//! rest is the program text.
//!
//! byte 0, bit 0: 0 = cnc836, 1 = heidenhain
//! byte 0, bit 1: 0 = builtin mill, 1 = builtin lathe
//! (ASCII '0'..'3' are the four combinations, handy for hand-written seeds.)

// included by each target and by cnc_core/tests/fuzz_regressions.rs;
// not every includer uses every helper
#![allow(dead_code)]

use cnc_core::{Dialect, Machine};
use std::sync::OnceLock;

static MILL: OnceLock<Machine> = OnceLock::new();
static LATHE: OnceLock<Machine> = OnceLock::new();
/// The bundled machines at other jerk limits: `JERKS`, mill then lathe.
static AT_JERK: OnceLock<Vec<Machine>> = OnceLock::new();

/// Jerk limits (mm/s³) that [`split_jerk`] sets on every axis of a
/// bundled machine: the realistic range and the bundled machines' 200
/// m/s³ below the single-average design's threshold, and 1000 m/s³ above
/// it; `None` leaves the axes acceleration-limited only.
const JERKS: [Option<f64>; 6] = [
    Some(2.0e4),
    Some(5.0e4),
    Some(1.0e5),
    Some(1.0e6),
    None,
    Some(3.3e4),
];

pub fn split(data: &[u8]) -> Option<(Dialect, &'static Machine, &[u8])> {
    let (&sel, text) = data.split_first()?;
    let dialect = if sel & 1 == 0 {
        Dialect::Cnc836
    } else {
        Dialect::Heidenhain
    };
    let machine = if sel & 2 == 0 {
        MILL.get_or_init(Machine::builtin_mill)
    } else {
        LATHE.get_or_init(Machine::builtin_lathe)
    };
    Some((dialect, machine, text))
}

/// As [`split`], and byte 0 also picks the machine's jerk and look-ahead:
///
/// byte 0, bits 2-4: 0-1 the bundled machine as it is (200 m/s³), 2-7 one
/// of `JERKS` set on every axis
/// byte 0, bit 5: 1 = a look-ahead of 4 blocks (the queue commits moves
/// before it knows what comes within the filters' reach)
pub fn split_jerk(data: &[u8]) -> Option<(Dialect, Machine, &[u8])> {
    let (dialect, machine, text) = split(data)?;
    let sel = data[0];
    let pick = usize::from((sel >> 2) & 7);
    let mut m = if pick < 2 {
        machine.clone()
    } else {
        let all = AT_JERK.get_or_init(|| {
            let mut v = Vec::new();
            for base in [Machine::builtin_mill(), Machine::builtin_lathe()] {
                for j in JERKS {
                    let mut m = base.clone();
                    for a in &mut m.axes {
                        a.max_jerk_mm_s3 = j;
                    }
                    // (the filters at every jerk, as before "auto")
                    m.planner.method = cnc_core::machine::PlanMethod::Filters;
                    v.push(m);
                }
            }
            v
        });
        let lathe = usize::from(sel & 2 != 0);
        all[lathe * JERKS.len() + pick - 2].clone()
    };
    if sel & 0x20 != 0 {
        m.planner.lookahead_blocks = 4;
    }
    Some((dialect, m, text))
}

/// The first sample at which an axis's velocity, acceleration or (with
/// `jerk`) jerk (first, second and third differences of the positions at
/// the sample rate) exceeds the machine's limit, as text.
pub fn over_a_limit(m: &Machine, pos: &[[f64; 3]], jerk: bool) -> Option<String> {
    let dt = m.dt();
    let (vmax, amax) = (m.vmax(), m.amax());
    let diff = |x: &[[f64; 3]]| -> Vec<[f64; 3]> {
        x.windows(2)
            .map(|w| std::array::from_fn(|i| (w[1][i] - w[0][i]) / dt))
            .collect()
    };
    let vel = diff(pos);
    let acc = diff(&vel);
    let jk = diff(&acc);
    for i in 0..3 {
        if let Some(k) = vel.iter().position(|v| v[i].abs() > vmax[i] * (1.0 + 1e-9)) {
            return Some(format!("v[{i}] = {} at sample {}", vel[k][i], k + 1));
        }
        let over = |a: &[f64; 3]| a[i].abs() > amax[i] * (1.0 + 1e-6) + 1e-6;
        if let Some(k) = acc.iter().position(over) {
            return Some(format!("a[{i}] = {} at sample {}", acc[k][i], k + 2));
        }
        let Some(j) = m.axis(i).and_then(|a| a.max_jerk_mm_s3).filter(|_| jerk) else {
            continue;
        };
        if let Some(k) = jk.iter().position(|x| x[i].abs() > j * (1.0 + 1e-6) + 1e-3) {
            return Some(format!("j[{i}] = {} > {j} at sample {}", jk[k][i], k + 3));
        }
    }
    None
}

/// The whole numbers written after `letter` (either case, optional sign,
/// leading zeros allowed, so `G073` and `g+73` count as 73); `None` for a
/// number too long to matter (it is refused by the parser anyway).
fn numbers_after(text: &[u8], letter: u8) -> impl Iterator<Item = Option<u64>> + '_ {
    (0..text.len())
        .filter(move |&i| text[i].eq_ignore_ascii_case(&letter))
        .map(move |i| {
            let mut j = i + 1;
            if j < text.len() && text[j] == b'+' {
                j += 1;
            }
            let start = j;
            while j < text.len() && text[j].is_ascii_digit() {
                j += 1;
            }
            std::str::from_utf8(&text[start..j])
                .ok()?
                .parse::<u64>()
                .ok()
        })
}

/// How many G73 words the text may hold.
pub fn g73_count(text: &[u8]) -> usize {
    numbers_after(text, b'G').filter(|&n| n == Some(73)).count()
}

/// Nested G73 loops with large Q counts are legitimately slow (9999 x 9999
/// passes run, never expanded): not a hang. An upper bound on the lines
/// the interpreter may read, lines x product of (Q + 1) over every Q word
/// when there is a G73 at all; inputs above `budget` are skipped.
pub fn loops_too_long(text: &[u8], budget: u64) -> bool {
    if g73_count(text) == 0 {
        return false;
    }
    let lines = text.iter().filter(|&&b| b == b'\n').count() as u64 + 1;
    let mut work = lines;
    for q in numbers_after(text, b'Q') {
        // a Q that is no whole number is an error: no loop
        let q = q.unwrap_or(0);
        work = work.saturating_mul(q.saturating_add(1));
        if work > budget {
            return true;
        }
    }
    false
}

/// The check's properties for any input: at most `max_errors` errors kept,
/// no fewer counted, `ok` exactly when none, the report renders.
pub fn check_props(dialect: Dialect, machine: &Machine, text: &[u8]) -> cnc_core::CheckReport {
    use cnc_core::source::StrSource;
    let report = cnc_core::check(StrSource::from_bytes(text), dialect, machine);
    assert!(
        report.errors.len() <= machine.limits.max_errors,
        "{} errors kept, max_errors {}",
        report.errors.len(),
        machine.limits.max_errors
    );
    assert!(report.error_count >= report.errors.len());
    assert_eq!(report.ok(), report.errors.is_empty());
    let _ = report.message();
    report
}

/// For an accepted program of at most `max_ticks` estimated ticks: the
/// executor runs it to the end without panic, samples numbered 0, 1, ...,
/// every position finite, the last sample exactly at the check's tick.
pub fn exec_props(
    dialect: Dialect,
    machine: &Machine,
    text: &[u8],
    report: &cnc_core::CheckReport,
    max_ticks: u64,
) -> Vec<[f64; 3]> {
    use cnc_core::exec::Executor;
    use cnc_core::source::StrSource;
    let mut pos = Vec::new();
    if !report.ok() || report.ticks > max_ticks {
        return pos;
    }
    let mut last = None;
    for (i, s) in Executor::new(StrSource::from_bytes(text), dialect, machine).enumerate() {
        assert_eq!(s.k, i as u64, "sample index");
        assert!(
            s.pos.iter().all(|c| c.is_finite()),
            "non-finite position {:?} at k={}",
            s.pos,
            s.k
        );
        assert!(s.t.is_finite());
        pos.push([s.pos.x, s.pos.y, s.pos.z]);
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
    pos
}
