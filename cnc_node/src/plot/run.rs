//! The offline run behind a program's plots: the program checked once and
//! run once, its steps handed to the sinks the wanted figures need (the
//! setpoints and actual positions for the path figure, the thread errors
//! for the thread figure).

use super::decimate::{one_run, Decimator, MAX_SERIES_POINTS};
use super::thread_errors::{ThreadErrorSeries, ThreadErrors};
use crate::offline::{check_text, run, SimSummary, Sink, Step};
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine, V3};

/// Setpoints and actual positions (mm, machine axes) of a run.
pub(crate) struct Run {
    pub(crate) setpoints: Vec<V3>,
    pub(crate) actual: Vec<V3>,
}

/// Collects the setpoints and the simulated actual positions of a run,
/// each thinned to [`MAX_SERIES_POINTS`].
struct RunPaths {
    joints: Vec<usize>,
    set: Decimator<V3>,
    act: Decimator<V3>,
}

impl RunPaths {
    fn new(machine: &Machine) -> RunPaths {
        RunPaths {
            joints: machine.joint_indices(),
            set: Decimator::new(MAX_SERIES_POINTS),
            act: Decimator::new(MAX_SERIES_POINTS),
        }
    }

    fn into_run(self) -> Run {
        Run {
            setpoints: one_run(self.set),
            actual: one_run(self.act),
        }
    }
}

impl Sink for RunPaths {
    fn step(&mut self, st: &Step) -> Result<(), String> {
        self.set.push(0, st.sample.pos);
        let mut a = V3::zeros();
        for (j, &i) in self.joints.iter().enumerate() {
            if let (Some(v), true) = (st.actual.get(j), i < 3) {
                a[i] = *v;
            }
        }
        self.act.push(0, a);
        Ok(())
    }

    fn finish(&mut self, _: &SimSummary) -> Result<(), String> {
        Ok(())
    }
}

/// One offline run of a program for its plots (`cnc plot`): checked once,
/// simulated once (as `cnc simulate`: the spindle model and its encoder
/// drive G33), the steps collected for the figures asked for.
pub struct ProgramRun<'a> {
    pub(crate) machine: &'a Machine,
    pub(crate) dialect: Dialect,
    pub(crate) program_name: &'a str,
    pub(crate) text: &'a str,
    /// the path figure's data, if asked for
    pub(crate) paths: Option<Run>,
    /// the thread errors, if asked for (an error: the machine has no
    /// spindle)
    thread: Option<Result<ThreadErrorSeries, String>>,
}

impl<'a> ProgramRun<'a> {
    /// Checks `text` and runs it once, collecting the path figure's data
    /// (`paths`) and the thread errors (`thread`). A program that does not
    /// pass the check is an error: nothing is plotted.
    pub fn new(
        machine: &'a Machine,
        dialect: Dialect,
        program_name: &'a str,
        text: &'a str,
        paths: bool,
        thread: bool,
    ) -> Result<ProgramRun<'a>, String> {
        check_text(machine, dialect, program_name, text, "nothing plotted")?;
        let mut run_paths = paths.then(|| RunPaths::new(machine));
        let mut errors = (thread && machine.spindle.is_some()).then(|| ThreadErrors::new(machine));
        let mut sinks: Vec<&mut dyn Sink> = Vec::new();
        if let Some(p) = run_paths.as_mut() {
            sinks.push(p);
        }
        if let Some(t) = errors.as_mut() {
            sinks.push(t);
        }
        if !sinks.is_empty() {
            run(StrSource::new(text), dialect, machine, &mut sinks)?;
        }
        let thread = thread.then(|| match errors {
            Some(t) => Ok(t.into_series()),
            None => Err(format!(
                "machine {}: no spindle ([spindle] in the machine file), so no G33",
                machine.name
            )),
        });
        Ok(ProgramRun {
            machine,
            dialect,
            program_name,
            text,
            paths: run_paths.map(RunPaths::into_run),
            thread,
        })
    }

    /// The lead error of each G33 pass (see [`ThreadErrors`]); an error
    /// when the machine has no spindle or the run was not asked for them.
    pub fn thread_errors(&self) -> Result<&ThreadErrorSeries, String> {
        match &self.thread {
            Some(Ok(s)) => Ok(s),
            Some(Err(e)) => Err(e.clone()),
            None => Err(format!(
                "{}: the run did not collect the thread errors",
                self.program_name
            )),
        }
    }

    /// [`thread_errors`](Self::thread_errors), taken.
    pub fn into_thread_errors(self) -> Result<ThreadErrorSeries, String> {
        match self.thread {
            Some(r) => r,
            None => Err(format!(
                "{}: the run did not collect the thread errors",
                self.program_name
            )),
        }
    }
}
