//! The path planner on a thread of its own, ahead of the loop that hands
//! its samples out: [`Ahead`] runs a [`Runner`] on a worker thread up to
//! `LEAD` steps ahead of the consumer, so that a sample whose speed takes
//! milliseconds to decide, or a run's start, does not make the 1 kHz loop
//! late. The steps are the same as the runner's on the consumer's own
//! thread, a feed hold and its end included:
//!
//! - the worker keeps the speed stage's state after every sample the
//!   consumer has not passed ([`Snapshot`]), and each run keeps what going
//!   back to them needs;
//! - a hold (or its end) asked for after sample k goes back to k's state
//!   and holds there, as the runner would have done after handing out k;
//!   the steps worked out past k are dropped (the consumer tells them by
//!   their epoch);
//! - the worker starts on what follows a run only once the consumer has
//!   reached a sample after which no hold changes the run (its last
//!   braking decided, no hold on: `Snapshot::settled`), or its end.
//!
//! Commands come from the consumer's thread as the worker asks for them.

use super::scale::LATENCY;
use super::{Runner, Step};
use crate::canon::Event;
use crate::path_speed::Snapshot;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;

/// Steps worked out ahead of the consumer at most (at 1 kHz, 0.1 s): no
/// more than an override's delay, so that it never undoes a step.
const LEAD: u64 = LATENCY;
/// Commands handed over at once when the worker asks.
const BATCH: usize = 64;

enum Cmd {
    /// the next commands; `true`: no more after them
    Events(Vec<Event>, bool),
    /// the consumer has had step `seq`
    Had(u64),
    /// a hold (`on`) or its end, after step `seq` (a sample of a run in
    /// progress, not settled); ending it, the override from the next step
    Hold {
        on: bool,
        seq: u64,
        scale: Option<f64>,
    },
    /// the feed override from step `at` on (`scale::LATENCY` after it was
    /// asked: never worked out yet)
    Scale { at: u64, scale: f64 },
}

// one value at a time: boxing the step would only add an allocation
#[allow(clippy::large_enum_variant)]
enum Out {
    /// step `seq`; `settled`: a sample after which no hold changes its run
    Step {
        epoch: u64,
        seq: u64,
        step: Step,
        settled: bool,
    },
    /// the worker wants commands
    Need,
    /// no step is to come
    End {
        epoch: u64,
    },
    Failed {
        epoch: u64,
        why: String,
    },
}

/// The consumer's side: a runner's steps, worked out ahead.
pub struct Ahead {
    tx: Sender<Cmd>,
    rx: Receiver<Out>,
    need: Arc<AtomicBool>,
    /// the steps of this epoch count; the next one's `seq`
    epoch: u64,
    seq: u64,
    /// the last step had: a sample of a run, not its last; settled
    in_run: bool,
    settled: bool,
    held: bool,
    closed: bool,
    ended: bool,
    /// the override last asked
    scale: f64,
}

impl Ahead {
    /// Moves `runner` to a thread of its own (which first calls
    /// `on_start`, e.g. to leave a real-time priority it inherited); gives
    /// it back if the thread cannot be started.
    pub fn spawn(mut runner: Runner, on_start: fn()) -> Result<Ahead, Box<Runner>> {
        let (tx, crx) = channel::<Cmd>();
        let (otx, rx) = channel::<Out>();
        let need = Arc::new(AtomicBool::new(false));
        runner.keep_for_rewind();
        let (slot_tx, slot_rx) = std::sync::mpsc::sync_channel::<Runner>(1);
        let flag = need.clone();
        let started = std::thread::Builder::new()
            .name("path-planner".into())
            .spawn(move || {
                on_start();
                if let Ok(runner) = slot_rx.recv() {
                    Work::new(runner, crx, otx, flag).run();
                }
            });
        if started.is_err() {
            return Err(Box::new(runner));
        }
        if let Err(e) = slot_tx.send(runner) {
            return Err(Box::new(e.0));
        }
        Ok(Ahead {
            tx,
            rx,
            need,
            epoch: 0,
            seq: 0,
            in_run: false,
            settled: false,
            held: false,
            closed: false,
            ended: false,
            scale: 1.0,
        })
    }

    /// A feed hold (`on`) of the run in progress, or its end: as
    /// `Runner::hold` called between the last step had and the next.
    pub fn hold(&mut self, on: bool) {
        self.hold_at(on, None);
    }

    /// The end of a feed hold with the override `scale`, as
    /// `Runner::resume` between the last step had and the next.
    pub fn resume(&mut self, scale: f64) {
        let live = self.held && self.in_run && !self.settled;
        self.hold_at(false, live.then_some(scale));
        if live {
            self.scale = scale;
        } else {
            self.set_scale(scale);
        }
    }

    fn hold_at(&mut self, on: bool, scale: Option<f64>) {
        if on == self.held {
            return;
        }
        self.held = on;
        if self.in_run && !self.settled {
            let _ = self.tx.send(Cmd::Hold {
                on,
                seq: self.seq - 1,
                scale,
            });
            self.epoch += 1;
        }
    }

    /// The feed override, as `Runner::set_scale` between the last step had
    /// and the next.
    pub fn set_scale(&mut self, scale: f64) {
        if scale != self.scale && scale > 0.0 && scale.is_finite() {
            self.scale = scale;
            let at = self.seq + LATENCY;
            let _ = self.tx.send(Cmd::Scale { at, scale });
        }
    }

    /// Whether no run is in progress.
    pub fn idle(&self) -> bool {
        !self.in_run
    }

    /// Hands the worker commands from `pull` if it asked for them. (It
    /// asks twice: the flag is seen at the next step even behind samples
    /// still queued, the `Need` message wakes a step waiting for one.)
    fn feed(&mut self, pull: &mut dyn FnMut() -> Option<Event>) {
        if self.closed || !self.need.swap(false, Ordering::AcqRel) {
            return;
        }
        let mut evs = Vec::with_capacity(BATCH);
        while evs.len() < BATCH {
            match pull() {
                Some(ev) => evs.push(ev),
                None => {
                    self.closed = true;
                    break;
                }
            }
        }
        let _ = self.tx.send(Cmd::Events(evs, self.closed));
    }

    /// The next step (waiting for the worker if it is not ahead); `None`
    /// after the last. `pull`: the next command, `None` after the last.
    pub fn step(
        &mut self,
        pull: &mut dyn FnMut() -> Option<Event>,
    ) -> Result<Option<Step>, String> {
        let gone = || "the path planner's thread stopped".to_string();
        if self.ended {
            return Ok(None);
        }
        loop {
            self.feed(pull);
            let out = match self.rx.try_recv() {
                Ok(o) => o,
                Err(TryRecvError::Empty) => self.rx.recv().map_err(|_| gone())?,
                Err(TryRecvError::Disconnected) => return Err(gone()),
            };
            match out {
                Out::Need => continue,
                Out::End { epoch } if epoch == self.epoch => {
                    self.ended = true;
                    return Ok(None);
                }
                Out::Failed { epoch, why } if epoch == self.epoch => return Err(why),
                Out::Step {
                    epoch,
                    seq,
                    step,
                    settled,
                } if epoch == self.epoch && seq == self.seq => {
                    self.seq += 1;
                    let _ = self.tx.send(Cmd::Had(seq));
                    self.in_run = matches!(step, Step::Sample { last: false, .. });
                    self.settled = settled;
                    return Ok(Some(step));
                }
                // (worked out before a hold, and dropped)
                _ => continue,
            }
        }
    }
}

/// The worker's side.
struct Work {
    runner: Runner,
    rx: Receiver<Cmd>,
    tx: Sender<Out>,
    need: Arc<AtomicBool>,
    epoch: u64,
    /// the next step's `seq`, and the last one the consumer has had
    seq: u64,
    had: Option<u64>,
    /// the speed stage's state after each sample of a run in progress the
    /// consumer has not passed
    snaps: VecDeque<(u64, Snapshot)>,
    /// the first sample of the last run worked out, and whether the last
    /// step was one of its samples (not its last)
    run_from: Option<u64>,
    in_run: bool,
    /// the last sample of a run that a hold may still go back into
    end: Option<u64>,
    asked: bool,
    closed: bool,
    /// nothing more comes (the last step, or an error)
    over: bool,
}

impl Work {
    fn new(runner: Runner, rx: Receiver<Cmd>, tx: Sender<Out>, need: Arc<AtomicBool>) -> Work {
        Work {
            runner,
            rx,
            tx,
            need,
            epoch: 0,
            seq: 0,
            had: None,
            snaps: VecDeque::new(),
            run_from: None,
            in_run: false,
            end: None,
            asked: false,
            closed: false,
            over: false,
        }
    }

    /// Whether the worker may work out the next step.
    fn may_go(&self) -> bool {
        let ahead = self.seq - self.had.map_or(0, |h| h + 1);
        let gate = match self.end {
            None => true,
            Some(_) => self
                .had
                .and_then(|h| self.snap(h))
                .is_some_and(Snapshot::settled),
        };
        !self.over && !self.asked && ahead < LEAD && gate
    }

    fn snap(&self, seq: u64) -> Option<&Snapshot> {
        let first = self.snaps.front()?.0;
        let i = usize::try_from(seq.checked_sub(first)?).ok()?;
        self.snaps.get(i).filter(|s| s.0 == seq).map(|s| &s.1)
    }

    fn run(mut self) {
        loop {
            let cmd = if self.may_go() {
                match self.rx.try_recv() {
                    Ok(c) => Some(c),
                    Err(TryRecvError::Empty) => None,
                    Err(TryRecvError::Disconnected) => return,
                }
            } else {
                match self.rx.recv() {
                    Ok(c) => Some(c),
                    Err(_) => return,
                }
            };
            match cmd {
                Some(c) => self.take(c),
                None => self.produce(),
            }
        }
    }

    fn take(&mut self, cmd: Cmd) {
        match cmd {
            Cmd::Events(evs, closed) => {
                for ev in evs {
                    self.runner.push(ev);
                }
                if closed {
                    self.runner.close();
                    self.closed = true;
                }
                self.asked = false;
            }
            Cmd::Had(seq) => {
                self.had = Some(seq);
                while self.snaps.front().is_some_and(|s| s.0 < seq) {
                    self.snaps.pop_front();
                }
                if self.end.is_some_and(|e| seq >= e) {
                    self.end = None;
                }
                // (the run the consumer is in keeps what going back needs)
                if self.run_from.is_some_and(|f| seq >= f) {
                    if let Some(x) = self.snap(seq).map(Snapshot::needs_from) {
                        self.runner.keep_from(x);
                    }
                }
            }
            Cmd::Scale { at, scale } => self.runner.scale_at(at, scale),
            Cmd::Hold { on, seq, scale } => {
                self.epoch += 1;
                let Some(snap) = self.snap(seq).cloned() else {
                    // (cannot be: the consumer holds only within a run)
                    self.over = true;
                    let why = "a feed hold the path planner could not go back to".into();
                    let _ = self.tx.send(Out::Failed {
                        epoch: self.epoch,
                        why,
                    });
                    return;
                };
                // (the last run worked out: the worker goes past a run only
                // once the consumer has reached a settled sample of it)
                self.runner.rewind(&snap, on, seq);
                if let Some(scale) = scale {
                    self.runner.scale_now(scale);
                }
                self.snaps.retain(|s| s.0 <= seq);
                self.seq = seq + 1;
                self.in_run = true;
                self.end = None;
                self.over = false;
            }
        }
    }

    fn produce(&mut self) {
        match self.runner.step(true) {
            Ok(Some(step)) => {
                let mut settled = false;
                if let Step::Sample { last, .. } = step {
                    if !self.in_run {
                        self.run_from = Some(self.seq);
                    }
                    self.in_run = !last;
                    if last {
                        self.end = Some(self.seq);
                    } else if let Some(s) = self.runner.snapshot() {
                        settled = s.settled();
                        self.snaps.push_back((self.seq, s));
                    }
                } else {
                    self.in_run = false;
                }
                let _ = self.tx.send(Out::Step {
                    epoch: self.epoch,
                    seq: self.seq,
                    step,
                    settled,
                });
                self.seq += 1;
            }
            Ok(None) if self.closed => {
                self.over = true;
                let _ = self.tx.send(Out::End { epoch: self.epoch });
            }
            Ok(None) => {
                self.asked = true;
                self.need.store(true, Ordering::Release);
                let _ = self.tx.send(Out::Need);
            }
            Err(why) => {
                self.over = true;
                let _ = self.tx.send(Out::Failed {
                    epoch: self.epoch,
                    why,
                });
            }
        }
    }
}
