//! The pipeline: the stages a program's canonical commands pass, in
//! order, from the interpreter to the samples, put together in one place
//! for the executor and the check alike.
//!
//! ```text
//! Interpreter ──Canon──► Front: compensate ─► (travel of the
//!   (words, modal,          compensated path) ─► blend ──► Lookahead ──► Timeline
//!    motion, loops, ...)                                   (plan.rs)     (ticks)
//! ```
//!
//! [`Front`] is the interpreter's [`Canon`]: radius compensation
//! (`comp.rs`), the travel limits of the path it makes, and corner
//! blending within the path tolerance (`blend.rs`). [`Pipeline`] adds the
//! look-ahead and the timeline for the executor; [`Estimate`] adds them
//! for the check, which needs only the profiles' durations.

use crate::blend::{Blender, StopCost};
use crate::canon::{Canon, CompMode, Event, Feed, Src};
use crate::comp::{block_name, Comp};
use crate::dialect::Dialect;
use crate::geom::{Geom, V3};
use crate::interp::{Interpreter, Modal};
use crate::jerk::JerkBudget;
use crate::limits::{MoveLimits, MovePrep};
use crate::machine::Machine;
use crate::path_run::{Ahead, RunLimits, Runner, Step};
use crate::plan::{Item, ItemSink, Lookahead, PlanLimits, Planner};
use crate::profile::Profile;
use crate::source::ProgramSource;
use crate::timeline::Timeline;
use crate::travel::{self, Travel};
use arrayvec::ArrayVec;
use std::collections::VecDeque;

/// The stages between the interpreter and the planner: compensation, the
/// travel limits of the compensated path, blending.
pub struct Front {
    comp: Comp,
    blend: Blender,
    /// the path tolerance (G64 P), mm; 0: exact path (G61)
    tolerance: f64,
    /// the jerk budget for it ([`JerkBudget::for_tolerance`])
    budget: JerkBudget,
    travel: Travel,
    /// the bounding box of the compensated moves
    bbox: Option<(V3, V3)>,
    /// the compensation's output, reused
    scratch: VecDeque<Event>,
    /// commands ready for the planner
    out: VecDeque<Event>,
    /// the path planner plans the moves (`path_run`): no corner blends
    /// (its geometry keeps within P), and every change of P handed on
    path_planner: bool,
}

impl Front {
    pub fn new(machine: &Machine) -> Self {
        // (blends keep within the tolerance less the XYZ filter's error,
        // `Machine::smoothing_error_mm`)
        let jerk = machine.jerk_budget();
        let tolerance = machine.planner.path_tolerance_mm;
        Front {
            comp: Comp::new(machine.compensation.round_outside_corners, machine.home()),
            blend: Blender::new(
                jerk.error_mm(),
                Some(StopCost {
                    jerk,
                    accel: machine.amax().min(),
                    vmax: machine.vmax().min(),
                    amax: machine.amax(),
                    vmax_axes: machine.vmax(),
                    exact_stop_cos: machine.planner.exact_stop_angle_deg.to_radians().cos(),
                }),
            ),
            tolerance,
            budget: jerk,
            travel: Travel::new(machine),
            bbox: None,
            scratch: VecDeque::new(),
            out: VecDeque::with_capacity(8),
            path_planner: machine.plans_path(),
        }
    }

    /// The bounding box of the moves the compensation made (the
    /// interpreter keeps that of the moves that passed through).
    pub fn bbox(&self) -> Option<(V3, V3)> {
        self.bbox
    }

    /// The last stage: corner blending within the path tolerance.
    #[inline]
    fn pass(&mut self, ev: Event) {
        if self.path_planner {
            self.out.push_back(ev);
            return;
        }
        if self.tolerance > 0.0 || self.blend.holds() {
            self.blend.push(ev, self.tolerance, &mut self.out);
        } else {
            self.out.push_back(ev);
        }
        if let Event::Tolerance { mm } = ev {
            // (the blends before it have been passed on)
            self.blend.follow_tolerance(mm);
        }
    }
}

impl Canon for Front {
    #[inline]
    fn command(&mut self, ev: Event, errors: &mut Vec<String>) {
        if self.comp.idle() {
            self.comp.passed(&ev);
            self.pass(ev);
            return;
        }
        let mut comped = std::mem::take(&mut self.scratch);
        self.comp.push(ev, &mut comped, errors);
        // the commanded (compensated) path: travel limits and bounding box
        for ev in &comped {
            let (geom, src) = match *ev {
                Event::Move { geom, src, .. } => (geom, src),
                // a thread moved by the geometry offset: its extent
                Event::Thread(m) => (
                    Geom::Line {
                        start: m.seg.start,
                        end: m.seg.prog_end,
                    },
                    m.src,
                ),
                _ => continue,
            };
            let (mut lo, mut hi) = geom.bbox();
            if let Event::Thread(m) = *ev {
                lo = lo.inf(&m.seg.end);
                hi = hi.sup(&m.seg.end);
            }
            for i in 0..3 {
                if let Some((_, text)) = self.travel.exceeded(i, geom.start()[i], lo[i], hi[i]) {
                    errors.push(format!(
                        "travel limit: with radius compensation the path of block {} reaches {text}",
                        block_name(src)
                    ));
                }
            }
            travel::grow(&mut self.bbox, lo, hi);
        }
        for ev in comped.drain(..) {
            self.pass(ev);
        }
        self.scratch = comped;
    }

    fn set_compensation(&mut self, mode: Option<CompMode>, _at: Src) {
        self.comp.set_mode(mode);
    }

    fn set_tool_offset(&mut self, offset: V3) {
        self.comp.set_geometry_offset(offset);
    }

    fn set_path_tolerance(&mut self, mm: f64) {
        if self.path_planner {
            // (the path planner's runs end where P changes; G61 and a P
            // under 1 µm are P 1 µm there, `path_run::P_MIN`)
            let mm = mm.max(crate::path_run::P_MIN);
            if mm != self.tolerance.max(crate::path_run::P_MIN) {
                self.tolerance = mm;
                let mut errors = Vec::new();
                self.command(Event::Tolerance { mm }, &mut errors);
                debug_assert!(errors.is_empty());
            }
            return;
        }
        self.tolerance = mm;
        // the jerk filters follow the tolerance: where their budget
        // changes, every stage behind changes it at an exact stop
        let budget = self.budget.for_tolerance(mm);
        if budget != self.budget {
            self.budget = budget;
            let mut errors = Vec::new();
            self.command(Event::Tolerance { mm }, &mut errors);
            debug_assert!(errors.is_empty());
        }
    }

    fn compensating(&self) -> bool {
        self.comp.active()
    }

    #[inline]
    fn passes_through(&self) -> bool {
        self.comp.idle()
    }

    #[inline]
    fn ready(&self) -> usize {
        self.out.len()
    }

    #[inline]
    fn pop(&mut self) -> Option<Event> {
        self.out.pop_front()
    }

    fn take(&mut self, batch: &mut VecDeque<Event>) {
        batch.clear();
        std::mem::swap(&mut self.out, batch);
    }
}

/// What a [`Watched`] front shows: every command as the interpreter hands
/// it on (before compensation) and the settings, as they come. For tools
/// that read a program's commands as programmed beside the commanded path
/// (plots, recordings' programmed path).
pub trait Watcher {
    /// A command, before compensation and blending.
    fn command(&mut self, _cmd: &Event) {}
    /// G40 (`None`), G41/G42, programmed by block `at`.
    fn compensation(&mut self, _mode: Option<CompMode>, _at: Src) {}
    /// The selected tool's geometry offset.
    fn tool_offset(&mut self, _offset: V3) {}
}

/// The pipeline's front stages with a [`Watcher`] looking at what goes in.
pub struct Watched<W> {
    pub front: Front,
    pub watcher: W,
}

impl<W: Watcher> Canon for Watched<W> {
    fn command(&mut self, cmd: Event, errors: &mut Vec<String>) {
        self.watcher.command(&cmd);
        self.front.command(cmd, errors);
    }
    fn set_compensation(&mut self, mode: Option<CompMode>, at: Src) {
        self.watcher.compensation(mode, at);
        self.front.set_compensation(mode, at);
    }
    fn set_tool_offset(&mut self, offset: V3) {
        self.watcher.tool_offset(offset);
        self.front.set_tool_offset(offset);
    }
    fn set_path_tolerance(&mut self, mm: f64) {
        self.front.set_path_tolerance(mm);
    }
    fn compensating(&self) -> bool {
        self.front.compensating()
    }
    fn passes_through(&self) -> bool {
        self.front.passes_through()
    }
    fn ready(&self) -> usize {
        self.front.ready()
    }
    fn pop(&mut self) -> Option<Event> {
        self.front.pop()
    }
    fn take(&mut self, batch: &mut VecDeque<Event>) {
        self.front.take(batch)
    }
}

impl<S: ProgramSource, W: Watcher> Interpreter<S, Watched<W>> {
    /// An interpreter whose commands pass compensation and blending, with
    /// `watcher` shown each as it goes in.
    pub fn watched(src: S, dialect: Dialect, machine: &Machine, watcher: W) -> Self {
        let front = Front::new(machine);
        Interpreter::with_canon(src, dialect, machine, Watched { front, watcher })
    }

    /// The watcher.
    pub fn watcher(&self) -> &W {
        &self.canon().watcher
    }
}

impl<S: ProgramSource> Interpreter<S, Front> {
    /// An interpreter whose commands pass compensation and blending: what
    /// the planner is fed. Iterate it for the planner's events.
    pub fn new(src: S, dialect: Dialect, machine: &Machine) -> Self {
        Interpreter::with_canon(src, dialect, machine, Front::new(machine))
    }

    /// The bounding box of the path as commanded (programmed moves and
    /// compensated ones).
    pub fn path_bbox(&self) -> Option<(V3, V3)> {
        let mut b = self.bbox();
        if let Some((lo, hi)) = self.canon().bbox() {
            travel::grow(&mut b, lo, hi);
        }
        b
    }
}

/// The executor's pipeline: the interpreter with its front stages, the
/// look-ahead, and the timeline that puts planned items on sample ticks.
pub struct Pipeline<S> {
    interp: Interpreter<S, Front>,
    planner: Planner,
    /// the path planner, on a machine that plans with it
    runner: Option<Runs>,
    /// shared with the sampling (stops, dwells and threads on ticks)
    pub timeline: Timeline,
}

/// The path planner on this thread, or on its own ahead of it.
enum Runs {
    Here(Box<Runner>),
    Ahead(Ahead),
}

impl<S: ProgramSource> Pipeline<S> {
    pub fn new(source: S, dialect: Dialect, machine: &Machine) -> Self {
        let lim = PlanLimits::from_machine(machine);
        let runner = RunLimits::for_machine(machine)
            .map(|l| Runs::Here(Box::new(Runner::new(l, machine.planner.path_tolerance_mm))));
        Pipeline {
            interp: Interpreter::new(source, dialect, machine),
            planner: Planner::new(lim),
            timeline: timeline_for(&lim, runner.is_some()),
            runner,
        }
    }

    /// With the path planner: plans on a thread of its own, ahead of the
    /// samples (`path_run::Ahead`: the same samples, feed holds included),
    /// and smooths the geometry on another; before the first step. Each
    /// thread first calls `on_start`. Without threads, nothing changes.
    pub fn plan_ahead(&mut self, on_start: fn()) {
        if let Some(Runs::Here(mut r)) = self.runner.take() {
            r.work_ahead(on_start);
            self.runner = Some(match Ahead::spawn(*r, on_start) {
                Ok(a) => Runs::Ahead(a),
                Err(r) => Runs::Here(r),
            });
        }
    }

    /// Whether the path planner plans the moves ([`Pipeline::path_step`]
    /// instead of [`Pipeline::next_item`]).
    pub fn path_planner(&self) -> bool {
        self.runner.is_some()
    }

    /// With the path planner: a feed hold (`on`) of the run in progress,
    /// or its end.
    pub fn path_hold(&mut self, on: bool) {
        match self.runner.as_mut() {
            Some(Runs::Here(r)) => r.hold(on),
            Some(Runs::Ahead(a)) => a.hold(on),
            None => {}
        }
    }

    /// With the path planner: the feed override (`path_run::scale`: from
    /// 0.1 s on).
    pub fn path_scale(&mut self, scale: f64) {
        match self.runner.as_mut() {
            Some(Runs::Here(r)) => r.set_scale(scale),
            Some(Runs::Ahead(a)) => a.set_scale(scale),
            None => {}
        }
    }

    /// With the path planner: the end of a feed hold, with the override
    /// `scale` (at once for a run that stands held; `Runner::resume`).
    pub fn path_resume(&mut self, scale: f64) {
        match self.runner.as_mut() {
            Some(Runs::Here(r)) => r.resume(scale),
            Some(Runs::Ahead(a)) => a.resume(scale),
            None => {}
        }
    }

    /// With the path planner: whether no run is in progress (the machine
    /// stands between two runs).
    pub fn path_idle(&self) -> bool {
        match self.runner.as_ref() {
            Some(Runs::Here(r)) => r.idle(),
            Some(Runs::Ahead(a)) => a.idle(),
            None => false,
        }
    }

    /// With the path planner: the next sample or planned item, pulling
    /// commands through as the runs need them; `None` after the last.
    pub fn path_step(&mut self) -> Result<Option<Step>, String> {
        let interp = &mut self.interp;
        let runner = match self.runner.as_mut() {
            Some(Runs::Here(r)) => r,
            Some(Runs::Ahead(a)) => return a.step(&mut || interp.next()),
            None => return Err("the machine does not plan with the path planner".into()),
        };
        loop {
            if let Some(step) = runner.step(true)? {
                return Ok(Some(step));
            }
            if runner.closed() {
                return Ok(None);
            }
            match interp.next() {
                Some(ev) => runner.push(ev),
                None => runner.close(),
            }
        }
    }

    /// The next planned item, pulling commands through as the look-ahead
    /// needs them.
    pub fn next_item(&mut self) -> Option<Item> {
        loop {
            if let Some(i) = self.planner.pop() {
                return Some(i);
            }
            match self.interp.next() {
                Some(ev) => self.planner.push(ev),
                None => {
                    self.planner.flush();
                    return self.planner.pop();
                }
            }
        }
    }

    /// The interpreter's modal state (it runs ahead of the samples by the
    /// look-ahead window).
    pub fn modal(&self) -> &Modal {
        &self.interp.modal
    }

    /// Errors the interpreter met (none for a checked program).
    pub fn error_count(&self) -> usize {
        self.interp.error_count()
    }
}

/// The timeline of a planner with these limits; the path planner's has no
/// hold after a stop (no filter settles).
fn timeline_for(lim: &PlanLimits, path_planner: bool) -> Timeline {
    let mut tl = Timeline::for_limits(lim);
    if path_planner {
        tl.set_hold(0);
    }
    tl
}

/// The check's half of the pipeline after the interpreter: look-ahead and
/// timeline, fed events in program order, adding up the profiles'
/// durations (nothing is sampled). With the path planner, its runs
/// planned as the executor plans them, their samples counted.
pub(crate) struct Estimate {
    look: Lookahead<()>,
    sink: Settle,
    runner: Option<Runner>,
    /// the run in progress's samples so far
    run_ticks: u64,
    /// why the path planner could not plan the program, and at which line
    failed: Option<(u32, String)>,
}

/// Most moves whose profiles wait in [`Settle`].
const WAITING: usize = 16;

/// The check's sink: the moves' profiles are computed a few at a time,
/// then added up in order. (Each one is a chain of square roots and
/// divisions, independent of the others: side by side they overlap,
/// which they do not with the planning of every move between them.)
struct Settle {
    totals: Totals,
    /// (v0, v1, speed cap, acceleration, length, own path filter) of
    /// the moves waiting
    waiting: ArrayVec<([f64; 5], u32), WAITING>,
}

impl Settle {
    /// Adds up the moves waiting.
    #[inline]
    fn settle(&mut self) {
        for &([v0, v1, vcap, a, length], own_m) in &self.waiting {
            let mut p = Profile::new(v0, v1, vcap, a, length);
            p.own_m = own_m;
            self.totals.planned((), p);
        }
        self.waiting.clear();
    }
}

impl ItemSink for Settle {
    /// only the profile counts: the queue keeps nothing else of a move
    type Kept = ();
    /// only the durations count
    const VLIM: bool = false;
    #[inline]
    fn keep(_: &Geom, _: Feed, _: Src) {}
    #[inline]
    fn planned(&mut self, (): (), profile: Profile) {
        self.settle();
        self.totals.planned((), profile);
    }
    /// (only the duration counts: neither the speed limit over the feed
    /// nor `a_join`)
    #[inline]
    fn plan(&mut self, (): (), v0: f64, v1: f64, lim: MoveLimits, length: f64, _: f64) {
        if self.waiting.is_full() {
            self.settle();
        }
        self.waiting
            .push(([v0, v1, lim.vcap, lim.a, length], lim.own_m));
    }
    #[inline]
    fn item(&mut self, item: Item) {
        self.settle();
        self.totals.item(item);
    }
}

/// What the planned items add up to.
pub(crate) struct Totals {
    pub(crate) tl: Timeline,
    pub(crate) moves: u64,
    pub(crate) ended: bool,
    /// why the path planner could not plan the program, and at which line
    pub(crate) path_error: Option<(u32, String)>,
}

impl Totals {
    #[inline]
    fn planned(&mut self, (): (), profile: Profile) {
        self.moves += 1;
        self.tl.finish_profile(&profile);
    }

    #[inline]
    fn item(&mut self, item: Item) {
        match item {
            // (moves come to `planned`)
            Item::Move(m) => self.planned((), m.profile),
            Item::Dwell { seconds, .. } => self.tl.finish_dwell(seconds),
            Item::End { .. } => self.ended = true,
            Item::Spindle { rpm, .. } => self.tl.set_spindle(rpm),
            Item::Thread(m) => {
                self.moves += 1;
                self.tl.finish_thread(&m);
            }
            Item::Tool { .. } => {}
            Item::Smoothing(b) => self.tl.set_hold(b.hold_ticks()),
        }
    }
}

impl Estimate {
    /// `path`: the path planner's limits and the path tolerance at the
    /// start, on a machine that plans with it.
    pub(crate) fn new(lim: PlanLimits, path: Option<(RunLimits, f64)>) -> Self {
        Estimate {
            look: Lookahead::new(lim),
            sink: Settle {
                totals: Totals {
                    tl: timeline_for(&lim, path.is_some()),
                    moves: 0,
                    ended: false,
                    path_error: None,
                },
                waiting: ArrayVec::new(),
            },
            runner: path.map(|(l, tol)| Runner::new(l, tol)),
            run_ticks: 0,
            failed: None,
        }
    }

    /// With the path planner: what the runner has for the commands so far.
    fn drain_runs(&mut self) {
        let Some(runner) = self.runner.as_mut() else {
            return;
        };
        while self.failed.is_none() && !self.sink.totals.ended {
            match runner.step(false) {
                Ok(Some(Step::Sample { last, .. })) => {
                    if last {
                        let tl = &mut self.sink.totals.tl;
                        tl.finish_group_at(tl.group_k0.saturating_add(self.run_ticks));
                        self.run_ticks = 0;
                    } else {
                        self.run_ticks += 1;
                    }
                }
                Ok(Some(Step::Item(item))) => self.sink.totals.item(item),
                Ok(None) => return,
                Err(e) => self.failed = Some((runner.line(), e)),
            }
        }
    }

    /// Plans a batch of events; nothing after the end counts. `preps`:
    /// what [`PlanLimits::prepare`] makes of the moves among them, in
    /// order, as far as it has been computed already.
    pub(crate) fn run(&mut self, events: &VecDeque<Event>, preps: &[MovePrep]) {
        if let Some(runner) = self.runner.as_mut() {
            for ev in events {
                runner.push(*ev);
            }
            self.drain_runs();
            return;
        }
        let mut preps = preps.iter();
        for ev in events {
            if self.sink.totals.ended {
                return;
            }
            let prep = match ev {
                Event::Move { .. } => preps.next(),
                _ => None,
            };
            self.look.push(ev, prep, &mut self.sink);
        }
    }

    /// After the last event: plans what is left (the interpreter always
    /// ends with an `End` event, so this is a safeguard).
    pub(crate) fn finish(mut self) -> Totals {
        if let Some(runner) = self.runner.as_mut() {
            runner.close();
            self.drain_runs();
            let moves = self.runner.as_ref().map_or(0, Runner::moves);
            let mut totals = self.sink.totals;
            totals.moves = moves;
            totals.path_error = self.failed;
            return totals;
        }
        if !self.sink.totals.ended {
            self.look.flush(&mut self.sink);
        }
        self.sink.settle();
        // (moves as they came in, not the pieces of split lines)
        self.sink.totals.moves -= self.look.extra.min(self.sink.totals.moves);
        self.sink.totals
    }
}
