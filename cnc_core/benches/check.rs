//! `cnc_core::check` on a 100,000-block program, held in memory.
//!
//! The program is made like `bench/gen_program.py` makes it: small G01
//! moves and G02/G03 arcs near X100 Y100, roughly a third of each, all
//! geometry in whole units of 0.0001 mm. Arc end points are the start
//! rotated about the centre by an exactly rational rotation and rounded to
//! 4 decimals, and kept only if they lie on the circle within 0.0001 mm. The
//! feed is set before the first move. The generator is deterministic.
//!
//! Run: `cargo bench -p cnc_core --bench check`

use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::fmt::Write;
use std::time::Duration;

/// Motion blocks in the program (a header and M30 come on top).
const BLOCKS: usize = 100_000;
/// Units per millimetre (4 decimals).
const UNIT: i64 = 10_000;
/// Where the tool starts and stays near, in units.
const ANCHOR: (i64, i64) = (100 * UNIT, 100 * UNIT);
/// Beyond this distance from the anchor, moves steer back.
const SOFT: i64 = 20 * UNIT;

/// splitmix64: small, deterministic, good enough for test data.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// A whole number in `lo..=hi`.
    fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % (hi - lo + 1) as u64) as i64
    }
    /// A number in `-max..=max`, its sign turned towards the anchor when
    /// `pos` has drifted away from it.
    fn steer(&mut self, pos: i64, anchor: i64, max: i64) -> i64 {
        let v = self.range(-max, max);
        if (pos - anchor > SOFT && v > 0) || (anchor - pos > SOFT && v < 0) {
            -v
        } else {
            v
        }
    }
}

/// Units as a 4-decimal number, e.g. -1.2500.
fn mm(u: i64) -> String {
    let sign = if u < 0 { "-" } else { "" };
    format!("{sign}{}.{:04}", u.abs() / UNIT, u.abs() % UNIT)
}

/// `a / b` rounded to the nearest whole number, halves away from zero.
fn div_round(a: i64, b: i64) -> i64 {
    let q = (2 * a.abs() + b) / (2 * b);
    if a < 0 {
        -q
    } else {
        q
    }
}

fn program(blocks: usize) -> String {
    let mut rng = Rng(1);
    let (mut x, mut y, mut z) = (ANCHOR.0, ANCHOR.1, 10 * UNIT);
    let mut s = String::with_capacity(blocks * 48);
    s.push_str("N1 G17 G90 G94 G00 X100 Y100 Z10\nN2 F1000\n");
    for n in 3..blocks + 3 {
        let kind = rng.range(0, 2);
        if kind == 0 {
            // a line of 0.5..7 mm, Z moving by up to 1 mm within 4..16 mm
            let (dx, dy) = loop {
                let dx = rng.steer(x, ANCHOR.0, 5 * UNIT);
                let dy = rng.steer(y, ANCHOR.1, 5 * UNIT);
                if dx * dx + dy * dy >= (UNIT / 2) * (UNIT / 2) {
                    break (dx, dy);
                }
            };
            let dz = rng.range(-UNIT, UNIT);
            z = if (4 * UNIT..=16 * UNIT).contains(&(z + dz)) {
                z + dz
            } else {
                z - dz
            };
            (x, y) = (x + dx, y + dy);
            writeln!(s, "N{n} G01 X{} Y{} Z{}", mm(x), mm(y), mm(z)).unwrap();
            continue;
        }
        let g = if kind == 1 { "G02" } else { "G03" };
        loop {
            // centre offset (I, J) for a radius of 1..5 mm
            let i = rng.steer(x, ANCHOR.0, 5 * UNIT);
            let j = rng.steer(y, ANCHOR.1, 5 * UNIT);
            let r2 = i * i + j * j;
            if !(UNIT * UNIT..=25 * UNIT * UNIT).contains(&r2) {
                continue;
            }
            let (cx, cy) = (x + i, y + j);
            // rotation by 2*atan2(q, p): cos = (p²-q²)/d, sin = 2pq/d
            let (p, q) = (rng.range(1, 10), rng.range(1, 10));
            let d = p * p + q * q;
            let (mut c, mut sn) = (p * p - q * q, 2 * p * q);
            if rng.range(0, 3) == 0 {
                // beyond 180 degrees
                (c, sn) = (-c, -sn);
            }
            if g == "G02" {
                sn = -sn;
            }
            let (vx, vy) = (-i, -j);
            let ex = cx + div_round(c * vx - sn * vy, d);
            let ey = cy + div_round(sn * vx + c * vy, d);
            if (ex, ey) == (x, y) {
                continue; // a full circle
            }
            let re = (((ex - cx).pow(2) + (ey - cy).pow(2)) as f64).sqrt();
            if ((r2 as f64).sqrt() - re).abs() > 1.0 {
                continue; // the end off the circle by more than 0.0001 mm
            }
            writeln!(s, "N{n} {g} X{} Y{} I{} J{}", mm(ex), mm(ey), mm(i), mm(j)).unwrap();
            (x, y) = (ex, ey);
            break;
        }
    }
    writeln!(s, "N{} M30", blocks + 3).unwrap();
    s
}

fn bench_check(c: &mut Criterion) {
    let text = program(BLOCKS);
    let machine = Machine::builtin_mill();
    let report = check(StrSource::new(&text), Dialect::Cnc836, &machine);
    assert!(
        report.ok(),
        "the benchmark program is refused: {}",
        report.message()
    );
    let mut group = c.benchmark_group("check");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    group.throughput(Throughput::Elements(report.blocks));
    group.bench_function("100k_mixed_blocks", |b| {
        b.iter(|| check(StrSource::new(&text), Dialect::Cnc836, &machine))
    });
    group.finish();
}

criterion_group!(benches, bench_check);
criterion_main!(benches);
