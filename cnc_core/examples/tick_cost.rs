//! How long the executor takes for each sample, offline: the wall time of
//! every `next_sample` call on one program, as percentiles and the count
//! over 0.5 ms and 1 ms (a 1 kHz loop's whole cycle).
//!
//! `tick_cost MACHINE.toml PROGRAM.nc [DIALECT] [--paced] [--ahead]`:
//! `--ahead` plans on a thread of its own (`Executor::plan_ahead`); `--paced`
//! calls it once a sample period (sleeping between), as the node's loop
//! does, so that work on other threads can keep ahead as it would there.
//! With `TICK_COST_SHOW` set, each call over 1 ms is named on stderr.

use cnc_core::exec::Executor;
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine};
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().collect();
    let paced = args.iter().any(|a| a == "--paced");
    let ahead = args.iter().any(|a| a == "--ahead");
    args.retain(|a| a != "--paced" && a != "--ahead");
    if args.len() < 3 {
        eprintln!("usage: tick_cost MACHINE.toml PROGRAM.nc [DIALECT]");
        std::process::exit(2);
    }
    let run = || -> Result<(), String> {
        let m = std::fs::read_to_string(&args[1]).map_err(|e| e.to_string())?;
        let machine = Machine::from_toml(&m).map_err(|e| e.to_string())?;
        let text = std::fs::read_to_string(&args[2]).map_err(|e| e.to_string())?;
        let dialect: Dialect = args
            .get(3)
            .map_or("cnc836", String::as_str)
            .parse()
            .map_err(|e| format!("{e:?}"))?;
        let mut exec = Executor::new(StrSource::new(&text), dialect, &machine);
        if ahead {
            exec.plan_ahead(|| {});
        }
        let mut us = Vec::new();
        let start = Instant::now();
        let dt = exec.dt();
        loop {
            if paced {
                let due = start + std::time::Duration::from_secs_f64(dt * us.len() as f64);
                if let Some(wait) = due.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
            }
            let t0 = Instant::now();
            let s = exec.next_sample();
            us.push(t0.elapsed().as_secs_f64() * 1e6);
            if std::env::var_os("TICK_COST_SHOW").is_some() && us[us.len() - 1] > 1000.0 {
                eprintln!("sample {} took {:.0} µs", us.len() - 1, us[us.len() - 1]);
            }
            if s.is_none() {
                break;
            }
        }
        if let Some(f) = exec.fault() {
            return Err(f.to_string());
        }
        let total: f64 = us.iter().sum();
        let n = us.len();
        let over = |l: f64| us.iter().filter(|&&u| u > l).count();
        let mut sorted = us.clone();
        sorted.sort_by(f64::total_cmp);
        let q = |p: f64| sorted[((n - 1) as f64 * p) as usize];
        println!(
            "samples {n}  mean {:.1} µs  p50 {:.1}  p99 {:.1}  p99.9 {:.1}  max {:.1}  \
             over 0.5 ms {}  over 1 ms {}",
            total / n as f64,
            q(0.5),
            q(0.99),
            q(0.999),
            sorted[n - 1],
            over(500.0),
            over(1000.0)
        );
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("tick_cost: {e}");
        std::process::exit(1);
    }
}
