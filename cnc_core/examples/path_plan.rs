//! Plans one run with the planner stages that are not wired into the
//! executor yet, for `bench/motion/g2_bound.py`; on stderr how long each
//! stage took.
//!
//! `path_plan` (`G2_PLAN`): the geometry stage (`cnc_core::path_smooth`)
//! and the speed stage (`cnc_core::path_speed`); prints the position at
//! every sample, `x y z` one per line. Input, numbers separated by white
//! space:
//!
//! ```text
//! tol mode dt h          (P mm; mode 0 as it is, 1 smoothed, 2 smoothed
//!                         with the shrink made up; station spacing h mm)
//! vx vy vz ax ay az jx jy jz
//! x y z feed             (one line per point of the run's polyline)
//! ```
//!
//! With `PATH_PLAN_CHUNK=C,M` the geometry is worked out C mm of the run at
//! a time, with M mm on either side (`path_smooth::smooth_chunked`).
//!
//! `path_plan stations` (`G2_SPEED`): the speed stage alone on stations
//! the caller smoothed; prints the path position at every sample. Input:
//!
//! ```text
//! h len dt
//! vx vy vz ax ay az jx jy jz
//! tx ty tz kx ky kz k'x k'y k'z feed      (one line per station)
//! ```

use cnc_core::path_smooth::{self, Polyline};
use cnc_core::path_speed::{AxisLimits, Path, Planner, Station};
use std::io::{Read, Write};
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn main() {
    let stations = std::env::args().nth(1).as_deref() == Some("stations");
    if let Err(e) = input().and_then(|nums| {
        if stations {
            speed_only(&nums)
        } else {
            plan(&nums)
        }
    }) {
        eprintln!("path_plan: {e}");
        std::process::exit(1);
    }
}

/// The numbers on stdin.
fn input() -> Res<Vec<f64>> {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text)?;
    Ok(text
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()?)
}

/// The limits after `head` header numbers, and the records after them.
fn limits(nums: &[f64], head: usize, per: usize) -> Res<(AxisLimits, &[f64])> {
    if nums.len() < head + 9 || !(nums.len() - head - 9).is_multiple_of(per) {
        return Err(format!(
            "{} numbers: want {}, then {per} per record",
            nums.len(),
            head + 9
        )
        .into());
    }
    let three = |i: usize| [nums[head + i], nums[head + i + 1], nums[head + i + 2]];
    Ok((
        AxisLimits {
            v: three(0),
            a: three(3),
            j: three(6),
        },
        &nums[head + 9..],
    ))
}

fn plan(nums: &[f64]) -> Res<()> {
    let (lim, pts) = limits(nums, 4, 4)?;
    let (tol, mode, dt, h) = (nums[0], nums[1], nums[2], nums[3]);
    let run = Polyline {
        p: pts.chunks(4).map(|c| [c[0], c[1], c[2]]).collect(),
        feed: pts.chunks(4).map(|c| c[3]).collect(),
    };
    let t0 = Instant::now();
    // PATH_PLAN_CHUNK=C,M: the geometry worked out C mm at a time with M mm
    // on either side (`smooth_chunked`)
    let (chunk, margin) = match std::env::var("PATH_PLAN_CHUNK") {
        Ok(v) => {
            let mut it = v.split(',').map(str::parse::<f64>);
            match (it.next(), it.next()) {
                (Some(Ok(c)), Some(Ok(m))) => (c, m),
                _ => return Err(format!("PATH_PLAN_CHUNK={v}: want CHUNK,MARGIN in mm").into()),
            }
        }
        Err(_) => (f64::INFINITY, 0.0),
    };
    let sm = match mode as i64 {
        0 => path_smooth::plain(&run)?,
        m => path_smooth::smooth_chunked(&run, tol, m > 1, chunk, margin)?,
    };
    let t1 = Instant::now();
    let path = Path::new(h, sm.len(), sm.stations(h))?;
    let s = Planner::new(path, lim, dt)?.run(10_000_000)?;
    let t2 = Instant::now();
    let wmin = sm.w.iter().cloned().fold(f64::INFINITY, f64::min);
    eprintln!(
        "path_plan: {} samples; smoothed in {:.3} s (dev {:.2} um, w from {:.4} mm), speed in {:.3} s",
        s.len() - 1,
        (t1 - t0).as_secs_f64(),
        sm.dev * 1000.0,
        wmin,
        (t2 - t1).as_secs_f64()
    );
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for x in s {
        let p = sm.point(x);
        writeln!(out, "{:.12e} {:.12e} {:.12e}", p[0], p[1], p[2])?;
    }
    Ok(())
}

fn speed_only(nums: &[f64]) -> Res<()> {
    let (lim, rows) = limits(nums, 3, 10)?;
    let (h, len, dt) = (nums[0], nums[1], nums[2]);
    let st = rows
        .chunks(10)
        .map(|c| Station {
            t: [c[0], c[1], c[2]],
            k: [c[3], c[4], c[5]],
            kd: [c[6], c[7], c[8]],
            feed: c[9],
        })
        .collect();
    let path = Path::new(h, len, st)?;
    let t0 = Instant::now();
    let s = Planner::new(path, lim, dt)?.run(10_000_000)?;
    eprintln!(
        "path_plan: {} samples; speed in {:.3} s",
        s.len() - 1,
        t0.elapsed().as_secs_f64()
    );
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for x in s {
        writeln!(out, "{x:.12e}")?;
    }
    Ok(())
}
