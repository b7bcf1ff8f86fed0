//! The consumers of an offline run ([`Sink`]) and the run that feeds them.

use super::sim::{simulate_with, SimSummary, Step};
use cnc_core::exec::Sample;
use cnc_core::source::{ProgramSource, StrSource};
use cnc_core::{check, CheckReport, Dialect, Machine};

/// A consumer of an offline run: sees every step in order, then the end.
///
/// A sink keeps what it makes (a file, a summary, collected data) and
/// hands it out through its own methods once the run is over.
pub trait Sink {
    /// One step of the run. An error ends the sink: it sees no further
    /// step and is not finished; [`run`] returns the error.
    fn step(&mut self, step: &Step) -> Result<(), String>;
    /// The end of the run, after its last step, with what it measured
    /// (sample count, cycle time, following errors, a fault that stopped
    /// it early).
    fn finish(&mut self, summary: &SimSummary) -> Result<(), String>;
}

/// Runs a checked program to its end against the model once, handing
/// every step to each sink in turn and then finishing them. Returns what
/// the run measured, or the first error of a sink (the other sinks are
/// still fed and finished, so that their outputs are complete).
pub fn run<S: ProgramSource>(
    source: S,
    dialect: Dialect,
    machine: &Machine,
    sinks: &mut [&mut dyn Sink],
) -> Result<SimSummary, String> {
    run_with(source, dialect, machine, |_| {}, sinks)
}

/// [`run`], with `alter` applied to every interpolator sample before the
/// model and the sinks see it (see [`super::simulate_with`]).
pub fn run_with<S: ProgramSource>(
    source: S,
    dialect: Dialect,
    machine: &Machine,
    alter: impl FnMut(&mut Sample),
    sinks: &mut [&mut dyn Sink],
) -> Result<SimSummary, String> {
    let mut failed = vec![false; sinks.len()];
    let mut first_error: Option<String> = None;
    let summary = simulate_with(source, dialect, machine, alter, |st| {
        for (sink, failed) in sinks.iter_mut().zip(failed.iter_mut()) {
            if *failed {
                continue;
            }
            if let Err(e) = sink.step(st) {
                *failed = true;
                first_error.get_or_insert(e);
            }
        }
    });
    for (sink, failed) in sinks.iter_mut().zip(&failed) {
        if !*failed {
            if let Err(e) = sink.finish(&summary) {
                first_error.get_or_insert(e);
            }
        }
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok(summary),
    }
}

/// The check of a program held as text, before its offline run: the
/// report (its `ticks` size the sinks) if the program passes, else
/// `"{program_name}: N error(s), {refused}:"` and the errors.
pub fn check_text(
    machine: &Machine,
    dialect: Dialect,
    program_name: &str,
    text: &str,
    refused: &str,
) -> Result<CheckReport, String> {
    let report = check(StrSource::new(text), dialect, machine);
    if report.ok() {
        Ok(report)
    } else {
        Err(format!(
            "{program_name}: {} error(s), {refused}:\n{}",
            report.error_count,
            report.message()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts steps; fails at step `fail_at` when given.
    struct Count {
        steps: u64,
        finished: bool,
        fail_at: Option<u64>,
    }

    impl Sink for Count {
        fn step(&mut self, _: &Step) -> Result<(), String> {
            self.steps += 1;
            match self.fail_at {
                Some(k) if k == self.steps => Err(format!("failed at {k}")),
                _ => Ok(()),
            }
        }
        fn finish(&mut self, _: &SimSummary) -> Result<(), String> {
            self.finished = true;
            Ok(())
        }
    }

    #[test]
    fn every_sink_sees_every_step_and_a_failing_one_stops_alone() {
        let m = Machine::builtin_mill();
        let text = "G1 X5 F600\nM30\n";
        let report = check_text(&m, m.dialect, "p.nc", text, "nothing run").unwrap();
        let count = || Count {
            steps: 0,
            finished: false,
            fail_at: None,
        };
        let (mut a, mut b) = (count(), count());
        let s = run(StrSource::new(text), m.dialect, &m, &mut [&mut a, &mut b]).unwrap();
        assert_eq!((a.steps, b.steps), (s.samples, s.samples));
        assert_eq!(s.samples, report.ticks + 1);
        assert!(a.finished && b.finished);
        let mut bad = Count {
            fail_at: Some(3),
            ..count()
        };
        let mut good = count();
        let e = run(
            StrSource::new(text),
            m.dialect,
            &m,
            &mut [&mut bad, &mut good],
        )
        .unwrap_err();
        assert_eq!(e, "failed at 3");
        assert_eq!(bad.steps, 3);
        assert!(!bad.finished);
        assert!(good.finished && good.steps == s.samples);
        let e = check_text(&m, m.dialect, "bad.nc", "G1 X\n", "nothing run").unwrap_err();
        assert!(e.starts_with("bad.nc: 1 error(s), nothing run:\n"), "{e}");
    }
}
