//! Runs `cnc_core::path_speed` on a path read from stdin and prints the
//! path position at every sample, one per line, and on stderr how long the
//! planning took. Used by
//! `bench/motion/g2_bound.py` (`G2_SPEED=rust`) to put the speed stage on
//! the prototype's smoothed geometry.
//!
//! Input, numbers separated by white space:
//!
//! ```text
//! h len dt
//! vx vy vz ax ay az jx jy jz
//! tx ty tz kx ky kz k'x k'y k'z feed      (one line per station)
//! ```

use cnc_core::path_speed::{AxisLimits, Path, Planner, Station};
use std::io::{Read, Write};

fn main() {
    if let Err(e) = run() {
        eprintln!("path_speed: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text)?;
    let nums: Vec<f64> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    if nums.len() < 12 || !(nums.len() - 12).is_multiple_of(10) {
        return Err(format!("{} numbers: want 12, then 10 per station", nums.len()).into());
    }
    let (h, len, dt) = (nums[0], nums[1], nums[2]);
    let three = |i: usize| [nums[i], nums[i + 1], nums[i + 2]];
    let lim = AxisLimits {
        v: three(3),
        a: three(6),
        j: three(9),
    };
    let st = nums[12..]
        .chunks(10)
        .map(|c| Station {
            t: [c[0], c[1], c[2]],
            k: [c[3], c[4], c[5]],
            kd: [c[6], c[7], c[8]],
            feed: c[9],
        })
        .collect();
    let path = Path::new(h, len, st)?;
    let t0 = std::time::Instant::now();
    let s = Planner::new(&path, lim, dt)?.run(10_000_000)?;
    // how long planning took (wall time on this thread), for the bench
    eprintln!(
        "path_speed: {} samples in {:.3} s",
        s.len() - 1,
        t0.elapsed().as_secs_f64()
    );
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for x in s {
        writeln!(out, "{x:.12e}")?;
    }
    Ok(())
}
