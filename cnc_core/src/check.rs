//! The check before motion: the whole program through interpreter and
//! planner, without sampling. Reports every error, the estimated cycle time
//! (equal to the executed one, by the shared [`Timeline`]) and the bounding
//! box.

use crate::canon::Event;
use crate::diag::Diagnostic;
use crate::dialect::Dialect;
use crate::geom::V3;
use crate::interp::Interpreter;
use crate::limits::MovePrep;
use crate::machine::Machine;
use crate::parse::{parse_words, Appended, Word};
use crate::path_run::RunLimits;
use crate::pipeline::{Estimate, Front, Totals};
use crate::plan::PlanLimits;
use crate::source::{ProgramSource, SourceError, SourcePos};
use std::collections::VecDeque;

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

/// Events planned before the check decides to use a second thread.
const FIRST_EVENTS: usize = 512;
/// Lines read at a time by the reading thread. (Each batch
/// handed over may wake the other thread: with 2048 lines a 1,000,000-line
/// program makes about 120 context switches instead of 1,600 with 512, for
/// about 3 MiB more memory in the batches.)
const LINES: usize = 2048;
/// Batches of lines on their way through the interpreter at most.
const IN_FLIGHT: usize = 4;

/// Checks a whole program.
///
/// A program of more than a few hundred moves is checked by two threads in
/// a pipeline: this one reads lines, a second one parses and interprets
/// them, and this one plans the events that come back. (Planning weighs
/// more than interpreting with its arc geometry, so the parse goes to the
/// second thread, and what the planner works out of each move alone
/// (length, tangents, limits) to whichever thread has time.) Every stage
/// sees everything in program order and nothing flows backwards (the
/// reader only runs ahead by a few batches), so the report is the one a
/// single thread makes, bit for bit.
pub fn check<S: ProgramSource>(source: S, dialect: Dialect, machine: &Machine) -> CheckReport {
    let lim = PlanLimits::from_machine(machine);
    let mut interp = Interpreter::new(source, dialect, machine).with_loop_scan();
    let mut plan = Estimate::new(lim, path_limits(machine));
    let mut first = VecDeque::with_capacity(FIRST_EVENTS);
    if interp.fill(&mut first, FIRST_EVENTS) {
        return check_concurrently(interp, plan, first, dialect, machine);
    }
    plan.run(&first, &[]);
    report(&interp, plan.finish(), lim)
}

/// The check on this thread, one batch of events at a time.
fn one_thread<S: ProgramSource>(
    mut interp: Interpreter<S, Front>,
    mut plan: Estimate,
    lim: PlanLimits,
) -> CheckReport {
    let mut events = VecDeque::with_capacity(FIRST_EVENTS);
    loop {
        let more = interp.fill(&mut events, FIRST_EVENTS);
        plan.run(&events, &[]);
        if !more {
            return report(&interp, plan.finish(), lim);
        }
    }
}

/// The path planner's limits and the path tolerance at the start, on a
/// machine that plans with it.
fn path_limits(machine: &Machine) -> Option<(RunLimits, f64)> {
    RunLimits::for_machine(machine).map(|l| (l, machine.planner.path_tolerance_mm))
}

fn report<T: ProgramSource>(
    interp: &Interpreter<T, Front>,
    totals: Totals,
    lim: PlanLimits,
) -> CheckReport {
    let mut r = CheckReport {
        blocks: interp.blocks(),
        moves: totals.moves,
        duration_s: totals.tl.group_k0 as f64 * lim.dt,
        ticks: totals.tl.group_k0,
        bbox: interp.path_bbox(),
        errors: interp.errors().to_vec(),
        error_count: interp.error_count(),
    };
    if let Some((line, why)) = totals.path_error {
        // (a program the path planner cannot plan, though every block is
        // right: nothing of it may run)
        r.errors.push(Diagnostic::new(
            line,
            1,
            1,
            format!("the path planner cannot plan this: {why}"),
        ));
        r.error_count += 1;
    }
    r
}

/// The source of an interpreter whose lines come from the check's reader.
struct Fed;

impl ProgramSource for Fed {
    fn append_line(&mut self, _buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError> {
        Ok(None)
    }
    fn seek(&mut self, _pos: SourcePos) -> Result<(), SourceError> {
        Ok(())
    }
    /// Lines come from the reading thread in file order: a jump (G73)
    /// stops the pipeline and the check runs again on one thread.
    fn can_seek(&self) -> bool {
        false
    }
}

/// One line of a batch: read (`Batch::read`), then parsed (`Batch::parse`).
struct ParsedLine {
    pos: SourcePos,
    /// end of its text in `Batch::text`, of its words in `Batch::words`
    /// (the words' once parsed)
    text_end: usize,
    words_end: usize,
    /// its parse error, once parsed
    error: Option<Box<Diagnostic>>,
}

/// Lines read by the reader, parsed and interpreted by the interpreting
/// thread, and back with the events made of them. Batches are reused.
#[derive(Default)]
struct Batch {
    lines: Vec<ParsedLine>,
    text: Vec<u8>,
    words: Vec<Word>,
    /// after the last line: the end of the text, or a read error
    end: Option<Result<(), SourceError>>,
    /// the interpreter's events for these lines
    events: VecDeque<Event>,
    /// what the planner works out of each move among them alone (computed
    /// by the interpreting thread to even out the work; the planner would
    /// compute the same)
    preps: Vec<MovePrep>,
    /// the interpreter has ended the program (later lines are not run)
    finished: bool,
}

impl Batch {
    /// Reads up to `LINES` lines; [`Batch::parse`] parses them.
    fn read<S: ProgramSource>(&mut self, src: &mut S) {
        self.lines.clear();
        self.text.clear();
        self.words.clear();
        self.end = None;
        while self.lines.len() < LINES {
            let start = self.text.len();
            match src.append_line(&mut self.text) {
                Ok(Some(pos)) => self.lines.push(ParsedLine {
                    pos,
                    text_end: self.text.len(),
                    words_end: 0,
                    error: None,
                }),
                Ok(None) => {
                    self.end = Some(Ok(()));
                    return;
                }
                Err(e) => {
                    self.text.truncate(start);
                    self.end = Some(Err(e));
                    return;
                }
            }
        }
    }

    /// Parses the lines read, as `Interpreter::step` would (on the
    /// interpreting thread: the planner weighs more than the interpreter).
    fn parse(&mut self, dialect: Dialect) {
        let mut t0 = 0;
        for l in &mut self.lines {
            let mut words = Appended {
                start: self.words.len(),
                words: &mut self.words,
            };
            let line = &self.text[t0..l.text_end];
            let parsed = parse_words(dialect, l.pos.line, line, &mut words, &mut false);
            l.words_end = self.words.len();
            l.error = parsed.err().map(Box::new);
            t0 = l.text_end;
        }
    }

    /// Runs the lines through the interpreter and keeps its events; with
    /// `prepare`, also what the planner works out of each move alone.
    /// `lim`: the planner's limits where these lines start (the events'
    /// tolerance changes change its jerk budget as they do the planner's).
    fn interpret(
        &mut self,
        interp: &mut Interpreter<Fed, Front>,
        lim: &mut PlanLimits,
        prepare: bool,
    ) {
        let (mut t0, mut w0) = (0, 0);
        for l in &mut self.lines {
            if interp.is_finished() {
                break;
            }
            let text = &self.text[t0..l.text_end];
            let words = &self.words[w0..l.words_end];
            interp.exec_line(l.pos.line, text, l.error.take(), words);
            (t0, w0) = (l.text_end, l.words_end);
        }
        if !interp.is_finished() {
            match &self.end {
                Some(Ok(())) => interp.end_of_text(),
                Some(Err(e)) => interp.read_failed(e),
                None => {}
            }
        }
        interp.take_events(&mut self.events);
        self.finished = interp.is_finished();
        self.preps.clear();
        for ev in &self.events {
            match ev {
                // (the check's estimate does not use the speed limit over the feed)
                Event::Move { geom, feed, .. } if prepare => {
                    self.preps.push(lim.prepare(geom, feed, false));
                }
                _ => lim.follow(ev),
            }
        }
    }
}

/// The rest of the check after `first` (planned here) with the pipeline
/// described at [`check`]; if no thread can be started, on this thread.
fn check_concurrently<S: ProgramSource>(
    interp: Interpreter<S, Front>,
    mut plan: Estimate,
    first: VecDeque<Event>,
    dialect: Dialect,
    machine: &Machine,
) -> CheckReport {
    let lim = PlanLimits::from_machine(machine);
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::mpsc::{channel, sync_channel};
    let (to_interp, interp_rx) = sync_channel::<Batch>(IN_FLIGHT);
    let (interp_tx, from_interp) = channel::<Batch>();
    let (start_tx, start_rx) = sync_channel::<Interpreter<Fed, Front>>(1);
    // What the planner works out of each move alone can be computed on
    // either thread (the same bits either way). The interpreting thread
    // takes it on while it keeps up (no further batch waits for it), which
    // evens out the work.
    let queued = AtomicUsize::new(0);
    let queued = &queued;
    // (the path planner plans from the moves themselves: nothing to work
    // out ahead)
    let prepare = !machine.plans_path();
    // (the interpreting thread's limits start where `first` leaves them)
    let mut lim_after_first = lim;
    first.iter().for_each(|ev| lim_after_first.follow(ev));
    // (`move`: should this thread panic, the channels close as it unwinds
    // and the other thread ends, so the scope can join it)
    std::thread::scope(move |s| {
        let spawned = std::thread::Builder::new()
            .name("cnc-check-interp".into())
            .spawn_scoped(s, move || {
                let mut interp = start_rx.recv().ok()?;
                let mut lim = lim_after_first;
                for mut batch in interp_rx {
                    // take work off the planner while keeping up with it
                    let behind = queued.fetch_sub(1, Ordering::Relaxed) > 1;
                    batch.parse(dialect);
                    batch.interpret(&mut interp, &mut lim, prepare && !behind);
                    if interp_tx.send(batch).is_err() {
                        break;
                    }
                }
                Some(interp)
            });
        let Ok(handle) = spawned else {
            // no second thread: everything here, one batch of events at a time
            plan.run(&first, &[]);
            return one_thread(interp, plan, lim);
        };
        let (mut source, interp) = interp.replace_source(Fed);
        // the thread is waiting for it (a failed send means it panicked: `join` says so)
        let _ = start_tx.send(interp);
        plan.run(&first, &[]);
        let mut spare: Vec<Batch> = Vec::with_capacity(IN_FLIGHT);
        let (mut in_flight, mut reading) = (0, true);
        loop {
            let back = if reading && in_flight < IN_FLIGHT {
                let mut batch = spare.pop().unwrap_or_default();
                batch.read(&mut source);
                reading = batch.end.is_none();
                // never blocks: at most IN_FLIGHT batches are out
                queued.fetch_add(1, Ordering::Relaxed);
                if to_interp.send(batch).is_err() {
                    break;
                }
                in_flight += 1;
                // plan what has come back meanwhile, without waiting
                match from_interp.try_recv() {
                    Ok(b) => b,
                    Err(_) => continue,
                }
            } else if in_flight > 0 {
                match from_interp.recv() {
                    Ok(b) => b,
                    Err(_) => break,
                }
            } else {
                break;
            };
            in_flight -= 1;
            reading &= !back.finished;
            plan.run(&back.events, &back.preps);
            spare.push(back);
        }
        drop(to_interp);
        match handle.join() {
            Ok(Some(interp)) if interp.needs_seek() => {
                // the program jumps: again from the start, on this thread
                if let Err(e) = source.seek(SourcePos { offset: 0, line: 1 }) {
                    let mut r = report(&interp, plan.finish(), lim);
                    if r.errors.len() < machine.limits.max_errors {
                        r.errors.push(Diagnostic::new(
                            1,
                            1,
                            1,
                            format!("cannot read the program again: {}", e.0),
                        ));
                    }
                    r.error_count += 1;
                    return r;
                }
                one_thread(
                    Interpreter::new(source, dialect, machine).with_loop_scan(),
                    Estimate::new(lim, path_limits(machine)),
                    lim,
                )
            }
            Ok(Some(interp)) => report(&interp, plan.finish(), lim),
            Ok(None) => unreachable!("the interpreter was sent to the thread"),
            Err(panic) => std::panic::resume_unwind(panic),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Item, Planner};
    use crate::source::{ReaderSource, StrSource};
    use crate::timeline::Timeline;

    /// The check as one thread does it: event by event through the
    /// interpreter and the public planner.
    fn one_thread<S: ProgramSource>(src: S, dialect: Dialect, machine: &Machine) -> CheckReport {
        let lim = PlanLimits::from_machine(machine);
        let mut interp = Interpreter::new(src, dialect, machine);
        let mut planner = Planner::new(lim);
        let mut tl = Timeline::for_limits(&lim);
        let mut moves = 0;
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
                    Item::Spindle { rpm, .. } => tl.set_spindle(rpm),
                    Item::Thread(m) => {
                        moves += 1;
                        tl.finish_thread(&m);
                    }
                    Item::Tool { .. } => {}
                    Item::Smoothing(b) => tl.set_hold(b.hold_ticks()),
                }
            }
            ended |= ev.is_none();
        }
        let moves = moves - planner.split_extra();
        report(
            &interp,
            Totals {
                tl,
                moves,
                ended,
                path_error: None,
            },
            lim,
        )
    }

    /// A long program of every kind of block, errors included: arcs
    /// (some that do not fit), lines, dwells, spindle and tool changes,
    /// path tolerances (a G64 P in the first batch, then G61 and G64 P:
    /// the jerk budget follows them), comments, blank lines and bad words.
    fn program(lines: usize, seed: u64, dialect: Dialect) -> String {
        let mut x = seed;
        let mut next = move |n: u64| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) % n
        };
        let comment = dialect.comment_char() as char;
        let mut s =
            String::from("N1 G17 G90 G94 G00 X100 Y100 Z10 S1000 M03\nN2 G64 P0.02 F1500\n");
        let (mut px, mut py) = (100.0f64, 100.0f64);
        for k in 3..lines as u64 {
            let line = match next(40) {
                0 => format!("N{k} G04 P0.{}", next(9)),
                1 => format!("N{k} S{} M0{}", next(3000), 3 + next(3)),
                2 => format!("N{k} T{}", next(12)),
                3 => format!("{comment} just a comment"),
                4 => String::new(),
                // errors (the position follows the block all the same)
                5 => {
                    px = 80.0 + next(50) as f64;
                    format!("N{k} G01 X{px} Q{}", next(9))
                }
                6 => {
                    px = -0.5 - next(9) as f64;
                    format!("N{k} G01 X{px}")
                }
                7 => {
                    py += 0.5;
                    format!("N{k} G02 X{px:.4} Y{py:.4} I1 J0")
                }
                8 => {
                    let (dx, dy) = (next(9), next(9));
                    (px, py) = (px + dx as f64 / 10.0, py - dy as f64 / 10.0);
                    format!("N{k} G91 G01 X0.{dx} Y-0.{dy}\nG90")
                }
                9 => format!("N{k} G01 Z{}.{}", next(20), next(99)),
                10 => format!(
                    "N{k} {}",
                    ["G61", "G64 P0.004", "G64 P0.05"][next(3) as usize]
                ),
                11..=24 => {
                    let (dx, dy) = (
                        next(2000) as f64 / 1000.0 - 1.0,
                        next(2000) as f64 / 1000.0 - 1.0,
                    );
                    (px, py) = (px + dx, py + dy);
                    format!("N{k} G01 X{px:.4} Y{py:.4} F{}", 200 + next(3000))
                }
                _ => {
                    // an arc about a centre 1..3 mm away, ending on the circle
                    let (i, j) = (
                        next(200) as f64 / 100.0 + 1.0,
                        next(200) as f64 / 100.0 - 1.0,
                    );
                    let (cx, cy) = (px + i, py + j);
                    let r = (i * i + j * j).sqrt();
                    let a = (-j).atan2(-i) + next(600) as f64 / 100.0;
                    let (ex, ey) = (cx + r * a.cos(), cy + r * a.sin());
                    let g = if next(2) == 0 { "G02" } else { "G03" };
                    let l = format!("N{k} {g} X{ex:.4} Y{ey:.4} I{i:.4} J{j:.4}");
                    // the next block starts where this one ends, as written
                    (px, py) = (
                        format!("{ex:.4}").parse().unwrap(),
                        format!("{ey:.4}").parse().unwrap(),
                    );
                    l
                }
            };
            s.push_str(&line);
            s.push('\n');
        }
        s
    }

    fn same(a: &CheckReport, b: &CheckReport) {
        // Debug tells -0.0 from 0.0, so this is bit for bit
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
    }

    #[test]
    fn two_threads_report_what_one_thread_does() {
        let mill = Machine::builtin_mill();
        let lathe = Machine::builtin_lathe();
        for (seed, lines) in [(1, 20_000), (2, 3_000), (3, 700), (4, 50)] {
            for dialect in Dialect::ALL {
                let text = program(lines, seed, dialect);
                for m in [&mill, &lathe] {
                    let want = one_thread(StrSource::new(&text), dialect, m);
                    assert!(want.moves > 0 && want.error_count > 0);
                    same(&check(StrSource::new(&text), dialect, m), &want);
                }
                // the program end in the middle: nothing after it counts
                let mid = text.len() / 2;
                let cut = mid + text[mid..].find('\n').unwrap() + 1;
                let ended = format!("{}M30\n{}", &text[..cut], &text[cut..]);
                same(
                    &check(StrSource::new(&ended), dialect, &mill),
                    &one_thread(StrSource::new(&ended), dialect, &mill),
                );
            }
        }
    }

    #[test]
    fn two_threads_keep_the_first_errors_and_count_all() {
        let mill = Machine::builtin_mill();
        let text = "G00 X1 Q1\n".repeat(3000);
        let r = check(StrSource::new(&text), Dialect::Cnc836, &mill);
        assert_eq!(
            (r.errors.len(), r.error_count),
            (mill.limits.max_errors, 3000)
        );
        same(
            &r,
            &one_thread(StrSource::new(&text), Dialect::Cnc836, &mill),
        );
    }

    #[test]
    fn two_threads_report_a_read_error_where_one_thread_does() {
        let mut mill = Machine::builtin_mill();
        mill.limits.max_errors = 100_000;
        let mut text = program(5_000, 7, Dialect::Cnc836);
        // line 4001 is too long for the reader
        let at = text.match_indices('\n').nth(3999).unwrap().0 + 1;
        text.insert_str(at, &"X".repeat(5000));
        let reader = || ReaderSource::new(std::io::Cursor::new(text.as_bytes()), 4096);
        let r = check(reader(), Dialect::Cnc836, &mill);
        let last = r.errors.last().unwrap();
        assert!(
            last.line == 4001 && last.message.contains("longer than"),
            "{last}"
        );
        same(&r, &one_thread(reader(), Dialect::Cnc836, &mill));
    }
}
