//! The control loop (its thread in [`super`]): cycles on the instants of
//! a fixed grid at the interpolation rate, commands and readings taken
//! without blocking, each cycle's setpoints published by the cycle itself
//! and its sample handed to the DDS thread; at rest it wakes only for the
//! cycles that publish (`ros::Pace`, docs/ros_interface.md §3.1).

use super::phase::{
    phase_delay, phase_of, run_instant, ENCODER_PHASE, PHASE_READINGS, PHASE_STILL,
};
use super::{Cmd, Out, Rec};
use cnc_core::Machine;
use cnc_msgs::ros::{self, Grid, WallClock};
use cnc_msgs::{ros_error, ros_info, ros_warn};
use cnc_msgs::{Float64, JointState, SpindleEncoder, Time};
use cnc_node::controller::{ActualSample, Controller, EncoderSample, Job, Tick};
use cnc_node::convert::{self, time_ns};
use cnc_node::diagnostics::LOOP;
use cnc_node::params::Live;
use cnc_node::rt_queue::{self, CmdRx, NoCmd};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Cycles the loop runs in one wake-up at most when it woke late (wake-ups
/// then come twice a period: it catches up at up to four times its rate),
/// so the n-th cycle of a job stays meant for its instant (the executor's
/// time base, which a thread synchronizes to the encoder in) while the
/// encoder readings of the stall have time to arrive.
const CATCH_UP: u64 = 2;
/// The system clock's moves against the monotonic one (slews, steps) are
/// logged once they add up to this many ns (at most once a second).
const CLOCK_MOVE_LOG_NS: i128 = 10_000;
/// A loop further behind than this skips the missed cycles; a running job
/// then ends where it stands, in the error state (its time base is lost).
const MAX_BEHIND_S: f64 = 0.2;
/// How long a loop that fell [`MAX_BEHIND_S`] behind gives way, s: it
/// cannot keep its rate here (a host hold-up, or cycles that cost more
/// than their period), and at real-time priority it would otherwise hold
/// its CPU catching up and starve the node's own threads (DDS, the check,
/// shutdown) below it. See [`GiveWay`].
const GIVE_WAY_S: f64 = 1.0;

/// A loop must leave its CPU this share of the time at least, over each
/// [`IDLE_WINDOW_S`] (its thread's CPU time against the wall time): one
/// that leaves less cannot keep its rate here (its cycles and the
/// switches of its sleeps take about their whole period, or it is behind
/// and catching up without a sleep), and its real-time priority would
/// starve the threads below it, so it gives way. A healthy loop leaves
/// most of each period (at 1 kHz over 90 %).
const MIN_IDLE_SHARE: f64 = 0.1;
/// The window the idle share is taken over, s: twice [`MAX_BEHIND_S`], so
/// that a host holding the loop up in one piece for that long has
/// already made it fall behind.
const IDLE_WINDOW_S: f64 = 2.0 * MAX_BEHIND_S;

/// The share of the wall time a thread left its CPU over consecutive
/// windows of [`IDLE_WINDOW_S`], from its CPU time
/// (`ros::thread_cpu_time`, asked for once a window).
#[derive(Debug, Clone, Copy)]
struct IdleShare {
    start: Instant,
    cpu: Duration,
}

impl IdleShare {
    fn new(now: Instant, cpu: Duration) -> Self {
        IdleShare { start: now, cpu }
    }

    /// At `now`: the share of the window just ended, with the thread's
    /// CPU time in all from `cpu` (the next window starts), or None while
    /// it lasts.
    fn check(&mut self, now: Instant, cpu: impl FnOnce() -> Duration) -> Option<f64> {
        let over = now.saturating_duration_since(self.start);
        if over.as_secs_f64() < IDLE_WINDOW_S {
            return None;
        }
        let cpu = cpu();
        let used = cpu.saturating_sub(self.cpu).as_secs_f64() / over.as_secs_f64();
        *self = IdleShare::new(now, cpu);
        Some((1.0 - used).max(0.0))
    }
}

/// The control loop giving way after it fell behind or kept its CPU
/// ([`MIN_IDLE_SHARE`]): for [`GIVE_WAY_S`] it wakes only for the cycles
/// of the resting rate (`ros::Pace`), skips the ones between, and starts
/// no job, so the threads below it get the CPU back; a job that was
/// running ends at the first of those cycles. Then the loop goes on as
/// before: if it still cannot keep its rate, it gives way again.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct GiveWay {
    /// the first cycle after the give-way
    until: u64,
}

impl GiveWay {
    /// The loop fell behind and goes on at cycle `next`, `rate_hz`.
    fn start(&mut self, next: u64, rate_hz: f64) {
        self.until = next + (GIVE_WAY_S * rate_hz).round() as u64;
    }

    /// Whether cycle `n` falls in the give-way.
    fn active(&self, n: u64) -> bool {
        n < self.until
    }

    /// The cycle a loop at cycle `next` waits for: the next one at the
    /// resting rate (`every` cycles apart) while giving way, else `wanted`.
    fn target(&self, next: u64, every: u64, wanted: u64) -> u64 {
        if self.active(next) {
            next.div_ceil(every) * every
        } else {
            wanted
        }
    }
}

/// An encoder reading at most this many periods old is fresh: a job on a
/// machine with a spindle starts once the newest one is.
const FRESH_PERIODS: i64 = 3;
/// How long a job waits for fresh encoder readings at most, s (then it
/// starts, and the executor judges the readings as always).
const MAX_START_WAIT_S: f64 = 0.05;

/// The spindle encoder's readings as the loop takes them: straight from
/// their stream subscription's cache (best effort, keep last
/// `ros::STREAM_DEPTH`), without a thread of their own that would wake for
/// each one (a wake-up a cycle, about 1–2 % of a core at 1 kHz). A take
/// holds the cache's lock only while it copies a sample out, as the
/// simulator's loop does with its setpoints; DDS's threads run below the
/// loop's priority. Each reading goes on to the DDS thread for the
/// observer and recordings (a full queue drops).
pub(super) struct Readings {
    pub(super) sub: ros2_client::Subscription<SpindleEncoder>,
    pub(super) to_dds: rt_queue::Tx<SpindleEncoder>,
}

impl Readings {
    /// The next reading taken, if any (one that cannot be read is passed
    /// over).
    fn next(&mut self) -> Option<EncoderSample> {
        // (at most the cache's depth, so a stream of unreadable samples
        // cannot hold the loop)
        for _ in 0..=ros::STREAM_DEPTH {
            match ros::take_now(&self.sub) {
                Ok(Some((m, _))) => {
                    let e = EncoderSample {
                        stamp_ns: time_ns(&m.stamp),
                        count: m.count,
                        counts_per_rev: m.counts_per_rev,
                        index_count: m.index_count,
                        count_at_index: m.count_at_index,
                    };
                    self.to_dds.push(m);
                    return Some(e);
                }
                Ok(None) => return None,
                Err(_) => continue,
            }
        }
        None
    }
}

/// The setpoints and the spindle command, published by the cycle that
/// computes them, as the simulator's loop publishes its joint states and
/// readings. Handed to the DDS thread, each setpoint cost a wake-up of
/// that thread a cycle (about a fifth of a running node's CPU time at 1
/// kHz, BENCHMARKS.md "CPU per machine"); now that thread takes the
/// cycles' samples a few at a time, for the status, the action, the
/// observer and recordings. A publish serializes the message and adds it
/// to the writer's send window under its lock (both publishers fail at
/// once when the window is full: `ros::publisher_with_window`, the
/// default profile), then rings the DDS event loop, which runs below the
/// loop's priority and sends it.
pub(super) struct Commands {
    setpoints: ros2_client::Publisher<JointState>,
    spindle: ros2_client::Publisher<Float64>,
    /// the joints' names, in the machine's order
    names: Vec<String>,
    /// the spindle speed last published, rpm, and the cycle it went out in
    spindle_sent: Option<(f64, u64)>,
    /// cycles after which the spindle command goes out again
    spindle_again: u64,
}

/// The spindle command is published on change and at least this often:
/// the topic is volatile, and a simulator (or drive bridge) that starts
/// while the spindle turns would otherwise never hear the command.
const SPINDLE_REPEAT_S: f64 = 0.1;
/// It goes out again with the first published cycle this long after the
/// last: at rest the cycles publish every 20 ms only
/// (`ros::REST_RATE_HZ`), so the next one goes out within
/// [`SPINDLE_REPEAT_S`].
const SPINDLE_AGAIN_S: f64 = SPINDLE_REPEAT_S - 1.0 / ros::REST_RATE_HZ;

impl Commands {
    /// The publishers of the setpoints of the joints `names` and of the
    /// spindle command, for cycles `dt` s apart.
    pub(super) fn new(
        setpoints: ros2_client::Publisher<JointState>,
        spindle: ros2_client::Publisher<Float64>,
        names: Vec<String>,
        dt: f64,
    ) -> Self {
        Commands {
            setpoints,
            spindle,
            names,
            spindle_sent: None,
            spindle_again: (SPINDLE_AGAIN_S / dt).round().max(1.0) as u64,
        }
    }

    /// Publishes cycle `n`'s setpoints, stamped `stamp`, and the spindle
    /// command when it changed or is due again.
    fn publish(&mut self, n: u64, tick: &Tick, stamp: Time) {
        let _ = self
            .setpoints
            .publish(convert::joint_setpoints(tick, &self.names, stamp));
        let rpm = tick.spindle_rpm;
        let due = self
            .spindle_sent
            .is_none_or(|(last, at)| last != rpm || n >= at + self.spindle_again);
        if due {
            self.spindle_sent = Some((rpm, n));
            let _ = self.spindle.publish(convert::spindle_command(rpm));
        }
    }
}

/// A checked job waiting for its start (see [`Loop::cycle`]).
struct Pending {
    job: Job,
    rec: Option<Rec>,
    reply: Sender<Result<(), String>>,
    since: u64,
}

/// What the control loop owns besides the controller.
struct Loop {
    ctl: Controller,
    cmds: CmdRx<Cmd>,
    encoder: Readings,
    actual: rt_queue::Rx<ActualSample>,
    out: rt_queue::Tx<Out>,
    commands: Commands,
    here: Arc<[AtomicU64; 3]>,
    state: Arc<AtomicU32>,
    /// the cycles of the last status and of the last one sent for a line
    /// change, and how many cycles apart they go at most and at least
    last_status: Option<u64>,
    line_change: u64,
    status_every: u64,
    line_every: u64,
    dropped: u64,
    pending_rec: Option<(u32, Rec)>,
    /// the newest encoder reading's age at each cycle of a job (logged
    /// with loop_stats)
    enc_age: Option<ros::Lateness>,
    newest_enc: i64,
    /// how long before its stamp a cycle runs, ns
    /// ([`Grid::runs_early_by`]). The
    /// phase against the readings is taken at that instant, not at the
    /// stamp: on a host whose sleeps end late at random the margin grows
    /// to 150 µs, and a grid lined up by its stamps ran its cycles that
    /// much closer to the readings they wait for
    run_early_ns: i64,
    /// how the readings reached the running job's cycles (logged at its end)
    job_readings: JobReadings,
    /// at rest: the phase against the readings ([`phase_of`]) at the first
    /// of the readings in a row that kept to it, and how many, and a move
    /// of the grid asked for ([`phase_delay`])
    phase_run: Option<(i64, u32)>,
    rephase: Option<i64>,
    /// when the samples go out: every cycle while a job runs (and a
    /// second after), else at the resting rate
    pace: ros::Pace,
    pending: Option<Pending>,
    /// after the loop fell behind or kept its CPU: no job starts, and it
    /// wakes at the resting rate, until this ends
    give_way: GiveWay,
    /// why the running job ends at the next cycle (the loop gave way)
    end_job: Option<String>,
    /// a request is being checked (a job may follow)
    checking: Arc<AtomicBool>,
    has_spindle: bool,
    period_ns: i64,
    max_wait: u64,
}

pub(super) fn control_loop(
    machine: Machine,
    cmds: CmdRx<Cmd>,
    (encoder, actual): (Readings, rt_queue::Rx<ActualSample>),
    (out, commands): (rt_queue::Tx<Out>, Commands),
    here: Arc<[AtomicU64; 3]>,
    (state, checking): (Arc<AtomicU32>, Arc<AtomicBool>),
    live: Arc<Live>,
) {
    let dt = machine.dt();
    let mut stats = live.loop_stats();
    let period = Duration::from_secs_f64(dt);
    let mut lateness = ros::Lateness::new();
    let mut stats_due = Instant::now() + stats.unwrap_or_default();
    // (a cycle computes from its stamp, so it may run when the sleep ends,
    // a few tens of µs early, instead of spinning to its instant)
    let mut grid = Grid::new(Instant::now() + period, dt).running_early();
    let mut clock = WallClock::new();
    // (how far the system clock has moved against the monotonic one since
    // it was last logged, ns, and when that was)
    let (mut clock_moved, mut clock_logged) = (0i128, None::<Instant>);
    let has_spindle = machine.spindle.is_some();
    let mut lp = Loop {
        pace: ros::Pace::new(machine.interpolation.rate_hz),
        pending: None,
        checking,
        has_spindle,
        period_ns: (dt * 1e9).round() as i64,
        max_wait: (MAX_START_WAIT_S / dt).ceil() as u64,
        ctl: Controller::new(machine),
        cmds,
        encoder,
        actual,
        out,
        commands,
        here,
        state,
        last_status: None,
        line_change: 0,
        status_every: (0.1 / dt).round().max(1.0) as u64,
        line_every: (0.02 / dt).round().max(1.0) as u64,
        dropped: 0,
        pending_rec: None,
        enc_age: Some(ros::Lateness::new()),
        newest_enc: 0,
        run_early_ns: 0,
        job_readings: JobReadings::default(),
        phase_run: None,
        rephase: None,
        give_way: GiveWay::default(),
        end_job: None,
    };
    let mut idle = IdleShare::new(Instant::now(), ros::thread_cpu_time());
    let mut last_idle = None;
    loop {
        // cycles are meant for the instants of a fixed grid and stamped
        // with them (in the wall clock, as the simulator stamps the
        // encoder): stamp differences are exact periods, and a late
        // wake-up runs the missed cycles, catching up. At rest (no job for
        // a second) the loop wakes only for the cycles that publish and
        // skips the ones between (an idle cycle computes and publishes
        // nothing); a command waits at most a resting period
        let resting = lp.resting(grid.next()) || lp.give_way.active(grid.next());
        let target = if resting {
            lp.pace.next_due(grid.next())
        } else {
            grid.next()
        };
        let target = lp.give_way.target(grid.next(), lp.pace.every(), target);
        let intended = target + 1 - grid.next();
        let deadline = grid.wait_for(target);
        let now = Instant::now();
        if stats.is_some() {
            lateness.record(now.saturating_duration_since(deadline));
        }
        // (woken early, the cycle it woke for is due)
        let mut due = grid.due(now.max(deadline));
        if (due + 1).saturating_sub(intended) as f64 * dt > MAX_BEHIND_S {
            let why = format!(
                "the control loop fell {:.0} ms behind; {} cycles skipped",
                due as f64 * dt * 1000.0,
                due - 1
            );
            LOOP.skipped(due - 1);
            grid.skip(due - 1);
            due = 1;
            lp.give_way(grid.next(), 1.0 / dt, &why);
        }
        if resting && due > 1 {
            grid.skip(due - 1);
            due = 1;
        }
        LOOP.wake(
            now.saturating_duration_since(deadline),
            due.min(CATCH_UP),
            dt,
        );
        clock_moved += clock.update();
        if clock_moved.abs() >= CLOCK_MOVE_LOG_NS
            && clock_logged.is_none_or(|t: Instant| t.elapsed() >= Duration::from_secs(1))
        {
            // (stamps follow the system clock: a stamp this far off the
            // grid a subscriber sees is this, not the loop)
            ros_info!(
                "the system clock moved {:+.1} µs against the monotonic clock; the stamps follow it",
                clock_moved as f64 / 1000.0
            );
            (clock_moved, clock_logged) = (0, Some(Instant::now()));
        }
        lp.run_early_ns = grid.runs_early_by().as_nanos() as i64;
        for _ in 0..due.min(CATCH_UP) {
            let n = grid.advance();
            let stamp = clock.stamp(grid.at(n));
            if !lp.cycle(n, stamp) {
                return;
            }
        }
        // a loop that keeps its CPU gives way (its job ends)
        if let Some(share) = idle.check(Instant::now(), ros::thread_cpu_time) {
            last_idle = Some(share);
            if share < MIN_IDLE_SHARE && !lp.give_way.active(grid.next()) {
                let why = format!(
                    "the control loop cannot keep {:.0} Hz on this host: it left its CPU {:.1} % of the last {:.0} ms (it must leave {:.0} %)",
                    1.0 / dt,
                    share * 100.0,
                    IDLE_WINDOW_S * 1000.0,
                    MIN_IDLE_SHARE * 100.0
                );
                lp.give_way(grid.next(), 1.0 / dt, &why);
                lp.end_job = Some(why);
            }
        }
        // at rest, the cycles lined up with the encoder's sampling
        if let Some(d) = lp.rephase.take() {
            if lp.resting(grid.next()) {
                grid.delay(Duration::from_nanos(d as u64));
                ros_info!(
                    "control cycles moved {} us later: they now come {:.0} us after the encoder's sampling",
                    d / 1000,
                    ENCODER_PHASE * dt * 1e6
                );
            }
        }
        let now_stats = live.loop_stats();
        if now_stats != stats {
            // (loop_stats set while the node runs: from now on)
            stats = now_stats;
            stats_due = Instant::now() + stats.unwrap_or_default();
        }
        if let Some(every) = stats {
            if Instant::now() >= stats_due {
                stats_due += every;
                ros_info!(
                    "loop lateness {}; wakes {} us early; left its CPU {}",
                    lateness.summary(),
                    grid.margin().as_micros(),
                    last_idle.map_or("-".to_string(), |s| format!(
                        "{:.1} % of the last {:.0} ms",
                        s * 100.0,
                        IDLE_WINDOW_S * 1000.0
                    ))
                );
                if let Some(a) = &lp.enc_age {
                    if a.count() > 0 {
                        ros_info!("encoder reading age {}", a.summary());
                    }
                }
            }
        }
    }
}

/// How the spindle encoder's readings reached a job's cycles: how many
/// cycles there were, how many ran without their period's reading (the
/// newest they had was older than a period: the cycles come half a period
/// after the sampling, so their period's had not come yet), and the
/// newest reading's largest age, ns. Logged at the job's end, so that a
/// thread's measurement can tell a transport that held the readings back
/// (the tracker then predicts from older readings, further ahead) from
/// the controller's own error.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct JobReadings {
    job: u32,
    cycles: u64,
    without: u64,
    oldest_ns: i64,
}

impl JobReadings {
    fn record(&mut self, age_ns: i64, period_ns: i64) {
        self.cycles += 1;
        if age_ns > period_ns {
            self.without += 1;
        }
        self.oldest_ns = self.oldest_ns.max(age_ns);
    }

    /// The log line (None: no job, or no readings in it).
    fn summary(&self, period_ns: i64) -> Option<String> {
        (self.job != 0 && self.cycles > 0).then(|| {
            format!(
                "job {}: encoder readings at its {} cycles: {} without their period's reading, \
                 the newest up to {:.1} ms old (period {:.1} ms)",
                self.job,
                self.cycles,
                self.without,
                self.oldest_ns as f64 * 1e-6,
                period_ns as f64 * 1e-6
            )
        })
    }
}

impl Loop {
    /// The loop gives way from cycle `next` ([`GiveWay`]) for `why`, which
    /// it logs with what giving way does.
    fn give_way(&mut self, next: u64, rate_hz: f64, why: &str) {
        ros_error!(
            "{why}; it gives way to the node's other threads for {GIVE_WAY_S} s (no job starts; it wakes {} times a second)",
            ros::REST_RATE_HZ
        );
        self.give_way.start(next, rate_hz);
    }

    /// At rest at cycle `n`: no job, none starting, and none for a second.
    fn resting(&self, n: u64) -> bool {
        self.pace.resting(n)
            && self.pending.is_none()
            && self.ctl.job_id() == 0
            && !self.checking.load(Ordering::Relaxed)
    }

    /// One control cycle, `n`, for the instant `stamp`; false: the node is
    /// gone.
    ///
    /// A job on a machine with a spindle starts once the newest encoder
    /// reading is fresh (at most [`FRESH_PERIODS`] old), waiting up to
    /// [`MAX_START_WAIT_S`]: a simulator at rest publishes its readings at
    /// the resting rate only, and turns to every step when the setpoints
    /// come every cycle, as they do from the moment a job waits (its
    /// readings reach the loop a few ms later). Without the wait a G95 or
    /// G33 block at a job's start could see a reading 20 ms old and take
    /// the encoder for lost.
    fn cycle(&mut self, n: u64, stamp: Time) -> bool {
        loop {
            match self.cmds.try_recv() {
                Ok(Cmd::Start(job, rec, reply)) => {
                    if let Some(p) = self.pending.take() {
                        let _ = p.reply.send(Err("another job is starting".into()));
                    }
                    self.pending = Some(Pending {
                        job,
                        rec,
                        reply,
                        since: n,
                    });
                }
                Ok(Cmd::Abort(reply)) => {
                    let _ = reply.send(self.ctl.abort());
                }
                Ok(Cmd::Hold(on, reply)) => {
                    let _ = reply.send(self.ctl.feed_hold(on));
                }
                Ok(Cmd::Override(pct)) => {
                    if let Err(e) = self.ctl.set_feed_override(pct) {
                        ros_warn!("{e}");
                    }
                }
                Err(NoCmd::Empty) => break,
                Err(NoCmd::Gone) => return false,
            }
        }
        let now_ns = time_ns(&stamp);
        let mut read = false;
        while let Some(e) = self.encoder.next() {
            self.newest_enc = self.newest_enc.max(e.stamp_ns);
            self.ctl.encoder(e);
            read = true;
        }
        if read && self.resting(n) {
            let phase = phase_of(
                run_instant(now_ns, self.run_early_ns),
                self.newest_enc,
                self.period_ns,
            );
            let (still, period) = ((PHASE_STILL * self.period_ns as f64) as i64, self.period_ns);
            let near = |p: i64| {
                let d = (phase - p).rem_euclid(period);
                d.min(period - d) <= still
            };
            self.phase_run = match self.phase_run {
                Some((p, k)) if near(p) => Some((p, k + 1)),
                _ => Some((phase, 1)),
            };
            let steady = self.phase_run.is_some_and(|(_, k)| k >= PHASE_READINGS);
            self.rephase = phase_delay(phase, period).filter(|_| steady);
            if self.rephase.is_some() {
                self.phase_run = None;
            }
        }
        while let Ok(Some(a)) = self.actual.pop() {
            self.ctl.actual(a);
        }
        if let Some(p) = self.pending.take() {
            let fresh = self.newest_enc >= now_ns - FRESH_PERIODS * self.period_ns;
            // (a job running: the start is refused at once)
            let now = !self.has_spindle || self.ctl.job_id() != 0;
            if self.give_way.active(n) {
                // (it waits, as for its readings; its cycles could not run)
                self.pending = Some(Pending { since: n, ..p });
            } else if now || fresh || n - p.since >= self.max_wait {
                let id = p.job.id;
                let r = self.ctl.start(p.job);
                if r.is_ok() {
                    self.pending_rec = p.rec.map(|r| (id, r));
                }
                let _ = p.reply.send(r);
            } else {
                self.pending = Some(p);
            }
        }
        let in_job = self.ctl.job_id() != 0;
        if self.job_readings.job != self.ctl.job_id() {
            if let Some(line) = self.job_readings.summary(self.period_ns) {
                ros_info!("{line}");
            }
            self.job_readings = JobReadings {
                job: self.ctl.job_id(),
                ..JobReadings::default()
            };
        }
        // the newest reading's age at a job's cycle: for loop_stats and
        // for the job's own line
        if in_job && self.newest_enc > 0 {
            let age = now_ns - self.newest_enc;
            if let Some(a) = self.enc_age.as_mut() {
                a.record(Duration::from_nanos(age.max(0) as u64));
            }
            self.job_readings.record(age, self.period_ns);
        }
        let prev_state = self.ctl.state();
        if let Some(why) = self.end_job.take() {
            self.ctl.end_job(&why);
        }
        let tick = self.ctl.tick(now_ns);
        for j in 0..tick.n {
            self.here[j].store(tick.positions[j].to_bits(), Ordering::Relaxed);
        }
        self.state.store(tick.state as u32, Ordering::Relaxed);
        // status: on a state change at once, on a line change at most 50 Hz,
        // and at least 10 Hz (counted in cycles: each is meant for its instant)
        let due = tick.state != prev_state
            || self.last_status.is_none_or(|l| n >= l + self.status_every)
            || (tick.changed && n >= self.line_change + self.line_every);
        let status = due.then(|| {
            self.last_status = Some(n);
            self.line_change = n;
            self.ctl.status()
        });
        let busy = in_job
            || self.ctl.job_id() != 0
            || self.pending.is_some()
            || self.checking.load(Ordering::Relaxed);
        if busy || tick.state != prev_state {
            self.pace.busy(n);
        }
        let recorder = self.pending_rec.take();
        let setpoints = self.pace.due(n) || recorder.is_some();
        if !(setpoints || status.is_some()) {
            return true;
        }
        if setpoints {
            self.commands.publish(n, &tick, stamp);
        }
        let o = Out {
            stamp,
            tick,
            place: self.ctl.place(),
            status,
            job: self.ctl.job_id(),
            recorder,
        };
        if !self.out.push(o) {
            self.dropped += 1;
            LOOP.dropped(1);
            if self.dropped.is_power_of_two() {
                ros_error!("publisher queue full, {} samples dropped", self.dropped);
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_s_readings_count_the_cycles_without_their_period_s_reading() {
        let mut r = JobReadings {
            job: 7,
            ..JobReadings::default()
        };
        assert_eq!(JobReadings::default().summary(1_000_000), None);
        assert_eq!(r.summary(1_000_000), None);
        // on time (half a period), a cycle late, then 8 ms held back
        for age in [500_000, 500_000, 1_500_000, 8_500_000, 500_000] {
            r.record(age, 1_000_000);
        }
        assert_eq!(
            r.summary(1_000_000).unwrap(),
            "job 7: encoder readings at its 5 cycles: 2 without their period's reading, \
             the newest up to 8.5 ms old (period 1.0 ms)"
        );
    }

    #[test]
    fn a_loop_that_fell_behind_wakes_at_the_resting_rate_for_a_second() {
        // 20 kHz: resting cycles are 400 apart (50 Hz)
        let (rate, every) = (20_000.0, 400);
        let mut g = GiveWay::default();
        assert!(!g.active(0));
        assert_eq!(g.target(7, every, 7), 7);
        g.start(16_903, rate);
        assert_eq!(g.until, 36_903);
        assert!(g.active(16_903) && g.active(36_902) && !g.active(36_903));
        // the next cycle the loop wakes for: the next of the resting grid
        assert_eq!(g.target(16_903, every, 16_903), 17_200);
        assert_eq!(g.target(17_200, every, 17_200), 17_200);
        assert_eq!(g.target(36_801, every, 36_801), 37_200);
        // over: the cycle the loop wanted
        assert_eq!(g.target(36_903, every, 36_903), 36_903);
        // at 1 kHz, a second is 1000 cycles
        g.start(5, 1000.0);
        assert_eq!(g.until, 1005);
    }

    #[test]
    fn the_idle_share_is_taken_over_windows_of_400_ms() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut w = IdleShare::new(t0, ms(5));
        // the window lasts: no share yet (and no CPU time asked for)
        assert_eq!(w.check(t0 + ms(399), || unreachable!()), None);
        // 400 ms, 380 of them on the CPU: 5 % left
        let share = w.check(t0 + ms(400), || ms(385)).unwrap();
        assert!((share - 0.05).abs() < 1e-12, "{share}");
        assert!(share < MIN_IDLE_SHARE);
        // the next window starts there: 500 ms, 50 on the CPU
        assert_eq!(w.check(t0 + ms(700), || unreachable!()), None);
        let share = w.check(t0 + ms(900), || ms(435)).unwrap();
        assert!((share - 0.9).abs() < 1e-12, "{share}");
        // (more CPU time than wall time, a clock's rounding: none left)
        assert_eq!(w.check(t0 + ms(1300), || ms(900)), Some(0.0));
    }
}
