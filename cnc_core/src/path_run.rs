//! The path planner (`[planner] method = "path"`): the canonical moves
//! between rests become runs, each planned by the geometry stage
//! (`path_smooth`) and the speed stage (`path_speed`) as its moves come,
//! one path position per sample. No setpoint filter follows: every
//! sample keeps each axis's velocity, acceleration and jerk, and the
//! smoothed path stays within the path tolerance P.
//!
//! **Runs.** A rapid is a run of its own: its path is the move as
//! programmed (`Run::exact`). G61 (an exact path) and a P under `P_MIN`
//! run as P = `P_MIN`, 1 µm, the deviation the filters allow an exact
//! path too (`shares::XYZ_FILTER_ERROR_MM`): a CAM polyline's fine kinks
//! are passed within it instead of at rest, and a corner turning by more
//! than about 4.6° stops exactly on its vertex (below). A corner that turns so
//! sharply that its blend within P would be narrower than `W_MIN` (0.1
//! mm) ends a run too: the machine stops exactly on it. Feed moves under G64 P run together (`Run::smooth`)
//! until something that is not a feed move comes (a rapid, a dwell, a
//! spindle or tool command, a thread, a change of P or of G94/G95, the end); the run
//! ends at rest on the last move's end. Its moves reach the geometry as
//! points: a line as its ends and a point 4 µm inside each (the feed is
//! the move's there), an arc or a helix as points at most 4 µm apart; a
//! point between two moves takes the slower feed. The averages' shrink
//! of curves is always made up (`twice`).
//!
//! **Samples.** A run of N samples (the first at its start, the last at
//! rest on its end) takes N − 1 ticks: its last sample is the first of
//! whatever follows, as a stop is with the look-ahead's planner. The check
//! runs the same runs and counts their samples, so the estimate is the
//! run to the tick.
//!
//! [`Runner`] turns the canonical commands into runs and the planned items
//! that lie between them (dwells, spindle and tool commands, threads, the
//! end).

mod ahead;
mod exact;
mod limits;
mod scale;
pub use ahead::Ahead;
use exact::exact_station;
pub use limits::RunLimits;

use crate::canon::{Event, Feed, Src};
use crate::geom::{Geom, V3};
use crate::path_smooth::{Stream, Worker, DS};
use crate::path_speed::{Path, Planner, Snapshot, Station};
use crate::plan::Item;
use std::collections::VecDeque;

/// A rapid's feed: the axes' speed limits alone, mm/s.
pub const NO_FEED: f64 = 1e9;
/// Station spacing, mm: the geometry's grid, so that a narrow blend is
/// seen.
const H: f64 = DS;
/// Each chunk of the geometry, and the run either side of it, mm (at P
/// 0.01, 20 mm either side already give the whole run's path within 1
/// nm; at P 0.001 the chunks differ by about a micron and fade into each
/// other over 8 mm, `path_smooth::Stream`).
const CHUNK: f64 = 40.0;
const MARGIN: f64 = 30.0;
/// With a worker for the geometry, how far the moves are taken in ahead
/// of the samples, mm: each chunk is handed over about a second before
/// the speed stage reaches it at 100 mm/s.
const AHEAD: f64 = 4.0 * CHUNK;
/// With a worker, how far past the last sample the speed stage has its
/// stations, mm.
const LEAD: f64 = 20.0;
/// Stations handed to the speed stage at once on an exact run.
const BATCH: usize = 256;
/// The smallest path tolerance the runs are smoothed within, mm: that of
/// an exact path (G61, and any P under it), the 1 µm the filters keep
/// there too (`shares::XYZ_FILTER_ERROR_MM`); the 4 µm grid resolves
/// no narrower blends.
pub const P_MIN: f64 = 0.001;
/// Moves shorter than this are left out, mm.
const TINY: f64 = 1e-9;
/// The narrowest corner blend the geometry's grid resolves, mm: a corner
/// whose blend within P would be narrower is an exact stop instead (the
/// average at a corner turning by θ leaves it by about w sin(θ/2) / 4).
const W_MIN: f64 = 0.1;
/// A corner that turns back by more than about 135° (its cosine under
/// this) is an exact stop whatever P: its blend would be a hairpin.
const HAIRPIN_COS: f64 = -0.7;
/// The run's path.
enum Shape {
    /// One move as programmed; the next station's index.
    Exact { geom: Geom, feed: f64, next: usize },
    /// Feed moves smoothed within P; the point between the last move and
    /// the next (its feed: the last move's, until the next one's is known).
    Smooth {
        geo: Box<Stream>,
        pending: Option<([f64; 3], f64)>,
    },
}

/// What a run has next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Next {
    /// The path position of the next sample, mm from the run's start;
    /// `last`: at rest on the run's end.
    At { x: f64, last: bool },
    /// The speed stage needs the next move (a smooth run not ended).
    More,
}

/// One run from rest to rest.
pub struct Run {
    shape: Shape,
    speed: Planner,
    /// the moves' places on the programmed path (start, block), the first
    /// the one being run
    moves: VecDeque<(f64, Src)>,
    /// G95: the programmed spindle speed (a run is all G95 or none)
    rpm: Option<f64>,
    /// the programmed length so far
    len: f64,
    /// where the run starts, and where its last move so far ends, and its
    /// direction there
    start: V3,
    end: V3,
    end_tangent: V3,
    /// the path tolerance of a smooth run, mm
    tol: f64,
    /// no move is to come
    ended: bool,
    /// the last sample's path position, and where what a rewind needs
    /// starts (`keep_from`)
    at: f64,
    keep: f64,
    /// the move being run (in `moves`)
    mv: usize,
    scratch: Vec<Station>,
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// A move's speed, mm/s (a rapid's: none but the axes').
fn feed_mm_s(feed: Feed) -> f64 {
    match feed {
        Feed::Rapid => NO_FEED,
        f => f.speed_mm_s().min(NO_FEED),
    }
}

impl Run {
    /// A run of one move as programmed (a rapid, or a move under G61).
    pub fn exact(geom: Geom, feed: Feed, src: Src, lim: &RunLimits) -> Result<Run, String> {
        let mut run = Run::new(
            Shape::Exact {
                geom,
                feed: feed_mm_s(feed),
                next: 0,
            },
            lim,
        )?;
        run.moves.push_back((0.0, src));
        run.rpm = per_rev(feed);
        run.len = geom.length();
        run.start = geom.start();
        run.end = geom.end();
        run.ended = true;
        Ok(run)
    }

    /// A run of feed moves smoothed within `tol` mm; its moves come with
    /// [`Run::add`].
    pub fn smooth(tol: f64, lim: &RunLimits) -> Result<Run, String> {
        let geo = Stream::new(tol, true, CHUNK, MARGIN, H).map_err(err)?;
        let mut run = Run::new(
            Shape::Smooth {
                geo: Box::new(geo),
                pending: None,
            },
            lim,
        )?;
        run.tol = tol;
        Ok(run)
    }

    /// Whether `geom` turns from the run's last move so sharply that its
    /// blend within P would be narrower than the grid resolves: the run
    /// ends at rest on the corner instead.
    pub fn corner_stops(&self, geom: &Geom) -> bool {
        if self.moves.is_empty() || self.ended {
            return false;
        }
        let c = self.end_tangent.dot(&geom.start_tangent()).clamp(-1.0, 1.0);
        let half_sin = (0.5 * (1.0 - c)).sqrt();
        c < HAIRPIN_COS || 4.0 * self.tol < W_MIN * half_sin
    }

    fn new(shape: Shape, lim: &RunLimits) -> Result<Run, String> {
        let mut speed = Planner::new(Path::open(H).map_err(err)?, lim.axes, lim.dt).map_err(err)?;
        speed.check_samples(lim.machine);
        speed.limit_normal_accel(lim.normal_a);
        Ok(Run {
            shape,
            speed,
            moves: VecDeque::new(),
            rpm: None,
            len: 0.0,
            start: V3::zeros(),
            end: V3::zeros(),
            end_tangent: V3::zeros(),
            tol: 0.0,
            ended: false,
            at: 0.0,
            keep: f64::INFINITY,
            mv: 0,
            scratch: Vec::new(),
        })
    }

    /// Hands the geometry's chunks to `worker` (a smooth run).
    fn work_ahead(&mut self, worker: &Worker) {
        if let Shape::Smooth { geo, .. } = &mut self.shape {
            geo.work_ahead(worker);
        }
    }

    /// Whether the run takes more moves, and has fewer than `AHEAD` mm of
    /// them past its last sample.
    fn wants_moves(&self) -> bool {
        !self.ended && self.len < self.at + AHEAD
    }

    /// The next feed move of a smooth run.
    pub fn add(&mut self, geom: &Geom, feed: Feed, src: Src) -> Result<(), String> {
        let Shape::Smooth { geo, pending } = &mut self.shape else {
            return Err("a move added to a run of one move".into());
        };
        if self.ended {
            return Err("a move added to a run that has ended".into());
        }
        let f = feed_mm_s(feed);
        let l = geom.length();
        let a = |v: V3| [v[0], v[1], v[2]];
        match pending.take() {
            Some((p, fp)) => geo.push(p, fp.min(f)).map_err(err)?,
            None => geo.push(a(geom.start()), f).map_err(err)?,
        }
        match geom {
            Geom::Line { start, end } => {
                if l > 2.0 * DS {
                    let u = (end - start) / l;
                    geo.push(a(start + u * DS), f).map_err(err)?;
                    geo.push(a(end - u * DS), f).map_err(err)?;
                }
            }
            Geom::Arc(_) => {
                let n = (l / DS).ceil().max(1.0) as usize;
                for i in 1..n {
                    geo.push(a(geom.eval(l * i as f64 / n as f64)), f)
                        .map_err(err)?;
                }
            }
        }
        *pending = Some((a(geom.end()), f));
        geo.hand_over().map_err(err)?;
        if self.moves.is_empty() {
            self.start = geom.start();
            self.rpm = per_rev(feed);
        }
        self.end = geom.end();
        self.end_tangent = geom.end_tangent();
        self.moves.push_back((self.len, src));
        self.len += l;
        Ok(())
    }

    /// No more moves join the run: it ends at rest on the last one's end.
    pub fn end(&mut self) -> Result<(), String> {
        if self.ended {
            return Ok(());
        }
        self.ended = true;
        if let Shape::Smooth { geo, pending } = &mut self.shape {
            if let Some((p, f)) = pending.take() {
                geo.push(p, f).map_err(err)?;
            }
            geo.finish().map_err(err)?;
            geo.hand_over().map_err(err)?;
        }
        Ok(())
    }

    /// With a worker for the geometry: hands the speed stage a slice of
    /// stations it has ready while they reach less than `LEAD` past the
    /// last sample (a decision cut short for want of stations starts
    /// again).
    fn top_up(&mut self) -> Result<(), String> {
        let Shape::Smooth { geo, .. } = &self.shape else {
            return Ok(());
        };
        if geo.len().is_none() && self.speed.path().known() < self.at + LEAD {
            self.smooth_stations(false)?;
        }
        Ok(())
    }

    /// Hands the speed stage what stations the path has; whether any came.
    fn feed_stations(&mut self) -> Result<bool, String> {
        match &mut self.shape {
            Shape::Exact { geom, feed, next } => {
                let len = geom.length();
                let n = (len / H).ceil() as usize + 1;
                let upto = (*next + BATCH).min(n);
                for i in *next..upto {
                    let x = (i as f64 * H).min(len);
                    self.speed
                        .push(exact_station(geom, x, *feed))
                        .map_err(err)?;
                }
                let more = upto > *next;
                *next = upto;
                if upto == n && more {
                    self.speed.finish(len).map_err(err)?;
                }
                Ok(more)
            }
            Shape::Smooth { .. } => self.smooth_stations(true),
        }
    }

    /// A smooth run's stations to the speed stage: (`wait`) up to `LEAD`
    /// past the last sample, waiting for the geometry's worker if it must
    /// (a decision cut short for want of stations starts again), or a
    /// slice the worker has ready; and the run's end once the geometry
    /// has it. Whether any came.
    fn smooth_stations(&mut self, wait: bool) -> Result<bool, String> {
        let Shape::Smooth { geo, .. } = &mut self.shape else {
            return Ok(false);
        };
        let had = geo.len().is_some();
        let mut more = false;
        loop {
            if wait {
                geo.advance(&mut self.scratch).map_err(err)?;
            } else {
                geo.advance_ready(&mut self.scratch).map_err(err)?;
            }
            let got = !self.scratch.is_empty();
            more |= got;
            for st in self.scratch.drain(..) {
                self.speed.push(st).map_err(err)?;
            }
            if !wait || !got || geo.len().is_some() || self.speed.path().known() >= self.at + LEAD {
                break;
            }
        }
        if let (false, Some(len)) = (had, geo.len()) {
            self.speed.finish(len).map_err(err)?;
            return Ok(true);
        }
        Ok(more)
    }

    /// The next sample's path position, or `More` when a smooth run needs
    /// its next move (or its end).
    pub fn sample(&mut self) -> Result<Next, String> {
        loop {
            let next = {
                let Run { shape, speed, .. } = &mut *self;
                speed
                    .next_sample_on(&|x| Run::point_of(shape, x).into())
                    .map_err(err)?
            };
            if let Some(x) = next {
                self.at = x;
                self.top_up()?;
                if let Shape::Smooth { geo, .. } = &mut self.shape {
                    // (what lies behind the sample before this one: the
                    // caller may still want its point)
                    geo.forget_before(x.min(self.keep) - 2.0 * H);
                }
                return Ok(Next::At {
                    x,
                    last: self.speed.over(),
                });
            }
            if self.speed.over() {
                return Err("a sample asked of a run that is over".into());
            }
            if !self.feed_stations()? {
                if self.ended {
                    return Err("the speed stage stopped short of the run's end".into());
                }
                return Ok(Next::More);
            }
        }
    }

    /// A feed hold (`on`: the run brakes from its last sample to rest and
    /// stands) or its end (it goes on from there).
    pub fn hold(&mut self, on: bool) {
        if on == self.speed.held() {
            return;
        }
        if on {
            let Run { shape, speed, .. } = self;
            speed.hold(Some(&|x| Run::point_of(shape, x).into()));
        } else {
            self.speed.resume();
        }
    }

    /// The point at path position `x` (of the last sample or later): the
    /// run's ends exactly as programmed.
    pub fn point(&self, x: f64) -> V3 {
        if let Shape::Smooth { geo, .. } = &self.shape {
            if x <= 0.0 {
                return self.start;
            }
            if geo.len().is_some_and(|len| x >= len) {
                return self.end;
            }
        }
        Run::point_of(&self.shape, x)
    }

    /// The point at `x` on the run's path (its ends as the geometry has
    /// them).
    fn point_of(shape: &Shape, x: f64) -> V3 {
        match shape {
            Shape::Exact { geom, .. } => geom.eval(x),
            Shape::Smooth { geo, .. } => match geo.point(x) {
                Some(p) => V3::new(p[0], p[1], p[2]),
                None => V3::new(f64::NAN, f64::NAN, f64::NAN),
            },
        }
    }

    /// The block being run at path position `x` (on the programmed path's
    /// count: a corner's cut shortens it by microns).
    pub fn src_at(&mut self, x: f64) -> Src {
        while self.mv > 0 && self.moves[self.mv].0 > x {
            self.mv -= 1;
        }
        while self.mv + 1 < self.moves.len() && self.moves[self.mv + 1].0 <= x {
            self.mv += 1;
        }
        // (the moves behind both the sample and what a rewind needs go)
        let keep = x.min(self.keep);
        while self.mv > 0 && self.moves[1].0 <= keep {
            self.moves.pop_front();
            self.mv -= 1;
        }
        self.moves.get(self.mv).map_or(Src::default(), |m| m.1)
    }

    /// Keeps what going back to a sample at or after path position `x`
    /// needs (`Snapshot::needs_from`).
    pub fn keep_from(&mut self, x: f64) {
        self.keep = x;
        self.speed.keep_from(Some(x));
    }

    /// The speed stage's state after the last sample.
    pub fn snapshot(&self) -> Snapshot {
        self.speed.snapshot()
    }

    /// Goes back to `snap` (kept for: `keep_from`).
    pub fn restore(&mut self, snap: &Snapshot) {
        self.speed.restore(snap);
    }
}

/// What the runner hands on next.
// one value at a time: boxing the item would only add an allocation
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum Step {
    /// A sample of the run in progress: its path position, the point, the
    /// block; `last`: at rest on the run's end (the first sample of what
    /// follows, not one of the run's ticks).
    Sample {
        x: f64,
        pos: V3,
        src: Src,
        last: bool,
        /// G95: the programmed spindle speed, rpm
        rpm: Option<f64>,
    },
    /// A planned item between runs.
    Item(Item),
}

/// Turns the canonical commands into runs and the items between them:
/// commands go in with [`Runner::push`] (and [`Runner::close`] after the
/// last), samples and items come out of [`Runner::step`].
pub struct Runner {
    lim: RunLimits,
    /// the path tolerance (G64 P) in force, mm, at least `P_MIN` (G61:
    /// `P_MIN`)
    tol: f64,
    run: Option<Run>,
    /// with a worker: the run after this one, its moves taken in ahead
    next: Option<Run>,
    /// the run whose last sample was the last step (for `rewind`)
    done: Option<Run>,
    /// every run keeps what a rewind needs (`keep_for_rewind`)
    rewinds: bool,
    /// the feed override, and the steps handed out
    over: scale::Override,
    /// the geometry's own thread (`work_ahead`)
    worker: Option<Worker>,
    /// commands not taken yet
    queue: VecDeque<Event>,
    /// no command is to come
    closed: bool,
    /// moves taken
    moves: u64,
    /// the line of the last command taken
    line: u32,
}

impl Runner {
    pub fn new(lim: RunLimits, tolerance: f64) -> Runner {
        Runner {
            lim,
            tol: tolerance.max(P_MIN),
            run: None,
            next: None,
            done: None,
            rewinds: false,
            over: scale::Override::default(),
            worker: None,
            queue: VecDeque::new(),
            closed: false,
            moves: 0,
            line: 0,
        }
    }

    /// Smooths the geometry on a thread of its own (which first calls
    /// `on_start`) from the next run on, the same samples, and takes the
    /// moves in `AHEAD` of the samples, the next run's as the last one
    /// ends. Without a thread (it cannot be started) nothing changes.
    pub fn work_ahead(&mut self, on_start: fn()) {
        if self.worker.is_none() {
            self.worker = Worker::spawn(on_start);
        }
    }

    /// Every run from the next on keeps what going back to any of its
    /// samples needs, until told what it may forget (`keep_from`): for a
    /// runner working ahead of the samples' consumer (`ahead`).
    pub fn keep_for_rewind(&mut self) {
        self.rewinds = true;
    }

    /// The run in progress keeps what going back to a sample at or after
    /// path position `x` needs.
    pub fn keep_from(&mut self, x: f64) {
        if let Some(run) = self.run.as_mut().or(self.done.as_mut()) {
            run.keep_from(x);
        }
    }

    /// The speed stage's state after the last sample, if it was one of a
    /// run in progress (not its last).
    pub fn snapshot(&self) -> Option<Snapshot> {
        self.run.as_ref().map(Run::snapshot)
    }

    /// Goes back to `snap`, taken of the run in progress (or of the one
    /// whose last sample was the last step), and holds it (`on`) or ends
    /// its hold there, as `hold` at that sample would have.
    /// `seq`: the step it was taken after.
    pub fn rewind(&mut self, snap: &Snapshot, on: bool, seq: u64) {
        if self.run.is_none() {
            self.run = self.done.take();
        }
        self.rewind_scale(seq);
        if let Some(run) = self.run.as_mut() {
            run.restore(snap);
            run.hold(on);
        }
    }

    /// The line of the last command taken (where an error is reported).
    pub fn line(&self) -> u32 {
        self.line
    }

    /// The next command.
    pub fn push(&mut self, ev: Event) {
        self.queue.push_back(ev);
    }

    /// No command is to come.
    pub fn close(&mut self) {
        self.closed = true;
    }

    /// Whether no command is to come.
    pub fn closed(&self) -> bool {
        self.closed
    }

    /// A feed hold (`on`) of the run in progress, or its end.
    pub fn hold(&mut self, on: bool) {
        if let Some(run) = self.run.as_mut() {
            run.hold(on);
        }
    }

    /// Whether no run is in progress.
    pub fn idle(&self) -> bool {
        self.run.is_none()
    }

    /// A move taken: a run of `geom` starting from rest, or `None` for a
    /// move too short to count.
    fn start(&mut self, geom: Geom, feed: Feed, src: Src) -> Result<Option<Run>, String> {
        self.moves += 1;
        self.line = src.line;
        if geom.length() <= TINY {
            return Ok(None);
        }
        let mut run = if feed == Feed::Rapid {
            Run::exact(geom, feed, src, &self.lim)?
        } else {
            let mut r = Run::smooth(self.tol, &self.lim)?;
            if let Some(w) = &self.worker {
                r.work_ahead(w);
            }
            r.add(&geom, feed, src)?;
            r
        };
        if self.rewinds {
            run.keep_from(0.0);
        }
        run.speed.set_scale(self.over.scale);
        Ok(Some(run))
    }

    /// With a worker: takes the commands in as far ahead as the runs want
    /// them; `false` if it needs the next command first.
    fn fill(&mut self) -> Result<bool, String> {
        if self.worker.is_none() {
            return Ok(true);
        }
        loop {
            let closed = self.closed;
            let taker = match (self.run.as_mut(), self.next.as_mut()) {
                (_, Some(n)) => Some(n),
                (Some(r), None) => Some(r),
                (None, None) => None,
            };
            if let Some(run) = taker.filter(|r| !r.ended) {
                if !run.wants_moves() {
                    return Ok(true);
                }
                let (queue, moves, line) = (&mut self.queue, &mut self.moves, &mut self.line);
                if !take_into(run, queue, closed, moves, line)? {
                    return Ok(false);
                }
                continue;
            }
            // the run in progress has all its moves: the next one starts
            if self.run.is_none() || self.next.is_some() {
                return Ok(true);
            }
            match self.queue.front().copied() {
                Some(Event::Move { geom, feed, src }) => {
                    self.queue.pop_front();
                    self.next = self.start(geom, feed, src)?;
                }
                Some(Event::Tolerance { mm }) => {
                    self.queue.pop_front();
                    self.tol = mm.max(P_MIN);
                }
                Some(_) => return Ok(true),
                None => return Ok(self.closed),
            }
        }
    }

    /// Moves taken so far.
    pub fn moves(&self) -> u64 {
        self.moves
    }

    /// The next sample or item; `None` until the next command comes (once
    /// closed: there is nothing more). `points`: whether samples need
    /// their point (the check needs only their count).
    pub fn step(&mut self, points: bool) -> Result<Option<Step>, String> {
        let step = self.next_step(points)?;
        if step.is_some() {
            self.over.steps += 1;
        }
        Ok(step)
    }

    fn next_step(&mut self, points: bool) -> Result<Option<Step>, String> {
        self.apply_scale();
        self.done = None;
        loop {
            if self.run.is_none() {
                self.run = self.next.take();
            }
            if !self.fill()? {
                return Ok(None);
            }
            if let Some(run) = self.run.as_mut() {
                match run.sample()? {
                    Next::At { x, last } => {
                        let pos = if points { run.point(x) } else { V3::zeros() };
                        let (src, rpm) = (run.src_at(x), run.rpm);
                        if last {
                            // (the next run starts with the next step)
                            self.done = self.run.take();
                        }
                        return Ok(Some(Step::Sample {
                            x,
                            pos,
                            src,
                            last,
                            rpm,
                        }));
                    }
                    Next::More => {
                        let (queue, moves, line) =
                            (&mut self.queue, &mut self.moves, &mut self.line);
                        if !take_into(run, queue, self.closed, moves, line)? {
                            return Ok(None);
                        }
                        continue;
                    }
                }
            }
            let Some(ev) = self.queue.pop_front() else {
                return Ok(None);
            };
            let item = match ev {
                Event::Move { geom, feed, src } => {
                    self.run = self.start(geom, feed, src)?;
                    continue;
                }
                Event::Tolerance { mm } => {
                    self.tol = mm.max(P_MIN);
                    continue;
                }
                Event::Dwell { seconds, src } => Item::Dwell { seconds, src },
                Event::Spindle { rpm, src } => Item::Spindle { rpm, src },
                Event::Tool { number, src } => Item::Tool { number, src },
                Event::Thread(m) => Item::Thread(m),
                Event::End { src } => Item::End { src },
            };
            return Ok(Some(Step::Item(item)));
        }
    }
}

/// Takes the next command into smooth run `run` if it joins it (counting
/// the move and its line), or ends the run; `false`: no command yet.
/// `closed`: whether no command is to come.
fn take_into(
    run: &mut Run,
    queue: &mut VecDeque<Event>,
    closed: bool,
    moves: &mut u64,
    line: &mut u32,
) -> Result<bool, String> {
    match queue.front() {
        Some(ev) if joins(run, ev) => {
            if let Some(Event::Move { geom, feed, src }) = queue.pop_front() {
                *moves += 1;
                *line = src.line;
                if geom.length() > TINY {
                    run.add(&geom, feed, src)?;
                }
            }
        }
        Some(_) => run.end()?,
        None if closed => run.end()?,
        None => return Ok(false),
    }
    Ok(true)
}

/// Whether `ev` joins smooth run `run`: a feed move, G95 as the run is or
/// not, turning gently enough from the run's last move.
fn joins(run: &Run, ev: &Event) -> bool {
    matches!(ev, Event::Move { geom, feed, .. }
        if *feed != Feed::Rapid
            && per_rev(*feed).is_some() == run.rpm.is_some()
            && !run.corner_stops(geom))
}

/// G95: the programmed spindle speed of a move's feed.
fn per_rev(feed: Feed) -> Option<f64> {
    match feed {
        Feed::PerRev { rpm, .. } => Some(rpm),
        _ => None,
    }
}
