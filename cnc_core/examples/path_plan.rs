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
//! Modes 1 and 2 run both stages as a look-ahead would
//! (`path_smooth::Stream` into `path_speed::Planner`, the points a batch
//! at a time, each stage forgetting what lies behind the samples). With
//! `PATH_PLAN_CHUNK=C,M` the geometry is worked out C mm of the run at a
//! time, with M mm on either side; without it, the whole run at its end.
//!
//! `path_plan stations` (`G2_SPEED`): the speed stage alone on stations
//! the caller smoothed; prints the path position at every sample. Input:
//!
//! ```text
//! h len dt
//! vx vy vz ax ay az jx jy jz
//! tx ty tz kx ky kz k'x k'y k'z feed      (one line per station)
//! ```

use cnc_core::path_smooth::{self, Polyline, Stream};
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
    if mode as i64 == 0 {
        let sm = path_smooth::plain(&run)?;
        let t1 = Instant::now();
        let path = Path::new(h, sm.len(), sm.stations(h))?;
        let s = Planner::new(path, lim, dt)?.run(10_000_000)?;
        eprintln!(
            "path_plan: {} samples; smoothed in {:.3} s (as programmed), speed in {:.3} s",
            s.len() - 1,
            (t1 - t0).as_secs_f64(),
            t1.elapsed().as_secs_f64()
        );
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        for x in s {
            let p = sm.point(x);
            writeln!(out, "{:.12e} {:.12e} {:.12e}", p[0], p[1], p[2])?;
        }
        return Ok(());
    }
    streamed(&run, [tol, mode, dt, h, chunk, margin], lim)
}

/// Both stages as a look-ahead runs them: the run's points come a batch at
/// a time, the geometry hands the speed stage the stations it has worked
/// out, the samples come out as soon as they are decided, and each stage
/// forgets what lies behind them.
fn streamed(
    run: &Polyline,
    [tol, mode, dt, h, chunk, margin]: [f64; 6],
    lim: AxisLimits,
) -> Res<()> {
    const BATCH: usize = 256;
    let mut geo = Stream::new(tol, mode > 1.5, chunk, margin, h)?;
    let mut speed = Planner::new(Path::open(h)?, lim, dt)?;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let (mut stations, mut xs) = (Vec::new(), Vec::new());
    // samples, the most grid points and stations kept, each stage's time
    let (mut samples, mut most, mut took) = (0usize, (0usize, 0usize), (0.0, 0.0));
    let n = run.p.len();
    for i in (0..n).step_by(BATCH) {
        let t0 = Instant::now();
        for (p, f) in run.p[i..(i + BATCH).min(n)].iter().zip(&run.feed[i..]) {
            geo.push(*p, *f)?;
        }
        if i + BATCH >= n {
            geo.finish()?;
        }
        geo.advance(&mut stations)?;
        let t1 = Instant::now();
        for st in stations.drain(..) {
            speed.push(st)?;
        }
        if let Some(len) = geo.len() {
            speed.finish(len)?;
        }
        while let Some(x) = speed.next_sample()? {
            xs.push(x);
        }
        let t2 = Instant::now();
        for x in &xs {
            let p = geo
                .point(*x)
                .ok_or("a sample before the geometry has two points")?;
            writeln!(out, "{:.12e} {:.12e} {:.12e}", p[0], p[1], p[2])?;
        }
        samples += xs.len();
        most = (most.0.max(geo.kept()), most.1.max(speed.path().kept()));
        if let Some(x) = xs.last() {
            geo.forget_before(*x);
        }
        xs.clear();
        took.0 += (t1 - t0).as_secs_f64();
        took.1 += (t2 - t1).as_secs_f64();
    }
    if !speed.arrived() {
        return Err("the run did not come to rest on its end".into());
    }
    eprintln!(
        "path_plan: {} samples; smoothed in {:.3} s (dev {:.2} um, streamed: at most {} grid points and {} stations kept), speed in {:.3} s",
        samples - 1,
        took.0,
        geo.dev() * 1000.0,
        most.0,
        most.1,
        took.1
    );
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
