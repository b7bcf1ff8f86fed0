//! The check before motion: the whole program through interpreter and
//! planner, without sampling. Reports every error, the estimated cycle time
//! (equal to the executed one, by the shared [`Timeline`]) and the bounding
//! box.

use crate::diag::Diagnostic;
use crate::dialect::Dialect;
use crate::interp::Interpreter;
use crate::machine::Machine;
use crate::plan::{Item, PlanLimits, Planner, Timeline};
use crate::source::ProgramSource;
use crate::V3;

/// What the check found.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckReport {
    /// blocks (lines with words) in the program
    pub blocks: u64,
    /// moves executed (loops counted as run)
    pub moves: u64,
    /// estimated cycle time, s (a whole number of ticks)
    pub duration_s: f64,
    /// the same in ticks
    pub ticks: u64,
    /// bounding box of the path, machine coordinates (lathe X as radius)
    pub bbox: Option<(V3, V3)>,
    /// the errors kept (at most the machine's `max_errors`)
    pub errors: Vec<Diagnostic>,
    /// all errors found
    pub error_count: usize,
}

impl CheckReport {
    pub fn ok(&self) -> bool {
        self.error_count == 0
    }

    /// One error per line, `line L, column C: ...`, as the service answers.
    pub fn message(&self) -> String {
        let mut s = String::new();
        for e in &self.errors {
            s.push_str(&e.to_string());
            s.push('\n');
        }
        if self.error_count > self.errors.len() {
            s.push_str(&format!(
                "... and {} more errors\n",
                self.error_count - self.errors.len()
            ));
        }
        s.pop();
        s
    }
}

/// Checks a whole program.
pub fn check<S: ProgramSource>(source: S, dialect: Dialect, machine: &Machine) -> CheckReport {
    let lim = PlanLimits::from_machine(machine);
    let mut interp = Interpreter::new(source, dialect, machine);
    let mut planner = Planner::new(lim);
    let mut tl = Timeline::new(lim.dt);
    let mut moves = 0u64;
    let mut ended = false;
    while !ended {
        let ev = interp.next();
        match ev {
            Some(e) => planner.push(e),
            None => planner.flush(),
        }
        while let Some(item) = planner.pop() {
            match item {
                Item::Move(m) => {
                    moves += 1;
                    tl.finish_move(&m);
                }
                Item::Dwell { seconds, .. } => tl.finish_dwell(seconds),
                Item::End { .. } => ended = true,
                Item::Spindle { .. } | Item::Tool { .. } => {}
            }
        }
        if ev.is_none() {
            ended = true;
        }
    }
    CheckReport {
        blocks: interp.blocks(),
        moves,
        duration_s: tl.group_k0 as f64 * lim.dt,
        ticks: tl.group_k0,
        bbox: interp.bbox(),
        errors: interp.errors().to_vec(),
        error_count: interp.error_count(),
    }
}
