//! The executor: pulls events from the interpreter through the planner and
//! produces one setpoint sample per tick, sample k at t = k·dt exactly.
//! Positions come from the geometry at the profile's path length, never from
//! accumulated increments.
//!
//! Feed hold and abort scale time along the path: a virtual tick counter
//! advances by the feed scale σ per sample instead of 1. σ moves towards its
//! target so that the path speed changes by exactly the move's planned path
//! acceleration per second, so the deceleration stays within the axis
//! limits and the tool stays on the path. With σ = 1 the virtual counter is
//! the tick index and the samples are exactly those of an unscaled run.
//!
//! Jerk ([`crate::jerk`]): the setpoint is the path at a moving average of
//! the planned path length over the last M_s samples (a trapezoid convolved
//! with a rectangle is an S-curve; the point stays on the path), then a
//! moving average of the last M_f such points spreads the steps of the
//! normal acceleration. After each stop the setpoints hold still for
//! M_s + M_f − 2 ticks ([`crate::timeline::Timeline::hold`]), so that the
//! filtered path reaches every stop point exactly; the check counts those
//! ticks too. A line or an arc run from rest to rest has a path filter of its own
//! and no XYZ filter; it waits a tick at its start and holds that
//! filter's length
//! ([`crate::profile::Profile::own_filter`]). At high jerk ([`crate::jerk::JerkBudget::single_average`]) there
//! is no path filter (M_s = 1: the raw point, bit for bit) and the XYZ
//! filter alone limits the jerk. G33 samples bypass both filters: they follow the spindle
//! angle, and a filter's delay would shift the groove with the speed.
//!
//! Spindle-synchronized motion (see [`crate::thread`]): G33 blocks are a
//! function of the spindle angle and G95 moves scale their virtual time by
//! the measured spindle speed over the programmed one. Without an encoder
//! ([`Executor::attach_encoder`] not called) the spindle is ideal: it turns
//! exactly as commanded, which is what the check's estimate assumes. With
//! one, a [`SpindleTracker`] predicts the angle at each sample's instant
//! from the readings given to [`Executor::encoder`], led by the drives'
//! delay ([`Executor::set_setpoint_delay`] plus the lead axis's servo lag),
//! so that the axis, not its setpoint, is on the thread line; readings that stop
//! during synchronized motion, or a spindle that does not come up to speed
//! for a thread, stop the axes under control and end the run with
//! [`Executor::fault`] set.

use crate::canon::{Feed, Src, ThreadMove, ThreadSeg};
use crate::dialect::Dialect;
use crate::geom::V3;
use crate::interp::Modal;
use crate::jerk::{PathFilter, Smoother};
use crate::machine::Machine;
use crate::path_run::Step;
use crate::pipeline::Pipeline;
use crate::plan::{Item, PlanLimits, PlannedMove};
use crate::source::ProgramSource;
use crate::thread::{LeadAccel, AT_SPEED_SETTLE_S, AT_SPEED_TOLERANCE, ENCODER_TIMEOUT_CYCLES};
use crate::tracker::{EncoderReading, SpindleTracker};
use std::collections::VecDeque;

pub use crate::shares::MAX_OVERRIDE;
/// With the path planner, the least change of the feed scale passed on:
/// the measured spindle's noise does not re-plan every sample.
const PER_REV_STEP: f64 = 0.005;

/// One interpolation cycle's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// tick index
    pub k: u64,
    /// k·dt, s
    pub t: f64,
    /// commanded position, machine coordinates, mm
    pub pos: V3,
    /// the block being executed
    pub src: Src,
    /// commanded spindle speed, rpm, signed
    pub spindle_rpm: f64,
    pub tool: u32,
    /// path speed commanded at this tick, mm/s
    pub path_speed: f64,
    /// in a G33 block: how the setpoint follows the spindle
    pub sync: Option<Sync>,
    /// the last sample of the program
    pub last: bool,
}

/// What a G33 sample was computed from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sync {
    /// the spindle angle this setpoint is for, revolutions, counted in the
    /// direction of rotation: the angle predicted at t + `ahead`
    pub theta: f64,
    /// how far ahead of its instant the setpoint leads, s: the drives'
    /// setpoint delay plus the lead axis's servo lag (0: the ideal spindle)
    pub ahead: f64,
    /// θ₀ of the block: the angle at which the ideal thread line passes its start
    pub theta0: f64,
    /// lead axis and pitch along it, mm/rev
    pub lead: usize,
    pub pitch: f64,
    /// lead travel from the block's start, mm (on the thread line: the
    /// setpoint's is `u + accel_lead`)
    pub u: f64,
    /// how far the setpoint leads the line to take up the lead axis's
    /// servo lag under the spindle's acceleration, mm of lead travel
    /// ([`Machine::servo_accel_lag_s2`] × pitch × the spindle's
    /// acceleration × [`ThreadMove::accel_lead_weight`]: eased in over the
    /// line's first 20 ms after a run-in and out over its last 20 ms before
    /// a deceleration; 0 off the line)
    pub accel_lead: f64,
    /// the lead axis's coordinate at the block's start, and the sign of its travel
    pub lead_start: f64,
    pub lead_sign: f64,
    /// on the ideal thread line (not in the run-in or the deceleration)
    pub on_line: bool,
}

// one value at a time: boxing the move would only add an allocation
#[allow(clippy::large_enum_variant)]
enum Cur {
    Move(PlannedMove, Option<u64>),
    Dwell(u64),
    Thread(ThreadRun),
    /// a controlled stop along a thread block, then the end
    Stop(StopRun),
}

/// What the path planner hands the executor next.
// one value at a time: boxing would only add an allocation
#[allow(clippy::large_enum_variant)]
enum PathOut {
    Item(Option<Item>),
    /// a sample to hand out (`None`: the run is over)
    Sample(Option<Sample>),
}

#[derive(Clone, Copy)]
struct ThreadRun {
    m: ThreadMove,
    /// set once synchronized
    theta0: Option<f64>,
    /// ideal spindle, last block: the tick it ends at
    end_tick: Option<u64>,
    /// cycles waited for the spindle, and of those at speed
    waited: u64,
    settled: u64,
    /// lead travel, speed (mm/s) and acceleration (mm/s²) at the last
    /// sample
    u: f64,
    v: f64,
    acc: f64,
}

/// A controlled stop along a thread: lead travel, speed and acceleration
/// (along the travel), the lead deceleration `a` and jerk `j` (infinite:
/// none, the speed falls by `a` at once).
#[derive(Clone, Copy)]
struct StopRun {
    seg: ThreadSeg,
    u: f64,
    v: f64,
    acc: f64,
    a: f64,
    j: f64,
}

impl StopRun {
    /// The next cycle's lead speed, `dt` later: at most `a` of deceleration
    /// and `j` of jerk, braking as hard as still lets the braking ease back
    /// to zero as the speed reaches zero (v ≥ d²/(2j) after the cycle).
    fn next_speed(&mut self, dt: f64) -> f64 {
        if !self.j.is_finite() {
            return (self.v - self.a * dt).max(0.0);
        }
        let (j, d) = (self.j, -self.acc);
        let want = j * ((dt * dt + 2.0 * self.v / j).sqrt() - dt);
        let d1 = want.min(self.a).min(d + j * dt).max(d - j * dt);
        self.acc = -d1;
        let v1 = self.v - d1 * dt;
        // (the last cycles remove what is left quadratically: below a
        // nanometre a second the axis stands)
        if v1 < 1e-6 {
            0.0
        } else {
            v1
        }
    }
}

/// Runs a program (which must have passed [`crate::check`]) sample by sample.
pub struct Executor<S> {
    /// interpreter, front stages, look-ahead and timeline
    pipe: Pipeline<S>,
    dt: f64,
    k: u64,
    /// virtual tick: advances by `scale` per sample
    vk: f64,
    /// feed scale σ now, and where it is heading (0 = hold)
    scale: f64,
    target: f64,
    cur: Option<Cur>,
    pos: V3,
    src: Src,
    spindle: f64,
    tool: u32,
    done: bool,
    /// the measured spindle (None: ideal spindle)
    tracker: Option<SpindleTracker>,
    /// spindle ramp, rpm/s (how long a thread waits for the speed)
    spindle_ramp: f64,
    /// G95: measured over programmed spindle speed
    sp_scale: f64,
    /// readings older than this are a lost signal, s
    encoder_timeout: f64,
    /// the spindle's top speed, rev/s (readings implying more than
    /// [`IMPLAUSIBLE_SPEED`](crate::tracker::IMPLAUSIBLE_SPEED) times it are an encoder fault)
    spindle_max_rps: f64,
    /// why the encoder's readings cannot be followed (a fault at the next
    /// sample that needs the spindle)
    encoder_bad: Option<String>,
    /// why the run stopped early
    fault: Option<String>,
    /// stop now (abort): threads stop under control too
    halt: bool,
    /// the lead speed of the last thread sample, mm/s (a chained block
    /// starts at it)
    thread_v: f64,
    /// the jerk filters ([`crate::jerk`]): the path filter over the path
    /// length, then the XYZ filter (None: no jerk limit)
    path: Option<PathFilter>,
    smooth: Option<Smoother>,
    /// the machine's filter lengths (M_s, M_f), and those in use: a line
    /// run from rest to rest has a path filter of its own and no XYZ
    /// filter ([`crate::profile::Profile::own_filter`])
    filters: (usize, usize),
    filters_now: (usize, usize),
    /// a line or an arc run from rest to rest with its own path filter: that
    /// filter's length M (0: none), and the secant speeds of the last M + 1
    /// steps, oldest first (zeros before the line: it starts from rest).
    /// The filter is sized for steps of the path acceleration of at most
    /// a ([`crate::jerk::JerkBudget::own_filter_samples`]), so a change of
    /// the feed scale keeps any two within M samples of each other within a
    own_m: usize,
    w_hist: VecDeque<f64>,
    /// path length of every move finished, mm, and the raw sample's path
    /// length (None: not on the path, a bypassed sample)
    s_total: f64,
    raw_s: Option<f64>,
    /// the raw run ended but the filter has not settled: its last sample
    drain: Option<Sample>,
    /// the raw sample just made is a thread's controlled stop: it bypasses
    /// the filter as the thread did
    bypass: bool,
    /// path length of the moves finished since the last stop, and the
    /// path position (on that count) of the last move sample, mm
    s_base: f64,
    s_last: f64,
    /// the measured spindle's scale of the last move step (G95)
    sp_last: f64,
    /// the largest path acceleration any move may have (|a_max|), mm/s²
    a_top: f64,
    /// the drives apply a setpoint this long after its instant, s, and
    /// each axis trails it by its servo lag, s: G33 leads by both
    delay: f64,
    servo_lag: V3,
    /// each axis's servo lag under acceleration that G33 leads by, s²
    /// ([`Machine::servo_accel_lag_s2`] × `thread_accel_lead`)
    accel_lag: V3,
    /// the spindle acceleration that lead multiplies, averaged
    lead_acc: LeadAccel,
    /// with the path planner: the last sample's path position in its run,
    /// its run's G95 spindle speed, and the feed scale asked
    path_x: f64,
    path_rpm: Option<f64>,
    path_scale: f64,
}

/// The σ nearest `bad` within `ok`, by bisection between `bad` (where
/// `ok` fails) and `good` (where it holds, or is taken to: 0 or the σ in
/// force); `good` itself if `ok` fails at `good` too and `strict` is not
/// set.
fn bisect(bad: f64, good: f64, ok: impl Fn(f64) -> bool, strict: bool) -> f64 {
    if !strict && !ok(good) {
        return good;
    }
    let (mut good, mut bad) = (good, bad);
    for _ in 0..48 {
        let mid = 0.5 * (good + bad);
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    good
}

/// The spindle at a setpoint's instant, revolutions counted in the
/// direction of rotation.
#[derive(Clone, Copy, Debug)]
struct SpindleNow {
    theta: f64,
    /// the angle of the last index pulse (`None`: none seen yet)
    index: Option<f64>,
    /// speed, rev/s, and acceleration, rev/s²
    rev_s: f64,
    rev_s2: f64,
}

impl<S: ProgramSource> Executor<S> {
    pub fn new(source: S, dialect: Dialect, machine: &Machine) -> Self {
        let lim = PlanLimits::from_machine(machine);
        let pipe = Pipeline::new(source, dialect, machine);
        // (the path planner's samples keep every limit themselves)
        let filters = !pipe.path_planner();
        Executor {
            pipe,
            dt: lim.dt,
            k: 0,
            vk: 0.0,
            scale: 1.0,
            target: 1.0,
            cur: None,
            pos: machine.home(),
            src: Src::default(),
            spindle: 0.0,
            tool: 0,
            done: false,
            tracker: None,
            spindle_ramp: machine
                .spindle
                .as_ref()
                .map_or(1000.0, |s| s.acceleration_rpm_s),
            sp_scale: 1.0,
            encoder_timeout: machine
                .spindle
                .as_ref()
                .and_then(|s| s.encoder_timeout_ms)
                .map_or(ENCODER_TIMEOUT_CYCLES * lim.dt, |ms| ms * 1e-3),
            spindle_max_rps: machine
                .spindle
                .as_ref()
                .map_or(f64::INFINITY, |s| s.max_rpm / 60.0),
            encoder_bad: None,
            fault: None,
            halt: false,
            thread_v: 0.0,
            // (a path filter of one sample is none: the raw point's bits)
            path: (filters && lim.jerk.m_s > 1)
                .then(|| PathFilter::new(lim.jerk.m_s, 0.0, machine.home())),
            smooth: (filters && lim.jerk.m_f > 1)
                .then(|| Smoother::new(lim.jerk.m_f, machine.home())),
            filters: (lim.jerk.m_s, lim.jerk.m_f),
            filters_now: (lim.jerk.m_s, lim.jerk.m_f),
            own_m: 0,
            w_hist: VecDeque::new(),
            s_total: 0.0,
            raw_s: None,
            drain: None,
            bypass: false,
            s_base: 0.0,
            s_last: 0.0,
            sp_last: 1.0,
            a_top: lim.max_path_acceleration(),
            delay: 0.0,
            servo_lag: machine.servo_lag_s(),
            accel_lag: machine.servo_accel_lag_s2() * machine.interpolation.thread_accel_lead,
            lead_acc: LeadAccel::new(lim.dt),
            path_x: 0.0,
            path_rpm: None,
            path_scale: 1.0,
        }
    }

    /// With the path planner: plans on a thread of its own, up to 0.1 s
    /// ahead of the samples, and smooths the geometry on another, so that
    /// the loop calling `next_sample` does not wait for a decision or a
    /// chunk that takes milliseconds; the samples are the same, feed holds
    /// included (`path_run::Ahead`). Each thread first calls `on_start`
    /// (the node's drops the control loop's real-time priority). Call
    /// before the first sample.
    pub fn plan_ahead(&mut self, on_start: fn()) {
        self.pipe.plan_ahead(on_start);
    }

    /// The drives apply each setpoint `seconds` after its instant (0 by
    /// default; not finite or negative: 0). With a measured spindle a G33
    /// setpoint is for the angle predicted that much ahead plus the lead
    /// axis's servo lag, and G95 follows the speed predicted `seconds` ahead.
    pub fn set_setpoint_delay(&mut self, seconds: f64) {
        self.delay = if seconds.is_finite() {
            seconds.max(0.0)
        } else {
            0.0
        };
    }

    /// Held still (feed scale 0) and the filtered setpoint too.
    pub fn at_rest(&self) -> bool {
        self.scale == 0.0
            && self.smooth.as_ref().is_none_or(Smoother::settled)
            && self.path.as_ref().is_none_or(PathFilter::settled)
    }

    /// Couples G33 and G95 to the measured spindle: from now on the
    /// readings given to [`Executor::encoder`] drive them, and readings
    /// that stop during synchronized motion are a fault.
    pub fn attach_encoder(&mut self) {
        if self.tracker.is_none() {
            self.tracker = Some(SpindleTracker::default());
        }
    }

    /// A reading of the spindle encoder (its `t` in this executor's time:
    /// sample k is at k·dt). Ignored without [`Executor::attach_encoder`].
    ///
    /// A reading no encoder on this spindle can give (its counts per
    /// revolution changed, or its count moved faster than
    /// [`IMPLAUSIBLE_SPEED`](crate::tracker::IMPLAUSIBLE_SPEED) times the spindle's top speed since the last
    /// one) is not followed while a G33 or G95 block follows the spindle:
    /// it then stops under control, as for a lost signal. At any other
    /// time (a counter reset or a restarted simulator between a job's
    /// threads) the tracker starts over from that reading.
    pub fn encoder(&mut self, r: EncoderReading) {
        let Some(t) = self.tracker.as_mut() else {
            return;
        };
        if self.encoder_bad.is_some() {
            return;
        }
        if let Some(why) = t.implausible(&r, self.spindle_max_rps) {
            // (the sample before this reading's first used the tracker)
            if t.followed_at() >= (self.k as f64 - 1.5) * self.dt {
                self.encoder_bad = Some(why);
                return;
            }
            *t = SpindleTracker::default();
        }
        t.push(r);
    }

    /// Why the run ended early (lost encoder, spindle not turning), if it did.
    pub fn fault(&self) -> Option<&str> {
        self.fault.as_deref()
    }

    /// Aborts: decelerates along the path (a thread under control, at its
    /// lead acceleration) and ends the run.
    pub fn abort(&mut self) {
        self.halt = true;
        self.set_feed_target(0.0);
    }

    /// Stops as [`Executor::abort`] does, and ends the run with `why` as
    /// its fault (the first fault stands).
    pub fn stop(&mut self, why: String) {
        self.fault.get_or_insert(why);
        self.abort();
    }

    /// Interpolation period, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The interpreter's modal state (it runs ahead of the samples by the
    /// look-ahead window).
    pub fn modal(&self) -> &Modal {
        self.pipe.modal()
    }

    /// Sets the feed scale to head for (the feed override): 0 holds
    /// (decelerating along the path), 1 runs at the programmed feed, up to
    /// [`MAX_OVERRIDE`]. Values are clamped to that range.
    ///
    /// Below 1 the planned motion runs slower in time; every velocity
    /// and acceleration shrinks. Above 1 time runs faster only where that
    /// keeps every limit: in the cruise of a move, up to the speed its axes
    /// (and an arc's centripetal limit) allow, and back to 1 before the
    /// planned deceleration starts, so the moves' planned junction speeds
    /// stay as they are; dwells and the holds after stops are not sped up.
    pub fn set_feed_target(&mut self, target: f64) {
        self.target = if target.is_nan() {
            0.0
        } else {
            target.clamp(0.0, MAX_OVERRIDE)
        };
    }

    /// The fastest feed scale allowed at local time `tau` of `m` with an
    /// override over 1 (see [`Executor::set_feed_target`]).
    fn boost_limit(&self, m: &PlannedMove, tau: f64) -> f64 {
        let p = &m.profile;
        // (not while the last steps still reach back into the acceleration
        // or the move before: a sampled acceleration there adds to the
        // change of speed, or to the turn of the junction)
        let settled = p.t_acc + 2.0 * MAX_OVERRIDE * self.dt;
        if p.vp <= 0.0 || tau < settled || tau >= p.t_acc + p.t_cruise {
            return 1.0;
        }
        let cap = p.vlim;
        // from σ·vp back to vp before the cruise ends, at the path
        // acceleration, with a step in hand
        // (under a line's (or an arc's) own path filter the deceleration may start up to
        // that filter's length later, [`Self::update_scale`])
        let late = (2 + self.own_m) as f64 * cap * self.dt;
        let left = p.d_acc + p.d_cruise - p.s_at(tau) - late;
        let brake = (1.0 + 2.0 * p.a * left.max(0.0) / (p.vp * p.vp)).sqrt();
        (cap / p.vp).min(brake).max(1.0)
    }

    /// The feed scale in force (0 when held still).
    pub fn feed_scale(&self) -> f64 {
        self.scale
    }

    /// Moves σ towards its target so that the path speed *between samples*
    /// (the secant, what the axes see) changes by at most the move's path
    /// acceleration × dt per sample, whatever the profile itself does at
    /// the same time. With σ at its target nothing changes. `w_prev`: the
    /// secant speed of the step that led here (mm/s, in virtual time).
    ///
    /// Under a line's (or an arc's) own path filter of M samples (sized for steps of
    /// a, [`crate::jerk::JerkBudget::own_filter_samples`]) also: the
    /// secant's change differs from the one M steps back by at most a·dt;
    /// and where the line's deceleration is less than M + 3 samples away,
    /// or under way, σ rises only up to √½ (or stays where it is, if
    /// higher) with changes of at most a/2: the deceleration it meets is
    /// then at most a/2 too, or its change in the window is only the
    /// profile's own (whose cruise outlasts the window).
    fn update_scale(&mut self, m: &PlannedMove, tau: f64, w_prev: f64) {
        let p = &m.profile;
        let mut goal = if self.target > 1.0 {
            self.target.min(self.boost_limit(m, tau))
        } else {
            self.target
        };
        let mut rise = f64::INFINITY;
        if self.own_m > 0 && goal > self.scale {
            let ahead = (self.own_m + 3) as f64 * self.dt * goal;
            if p.t_acc + p.t_cruise - tau < ahead {
                goal = goal.min(self.scale.max(std::f64::consts::FRAC_1_SQRT_2));
                rise = 0.5 * p.a * self.dt;
            }
        }
        // (under a line's (or an arc's) own path filter the window is kept at the goal
        // too: after a change of σ the profile's own step may leave it)
        let own = self.own_m > 0 && self.w_hist.len() > self.own_m;
        if self.scale == goal && !own {
            return;
        }
        let dt = self.dt;
        let s0 = p.s_at(tau);
        let down = goal < self.scale;
        // path length at local time t. After a stop nothing moves until
        // the next group starts; past a moving end the moves after this one
        // are not known here: they may speed up or slow down at up to
        // `a_top`, and the bound on the safe side is taken
        let bend = if down { -0.5 } else { 0.5 } * self.a_top;
        let s_ext = |t: f64| {
            if t > p.duration && p.v1 > 0.0 {
                let u = t - p.duration;
                p.length + (u * p.v1 + bend * u * u).max(0.0)
            } else {
                p.s_at(t)
            }
        };
        let w = |sigma: f64| (s_ext(tau + sigma * dt) - s0) / dt;
        // a step that reaches into a neighbouring move (or came from one)
        // also turns with it: its change of speed keeps to the smaller
        // acceleration, leaving the neighbour its centripetal part
        let across = tau - self.scale * dt < 0.0 || tau + self.scale.max(goal) * dt > p.duration;
        let step = if across { p.a_join } else { p.a } * dt;
        let (from, to) = (self.scale, goal);
        if own {
            // under a line's (or an arc's) own path filter of M samples: the change of
            // the secant M steps back, which this step's may differ from
            // by at most a·dt (the filter's jerk is the difference over
            // M·dt); and the rate's bound on the side σ moves to (at the
            // goal, where the profile's own steps are on the limits: not
            // where they pass them by a rounding)
            let n = self.w_hist.len();
            let back = self.w_hist[n - self.own_m] - self.w_hist[n - self.own_m - 1];
            let slack = if from == to { 1e-6 * p.a * dt } else { 0.0 };
            let win = p.a * dt + slack;
            let lo = w_prev + (back - win).max(if down { -step } else { f64::NEG_INFINITY });
            let hi = w_prev
                + (back + win).min(if down {
                    f64::INFINITY
                } else {
                    step.min(rise) + slack
                });
            let x = w(to);
            self.scale = if x > hi {
                // (σ gives way, down to 0 if it must, where the secant is 0)
                bisect(to, 0.0, |g| w(g) <= hi, true)
            } else if x < lo && from > to {
                bisect(to, from, |g| w(g) >= lo, false)
            } else {
                to
            };
            return;
        }
        // the limit the secant must not pass, and whether σ = `to` keeps it
        let ok = |x: f64| {
            if down {
                x >= w_prev - step
            } else {
                x <= w_prev + step
            }
        };
        self.scale = if ok(w(to)) {
            to
        } else if !ok(w(from)) {
            from
        } else {
            // bisection between σ that keeps the limit and σ that does not
            let (mut good, mut bad) = (from, to);
            for _ in 0..48 {
                let mid = 0.5 * (good + bad);
                if ok(w(mid)) {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            good
        };
    }

    /// A sample standing still at the current position (a dwell, the hold
    /// after a stop). Its time runs at the feed scale but never faster than
    /// 1: a feed hold pauses it, an override over 100 % does not shorten it.
    fn still_sample(&mut self) -> Sample {
        let s = self.sample(self.pos, 0.0, false);
        self.scale = self.target.min(1.0);
        self.advance(self.scale);
        s
    }

    /// Errors the interpreter met (none for a checked program).
    pub fn error_count(&self) -> usize {
        self.pipe.error_count()
    }

    fn next_item(&mut self) -> Option<Item> {
        self.pipe.next_item()
    }

    fn sample(&self, pos: V3, speed: f64, last: bool) -> Sample {
        Sample {
            k: self.k,
            t: self.k as f64 * self.dt,
            pos,
            src: self.src,
            spindle_rpm: self.spindle,
            tool: self.tool,
            path_speed: speed,
            sync: None,
            last,
        }
    }

    /// The last sample, at `pos`: the run ends here.
    fn end_at(&mut self, pos: V3) -> Option<Sample> {
        self.done = true;
        Some(self.sample(pos, 0.0, true))
    }

    /// The spindle for this tick's setpoint (measured: predicted `ahead`
    /// s after its instant), counted in direction `dir`. `None`: no
    /// reading has come yet, and the run is younger than the encoder's
    /// timeout (a run that starts with G33 or G95 waits for the first).
    fn spindle_angle(&mut self, dir: f64, ahead: f64) -> Result<Option<SpindleNow>, String> {
        let Some(tr) = self.tracker.as_mut() else {
            let (theta, index) = self.pipe.timeline.ideal_angle(dir, self.vk);
            return Ok(Some(SpindleNow {
                theta,
                index: Some(index),
                rev_s: dir * self.pipe.timeline.spin_rpm / 60.0,
                rev_s2: 0.0,
            }));
        };
        if let Some(why) = &self.encoder_bad {
            return Err(why.clone());
        }
        let t = self.k as f64 * self.dt;
        if tr.last.is_none() {
            if t <= self.encoder_timeout {
                return Ok(None);
            }
            return Err(format!(
                "no spindle encoder reading came in the first {:.0} ms",
                self.encoder_timeout * 1000.0
            ));
        }
        let (Some(last), Some(p)) = (tr.last, tr.predict_motion(t + ahead, t)) else {
            return Err("no spindle encoder reading".into());
        };
        let late = t - last.t;
        if late > self.encoder_timeout {
            return Err(format!(
                "spindle encoder signal lost: no reading for {:.0} ms",
                late * 1000.0
            ));
        }
        let cpr = tr.cpr();
        Ok(Some(SpindleNow {
            theta: dir * p.counts / cpr,
            index: (last.index_count > 0).then(|| dir * last.count_at_index as f64 / cpr),
            rev_s: dir * p.per_s / cpr,
            rev_s2: dir * p.per_s2 / cpr,
        }))
    }

    /// Ends the run after a controlled stop of a thread from where `run`
    /// stands (its lead travel, speed and acceleration).
    fn stop_thread(&mut self, m: &ThreadMove, run: &ThreadRun, why: Option<String>) {
        if self.fault.is_none() {
            self.fault = why;
        }
        self.cur = Some(Cur::Stop(StopRun {
            seg: m.seg,
            u: run.u,
            v: run.v.max(0.0),
            acc: run.acc,
            a: m.accel,
            j: m.jerk,
        }));
    }

    /// One sample of a thread block; `None`: the block is done.
    fn thread_sample(&mut self, mut run: ThreadRun) -> Option<Sample> {
        let m = run.m;
        let dir = m.dir();
        let ahead = if self.tracker.is_some() {
            self.delay + self.servo_lag[m.seg.lead]
        } else {
            0.0
        };
        let SpindleNow {
            theta,
            index,
            rev_s,
            rev_s2,
        } = match self.spindle_angle(dir, ahead) {
            Ok(Some(a)) => a,
            Ok(None) if run.theta0.is_none() => {
                // the encoder's first reading is still to come: wait at the
                // start (as for a spindle not at speed yet)
                run.waited += 1;
                return self.wait_at_start(run);
            }
            r => {
                let why = r
                    .err()
                    .unwrap_or_else(|| "no spindle encoder reading".into());
                let why = format!("line {}: {why}", m.src.line);
                if run.theta0.is_none() {
                    // not moving yet: the run ends here
                    self.fault = Some(why);
                    self.src = m.src;
                    return self.end_at(m.seg.pos(run.u));
                }
                self.stop_thread(&m, &run, Some(why));
                return self.raw_sample();
            }
        };
        // (aborted in the chain's deceleration, the thread goes on to its
        // end point: that deceleration is the stop, planned within the
        // limits, and ends the run there)
        let decelerating = |t0: f64| {
            m.decel
                .is_some_and(|d| theta - t0 > m.seg.len / m.seg.pitch - 0.5 * d)
        };
        if self.halt && !run.theta0.is_some_and(decelerating) {
            self.stop_thread(&m, &run, None);
            return self.raw_sample();
        }
        let theta0 = match run.theta0 {
            Some(t) => t,
            None => {
                let want = m.rpm.abs() / 60.0;
                if (rev_s - want).abs() <= AT_SPEED_TOLERANCE * want {
                    run.settled += 1;
                } else {
                    run.settled = 0;
                }
                let settle = AT_SPEED_SETTLE_S
                    + AT_SPEED_TOLERANCE * m.rpm.abs() / self.spindle_ramp.max(1.0);
                let at_speed = self.tracker.is_none() || run.settled as f64 * self.dt >= settle;
                let held = self.target == 0.0;
                match index {
                    Some(ix) if at_speed && !held => {
                        let t0 = self.pipe.timeline.thread_begin(&m, theta, ix);
                        // the run-in starts within a revolution of now,
                        // unless the encoder's index is ahead of its count
                        // (no real encoder's is: a fault, nothing moved)
                        let wait = t0 + m.start_x() - theta;
                        if m.runin.is_some() && (wait > 2.0 || wait.is_nan()) {
                            self.fault = Some(format!(
                                "line {}: G33 cannot start: the spindle encoder's last index \
                                 pulse is {wait:.0} revolutions ahead of its count",
                                m.src.line
                            ));
                            self.src = m.src;
                            return self.end_at(m.seg.start);
                        }
                        run.theta0 = Some(t0);
                        t0
                    }
                    _ => {
                        if !held {
                            run.waited += 1;
                        }
                        let limit = m.rpm.abs() / self.spindle_ramp.max(1.0) + settle + 1.0;
                        if run.waited as f64 * self.dt > limit {
                            let no_index = if index.is_none() {
                                " and no index pulse was seen"
                            } else {
                                ""
                            };
                            let (line, rpm, now) = (m.src.line, m.rpm.abs(), rev_s.abs() * 60.0);
                            // (at speed now, yet never long enough: a
                            // spindle, or an encoder too coarse, whose
                            // measured speed wanders)
                            self.fault = Some(
                                if (rev_s - want).abs() <= AT_SPEED_TOLERANCE * want {
                                    format!(
                                        "line {line}: G33 needs the spindle steady at S{rpm}: its measured speed \
                                         (now {now:.0} rpm) did not stay within {:.0} % of it for {:.0} ms{no_index}",
                                        AT_SPEED_TOLERANCE * 100.0,
                                        settle * 1000.0
                                    )
                                } else {
                                    format!(
                                        "line {line}: G33 needs the spindle at S{rpm} but it turns at {now:.0} rpm{no_index}"
                                    )
                                },
                            );
                            self.src = m.src;
                            return self.end_at(m.seg.start);
                        }
                        return self.wait_at_start(run);
                    }
                }
            }
        };
        if run.end_tick.is_none() && m.decel.is_some() && self.tracker.is_none() {
            // the ideal spindle: the chain's last block ends on a known tick
            run.end_tick = Some(self.pipe.timeline.ideal_thread_end(&m));
        }
        let x = theta - theta0;
        let done = match run.end_tick {
            Some(k) => self.vk >= k as f64,
            None if m.decel.is_some() => x >= m.end_x(),
            None => x >= m.seg.len / m.seg.pitch,
        };
        if done {
            self.pos = m.seg.end;
            if self.halt {
                self.src = m.src;
                return self.end_at(m.seg.end);
            }
            if m.decel.is_some() {
                let k = run.end_tick.unwrap_or(self.vk.ceil() as u64);
                self.vk = self.vk.max(k as f64);
                self.pipe.timeline.finish_group_at(k);
            } else {
                self.pipe.timeline.thread_next(&m);
            }
            return None;
        }
        let (u, du) = m.at(x);
        let v = du * rev_s.max(0.0);
        run.u = u;
        run.acc = m.d2u_dx2(x) * rev_s * rev_s + du * rev_s2;
        run.v = v;
        self.thread_v = v;
        self.src = m.src;
        let on_line = du == m.seg.pitch;
        // on the line the lead axis accelerates with the spindle: lead it
        // by its servo's lag under acceleration too, eased in after the
        // run-in and out before the deceleration (switched on where the
        // line began, it stepped the setpoints: 2045 m/s³ at S2000 on the
        // 200 m/s³ lathe with a spindle rippling by ±2 %)
        let rev_s2_lead = self.lead_acc.push(rev_s2);
        let accel_lead = if on_line {
            self.accel_lag[m.seg.lead] * m.seg.pitch * rev_s2_lead * m.accel_lead_weight(x)
        } else {
            0.0
        };
        let mut s = self.sample(
            m.seg.pos(u + accel_lead),
            v * (m.seg.prog_end - m.seg.start).norm() / m.seg.len,
            false,
        );
        s.sync = Some(Sync {
            theta,
            ahead,
            theta0,
            lead: m.seg.lead,
            pitch: m.seg.pitch,
            u,
            accel_lead,
            lead_start: m.seg.start[m.seg.lead],
            lead_sign: (m.seg.prog_end[m.seg.lead] - m.seg.start[m.seg.lead]).signum(),
            on_line,
        });
        self.cur = Some(Cur::Thread(run));
        self.advance(1.0);
        Some(s)
    }

    /// A sample of a thread that has not started (waiting for the spindle
    /// or its encoder): at its start point, the same block next tick.
    fn wait_at_start(&mut self, run: ThreadRun) -> Option<Sample> {
        self.src = run.m.src;
        let s = self.sample(run.m.seg.start, 0.0, false);
        self.cur = Some(Cur::Thread(run));
        self.advance(1.0);
        Some(s)
    }

    fn advance(&mut self, step: f64) {
        self.k += 1;
        self.vk += step;
    }

    /// The next sample, or `None` after the last one.
    pub fn next_sample(&mut self) -> Option<Sample> {
        if self.smooth.is_none() && self.path.is_none() {
            return self.raw_sample();
        }
        let mut s = match self.drain.take() {
            Some(mut last) => {
                last.k += 1;
                last.t = last.k as f64 * self.dt;
                last.path_speed = 0.0;
                last
            }
            None => self.raw_sample()?,
        };
        if s.sync.is_some() || self.bypass {
            if let Some(pf) = self.path.as_mut() {
                pf.reset(self.s_total, s.pos, s.path_speed);
            }
            if let Some(f) = self.smooth.as_mut() {
                f.reset(s.pos, s.path_speed);
            }
            return Some(s);
        }
        let (mut p, mut v) = (s.pos, s.path_speed);
        if let Some(pf) = self.path.as_mut() {
            (p, v) = pf.push(self.raw_s.unwrap_or(self.s_total), v, p);
        }
        if let Some(f) = self.smooth.as_mut() {
            (p, v) = f.push(p, v);
        }
        let settled = self.smooth.as_ref().is_none_or(Smoother::settled)
            && self.path.as_ref().is_none_or(PathFilter::settled);
        if s.last && !settled {
            // the run ended off the filters' rest (a fault or an abort):
            // hold the end until they settle on it
            s.last = false;
            self.drain = Some(Sample { last: true, ..s });
        }
        s.pos = p;
        s.path_speed = v;
        Some(s)
    }

    /// At the start of a group (at rest, the hold after the stop before
    /// over): the path filter of `own` samples and no XYZ filter for a
    /// line or an arc run from rest to rest, else the machine's filters. The filters
    /// are made anew, standing at the stop: the sample the group starts
    /// with (the stop point again) fills the last of the old filters'
    /// slots that still held an earlier point, so either way it comes out
    /// as the stop point.
    fn filters_for(&mut self, own: Option<u32>) {
        let want = own.map_or(self.filters, |m| (m as usize, 1));
        if want == self.filters_now {
            return;
        }
        self.filters_now = want;
        self.path = Some(PathFilter::new(want.0, self.s_total, self.pos));
        self.smooth = (want.1 > 1).then(|| Smoother::new(want.1, self.pos));
    }

    /// The next unfiltered sample.
    fn raw_sample(&mut self) -> Option<Sample> {
        if self.done {
            return None;
        }
        self.bypass = false;
        self.raw_s = Some(self.s_total);
        loop {
            if self.cur.is_none() && self.vk < self.pipe.timeline.group_k0 as f64 {
                if self.fault.is_some() {
                    // stopped for good: the run ends here (the filter
                    // settles on the end point as the run drains)
                    return self.end_at(self.pos);
                }
                // the hold after a stop: the jerk filter settles
                return Some(self.still_sample());
            }
            if self.cur.is_none() {
                let item = if self.pipe.path_planner() {
                    if self.target == 0.0 && self.pipe.path_idle() {
                        // a feed hold between two runs: the next one waits
                        // (within a run the planner brakes, `path_step`)
                        return Some(self.still_sample());
                    }
                    match self.path_step() {
                        PathOut::Item(item) => item,
                        PathOut::Sample(s) => return s,
                    }
                } else {
                    self.next_item()
                };
                if self.fault.is_some() && !matches!(item, Some(Item::Move(_))) {
                    // stopped (what is not a move comes after a stop): the
                    // run ends here
                    return self.end_at(self.pos);
                }
                match item {
                    None | Some(Item::End { .. }) => return self.end_at(self.pos),
                    Some(Item::Move(m)) => {
                        if self.path.is_some() && m.profile.v0 == 0.0 {
                            let own = m.profile.own_filter();
                            self.filters_for(own);
                            self.own_m = own.unwrap_or(0) as usize;
                            self.w_hist.clear();
                            if self.own_m > 0 {
                                self.w_hist.resize(self.own_m + 1, 0.0);
                            }
                        }
                        if let Some(pf) = self.path.as_mut() {
                            pf.add_move(self.s_total, m.geom);
                        }
                        let stop = self.pipe.timeline.stop_tick(&m);
                        self.cur = Some(Cur::Move(m, stop));
                    }
                    Some(Item::Dwell { seconds, src }) => {
                        self.scale = self.target.min(1.0);
                        self.src = src;
                        let end = self.pipe.timeline.group_k0 + self.pipe.timeline.ticks(seconds);
                        self.pipe.timeline.finish_dwell(seconds);
                        self.cur = Some(Cur::Dwell(end));
                    }
                    Some(Item::Spindle { rpm, src }) => {
                        self.src = src;
                        self.spindle = rpm;
                        self.pipe.timeline.set_spindle(rpm);
                    }
                    Some(Item::Tool { number, src }) => {
                        self.src = src;
                        self.tool = number;
                    }
                    Some(Item::Smoothing(b)) => {
                        // (at rest, the hold over: the next group's start
                        // makes the filters anew)
                        self.filters = (b.m_s, b.m_f);
                        self.pipe.timeline.set_hold(b.hold_ticks());
                    }
                    Some(Item::Thread(m)) => {
                        if m.runin.is_some() {
                            // a new pass
                            self.lead_acc.reset();
                        }
                        self.cur = Some(Cur::Thread(ThreadRun {
                            m,
                            // a chained block is synchronized already
                            theta0: m.runin.is_none().then_some(self.pipe.timeline.theta0),
                            end_tick: None,
                            waited: 0,
                            settled: 0,
                            u: 0.0,
                            // a chained block goes on at the speed the
                            // last one left off at
                            v: if m.runin.is_none() {
                                self.thread_v
                            } else {
                                0.0
                            },
                            acc: 0.0,
                        }));
                    }
                }
                continue;
            }
            match self.cur.take() {
                Some(Cur::Move(m, stop)) => {
                    let tau = self.pipe.timeline.move_time(self.vk, &m.profile);
                    let running = match stop {
                        Some(end) => self.vk < end as f64,
                        None => tau < m.profile.duration,
                    };
                    if running {
                        self.raw_s = Some(self.s_total + m.profile.s_at(tau));
                        if self.fault.is_some() && self.scale == 0.0 {
                            // stopped after a lost encoder
                            return self.end_at(m.geom.eval(m.profile.s_at(tau)));
                        }
                        let spindle = self.spindle_scale(&m);
                        self.src = m.src;
                        let pos = m.geom.eval(m.profile.s_at(tau));
                        let s = self.sample(pos, m.profile.v_at(tau) * self.scale * spindle, false);
                        // the secant of the step that led here, in virtual
                        // time (the spindle's measured scale taken out)
                        let s_now = self.s_base + m.profile.s_at(tau);
                        let w_prev = (s_now - self.s_last) / (self.dt * self.sp_last.max(1e-9));
                        self.s_last = s_now;
                        if self.own_m > 0 {
                            self.w_hist.pop_front();
                            self.w_hist.push_back(w_prev);
                        }
                        self.update_scale(&m, tau, w_prev);
                        self.cur = Some(Cur::Move(m, stop));
                        self.sp_last = spindle;
                        self.advance(self.scale * spindle);
                        return Some(s);
                    }
                    self.pos = m.geom.end();
                    self.s_total += m.profile.length;
                    self.raw_s = Some(self.s_total);
                    if m.profile.v1 > 0.0 {
                        self.s_base += m.profile.length;
                    } else {
                        // a stop: the count starts again
                        self.s_base = 0.0;
                        self.s_last = 0.0;
                    }
                    self.pipe.timeline.finish_move(&m);
                }
                Some(Cur::Dwell(end)) if self.vk < end as f64 => {
                    self.cur = Some(Cur::Dwell(end));
                    return Some(self.still_sample());
                }
                Some(Cur::Dwell(_)) => {}
                Some(Cur::Thread(run)) => {
                    if let Some(s) = self.thread_sample(run) {
                        return Some(s);
                    }
                }
                Some(Cur::Stop(mut st)) => {
                    self.bypass = true;
                    let v1 = st.next_speed(self.dt);
                    st.u = (st.u + 0.5 * (st.v + v1) * self.dt).min(st.seg.len);
                    st.v = v1;
                    let pos = st.seg.pos(st.u);
                    self.pos = pos;
                    if v1 == 0.0 {
                        return self.end_at(pos);
                    }
                    let s = self.sample(pos, v1, false);
                    self.cur = Some(Cur::Stop(st));
                    self.advance(1.0);
                    return Some(s);
                }
                None => {}
            }
        }
    }

    /// With the path planner: the next planned item, or the sample to hand
    /// out (a run's; the end, after an error).
    fn path_step(&mut self) -> PathOut {
        // a feed hold brakes the run in progress to rest along its path at
        // once; the override, and under G95 the measured spindle speed
        // over the programmed one (its changes of 0.5 % or more), scale the
        // feed from 0.1 s on
        let spindle = match self.path_rpm {
            Some(rpm) => self.per_rev_scale(rpm, self.src.line),
            None => 1.0,
        };
        let scale = self.target * spindle;
        let held = self.path_scale == 0.0;
        if (scale - self.path_scale).abs() >= PER_REV_STEP * self.path_scale.max(0.01)
            || (scale == 0.0) != held
        {
            self.path_scale = scale;
        }
        if held && self.path_scale > 0.0 {
            // (a run that stands held goes on at the new scale at once)
            self.pipe.path_resume(self.path_scale);
        } else {
            self.pipe.path_hold(self.path_scale == 0.0);
            if self.path_scale > 0.0 {
                self.pipe.path_scale(self.path_scale);
            }
        }
        loop {
            match self.pipe.path_step() {
                Ok(Some(Step::Sample {
                    x,
                    pos,
                    src,
                    last,
                    rpm,
                })) => {
                    self.src = src;
                    self.path_rpm = rpm;
                    self.pos = pos;
                    if last {
                        // at rest on the run's end: this tick is the first
                        // of what follows
                        self.path_x = 0.0;
                        let k = self.vk.round() as u64;
                        self.pipe.timeline.finish_group_at(k);
                        if self.target == 0.0 {
                            return PathOut::Sample(Some(self.still_sample()));
                        }
                        continue;
                    }
                    let speed = (x - self.path_x) / self.dt;
                    self.path_x = x;
                    // (held still: at rest, as `at_rest` tells)
                    self.scale = if self.target == 0.0 && speed == 0.0 {
                        0.0
                    } else {
                        1.0
                    };
                    let s = self.sample(pos, speed, false);
                    self.advance(1.0);
                    return PathOut::Sample(Some(s));
                }
                Ok(Some(Step::Item(item))) => return PathOut::Item(Some(item)),
                Ok(None) => return PathOut::Item(None),
                Err(why) => {
                    self.fault = Some(format!("line {}: {why}", self.src.line));
                    return PathOut::Sample(self.end_at(self.pos));
                }
            }
        }
    }

    /// G95 with a measured spindle: measured over programmed speed (frozen
    /// once the signal is lost, while the axes stop).
    fn spindle_scale(&mut self, m: &PlannedMove) -> f64 {
        match m.feed {
            Feed::PerRev { rpm, .. } => self.per_rev_scale(rpm, m.src.line),
            _ => 1.0,
        }
    }

    /// `spindle_scale` of a G95 move at `rpm` programmed (its `line`).
    fn per_rev_scale(&mut self, rpm: f64, line: u32) -> f64 {
        if self.tracker.is_none() {
            return 1.0;
        }
        if self.fault.is_some() {
            return self.sp_scale;
        }
        let dir = if rpm < 0.0 { -1.0 } else { 1.0 };
        match self.spindle_angle(dir, self.delay) {
            Ok(Some(SpindleNow { rev_s, .. })) => {
                self.sp_scale = (rev_s * 60.0 / rpm.abs()).clamp(0.0, 2.0);
            }
            // (the encoder's first reading is still to come: the axes wait)
            Ok(None) => self.sp_scale = 0.0,
            Err(why) => {
                self.fault = Some(format!("line {line}: {why}"));
                self.set_feed_target(0.0);
            }
        }
        self.sp_scale
    }
}

impl<S: ProgramSource> Iterator for Executor<S> {
    type Item = Sample;
    fn next(&mut self) -> Option<Sample> {
        self.next_sample()
    }
}
