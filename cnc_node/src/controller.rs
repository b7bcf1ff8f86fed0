//! The controller behind the node: jobs, feed hold, abort, and one sample
//! per interpolation cycle. No DDS, no clocks: the node's loop calls
//! [`Controller::tick`] at its fixed rate with the time the cycle's sample
//! is for, hands it the spindle encoder's readings with
//! [`Controller::encoder`], and tests call both directly.
//!
//! Times are nanoseconds of one clock, the one the node stamps its
//! setpoints with, the encoder stamps its readings with and the machine
//! stamps its joint states with ([`Controller::actual`]; the system
//! clock of the host both nodes run on). A job's executor counts time from
//! its sample 0: a reading stamped `s` is given to it at
//! `t = (s − stamp of the job's sample 0) s`, and sample k is meant for
//! `t = k·dt` — so the loop must call [`Controller::tick`] exactly one
//! period apart in that clock (the node keeps its cycles on a fixed grid
//! and catches up after a late wake-up).

use crate::program::OwnedSource;
use cnc_core::exec::{Executor, Sync as ThreadSync};
use cnc_core::tracker::EncoderReading;
use cnc_core::{Dialect, Machine};
use cnc_msgs::ros;

/// Controller states, as in `cnc_msgs/ControllerStatus`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Idle = 0,
    Running = 1,
    Hold = 2,
    Error = 3,
}

/// A checked program ready to run.
pub struct Job {
    pub id: u32,
    pub text: Vec<u8>,
    pub dialect: Dialect,
    /// the check's estimate, ticks
    pub ticks: u64,
    /// the joint positions the check ran from, mm, in joint order (as
    /// [`Controller::positions`]): [`Controller::start`] refuses the job
    /// unless the machine stands exactly there
    pub start: Vec<f64>,
}

/// What the status topic shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    pub state: State,
    pub job_id: u32,
    pub source_line: u32,
    pub block_number: i64,
    pub active_g_codes: Vec<String>,
    pub active_tool: i32,
    pub spindle_rpm: f64,
    pub feed_override: f64,
    pub progress: f64,
    pub last_error: String,
}

/// Where the running (or last) job is in its program, as the status shows
/// it: cheap to take every cycle (no allocation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Place {
    /// 1-based line being executed, 0 before any
    pub line: u32,
    /// its N number, −1 if none
    pub block: i64,
    /// samples run ÷ samples estimated, 0..1
    pub progress: f64,
}

/// A reading of the spindle encoder (`cnc_msgs/SpindleEncoder`), stamped
/// in the controller's clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EncoderSample {
    /// when the count was latched, ns
    pub stamp_ns: i64,
    /// accumulated counts, signed
    pub count: i64,
    pub counts_per_rev: u32,
    /// index pulses seen
    pub index_count: i64,
    /// the count at the last index pulse
    pub count_at_index: i64,
}

/// The actual joint positions (`/sim/joint_states`), stamped in the
/// controller's clock.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ActualSample {
    /// the instant the positions are for, ns
    pub stamp_ns: i64,
    /// mm, in joint order (the first `n` entries)
    pub positions: [f64; 3],
    pub n: usize,
}

/// A thread stops when its lead axis, as the machine reports it, trails
/// or leads the thread line by more than this, degrees of the spindle:
/// the drives apply the setpoints later (or earlier) than the setpoint
/// delay the thread leads by, and the groove moves. The machine file's
/// `spindle.thread_phase_limit_deg` changes it.
pub const THREAD_PHASE_LIMIT_DEG: f64 = 2.0;
/// ... in the median of the last this many joint states (so a few late
/// setpoints, which the axis makes up within milliseconds, do not stop it).
const PHASE_MEDIAN: usize = 50;
/// ... from this many time constants of the lead axis's servo (1/kp and
/// the velocity lag) after the thread reached its line, when the
/// following error of the run-in's acceleration has died away.
const SETTLE_TIME_CONSTANTS: f64 = 5.0;
/// Setpoints kept for comparing the joint states with: at 1 kHz, 1 s.
const HISTORY: usize = 1024;

/// How many recent readings the controller keeps for a job's start (a G95
/// or G33 right at the start has the spindle's history at once): more
/// than the executor's tracker fits.
const RECENT: usize = 64;

/// One cycle's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// setpoints in joint order, mm (the first `n` entries)
    pub positions: [f64; 3],
    pub n: usize,
    /// commanded spindle speed, rpm, signed
    pub spindle_rpm: f64,
    pub state: State,
    /// the state or the executing line changed in this cycle
    pub changed: bool,
}

struct Running {
    id: u32,
    exec: Executor<OwnedSource>,
    ticks: u64,
    k: u64,
    aborting: bool,
    /// the time of the job's sample 0, ns (set by its first tick)
    t0_ns: Option<i64>,
    /// the last [`HISTORY`] samples' positions (mm, machine coordinates)
    /// and, on a thread's line, what they follow; by tick, k % HISTORY
    hist: Vec<(cnc_core::geom::V3, Option<ThreadSync>)>,
    /// the lead axis's last phases against its setpoints, degrees (ring),
    /// and how many there are since the thread settled on its line
    phase: [f64; PHASE_MEDIAN],
    phase_n: usize,
    /// stopping after a fault the controller found
    stopping: bool,
    /// the tick since which the samples are on a thread's line
    line_since: Option<u64>,
}

pub struct Controller {
    joints: Vec<usize>,
    machine: Machine,
    state: State,
    job: Option<Running>,
    positions: [f64; 3],
    spindle_rpm: f64,
    tool: u32,
    line: u32,
    block: Option<u64>,
    gcodes: Option<[&'static str; 4]>,
    last_job: u32,
    last_error: String,
    progress: f64,
    feed_override: f64,
    /// the latest encoder readings (ring), for the next job's start
    recent: [EncoderSample; RECENT],
    recent_head: usize,
    recent_len: usize,
}

impl Controller {
    pub fn new(machine: Machine) -> Self {
        let joints = machine.joint_indices();
        let home = machine.home();
        let mut positions = [0.0; 3];
        for (j, &i) in joints.iter().enumerate() {
            positions[j] = home[i];
        }
        Controller {
            joints,
            machine,
            state: State::Idle,
            job: None,
            positions,
            spindle_rpm: 0.0,
            tool: 0,
            line: 0,
            block: None,
            gcodes: None,
            last_job: 0,
            last_error: String::new(),
            progress: 0.0,
            feed_override: 1.0,
            recent: [EncoderSample::default(); RECENT],
            recent_head: 0,
            recent_len: 0,
        }
    }

    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// The running job's id, 0 when idle.
    pub fn job_id(&self) -> u32 {
        self.job.as_ref().map_or(0, |r| r.id)
    }

    /// The setpoints the machine stands at (or moves through), mm, in joint
    /// order: where a job started now starts from.
    pub fn positions(&self) -> &[f64] {
        &self.positions[..self.joints.len()]
    }

    /// Starts a checked job; refused while another runs, and refused when
    /// the machine no longer stands where the job was checked from
    /// ([`Job::start`]).
    ///
    /// The start is compared exactly (tolerance 0: every joint's f64
    /// equal): an idle machine's setpoints do not change, so any
    /// difference means a job moved it after the check began (a request
    /// that arrived during a job which ended before its check did). A
    /// program means something else from another start (G91 moves go
    /// elsewhere, a first G00 takes another path), and checking it again
    /// here would hold up the control loop for as long as the check takes:
    /// the job is refused, nothing moves, and the client sends it again.
    pub fn start(&mut self, job: Job) -> Result<(), String> {
        if let Some(r) = &self.job {
            return Err(format!(
                "job {} is running; wait for its end or abort it (nothing was queued)",
                r.id
            ));
        }
        if job.start.as_slice() != self.positions() {
            return Err(format!(
                "the machine moved since the program was checked: checked from {}, now at {} (mm); send it again",
                self.joint_text(&job.start),
                self.joint_text(self.positions())
            ));
        }
        // a job starts where the machine stands: the program's first move
        // runs from the last setpoint
        let m = self
            .machine
            .starting_at(&self.positions[..self.joints.len()]);
        let src = OwnedSource::owned(job.text).with_max_line(m.limits.max_line_bytes);
        let mut exec = Executor::new(src, job.dialect, &m);
        // the drives apply each setpoint this long after its instant: G33
        // leads by it (and by the servo's lag)
        exec.set_setpoint_delay(m.setpoint_delay_s());
        // G33 and G95 follow the measured spindle (readings from
        // `encoder`); a machine without a spindle has nothing to follow
        if self.machine.spindle.is_some() {
            exec.attach_encoder();
        }
        exec.set_feed_target(self.feed_override);
        // the path planner works ahead on threads of their own, below the
        // loop's real-time priority (they would inherit it)
        exec.plan_ahead(|| {
            let _ = ros::set_normal();
        });
        self.job = Some(Running {
            id: job.id,
            exec,
            ticks: job.ticks.max(1),
            k: 0,
            aborting: false,
            t0_ns: None,
            hist: Vec::with_capacity(HISTORY),
            phase: [0.0; PHASE_MEDIAN],
            phase_n: 0,
            stopping: false,
            line_since: None,
        });
        self.last_job = job.id;
        self.last_error.clear();
        self.progress = 0.0;
        self.state = State::Running;
        Ok(())
    }

    /// A reading of the spindle encoder: kept for the next job's start and
    /// given to the running job's executor in its time base. Call it before
    /// the [`Controller::tick`] that should see it.
    pub fn encoder(&mut self, e: EncoderSample) {
        self.recent_head = (self.recent_head + 1) % RECENT;
        self.recent[self.recent_head] = e;
        self.recent_len = (self.recent_len + 1).min(RECENT);
        if let Some(r) = self.job.as_mut() {
            if let Some(t0) = r.t0_ns {
                r.exec.encoder(reading(e, t0));
            }
        }
    }

    /// The machine's actual positions at an instant (the joint states).
    /// During a thread the lead axis is compared with the setpoint of
    /// `ahead` earlier (the setpoint delay and the servo lag it leads by,
    /// interpolated between the cycles around it): the median of the last
    /// [`PHASE_MEDIAN`] joint states beyond [`THREAD_PHASE_LIMIT_DEG`] (or
    /// the machine file's `spindle.thread_phase_limit_deg`)
    /// stops the thread under control and ends the job in error.
    pub fn actual(&mut self, a: ActualSample) {
        let dt = self.machine.dt();
        let line = self.line;
        let Some(r) = self.job.as_mut() else {
            return;
        };
        let (Some(t0), false) = (r.t0_ns, r.stopping) else {
            return;
        };
        let at = |k: u64| r.hist.get((k % HISTORY as u64) as usize).copied();
        // the newest sample's instant, and the one the actual stands for
        let Some(newest) = r.k.checked_sub(1) else {
            return;
        };
        let Some((_, Some(sync))) = at(newest) else {
            r.phase_n = 0;
            return;
        };
        let kf = ((a.stamp_ns - t0) as f64 * 1e-9 - sync.ahead) / dt;
        if !(kf.is_finite() && kf >= 0.0) {
            return;
        }
        let k0 = kf.floor() as u64;
        // the axis settles onto the line after the run-in's acceleration
        let settle = self.machine.axis(sync.lead).map_or(0.0, |ax| {
            SETTLE_TIME_CONSTANTS * (1.0 / ax.servo_kp + ax.servo_lag_s)
        });
        if r.line_since
            .is_none_or(|k| (k0 as f64) < k as f64 + settle / dt)
        {
            return;
        }
        if k0 + 1 > newest || newest - k0 >= HISTORY as u64 - 1 {
            return;
        }
        let (Some((p0, Some(s0))), Some((p1, Some(s1)))) = (at(k0), at(k0 + 1)) else {
            return;
        };
        let Some(j) = self.joints.iter().position(|&i| i == sync.lead) else {
            return;
        };
        if !(s0.on_line && s1.on_line) || s0.lead != sync.lead || s1.lead != sync.lead {
            return;
        }
        let f = kf - k0 as f64;
        let want = p0[sync.lead] + f * (p1[sync.lead] - p0[sync.lead]);
        let off = sync.lead_sign * (a.positions[j] - want);
        let deg = off / sync.pitch * 360.0;
        if !deg.is_finite() || j >= a.n {
            return;
        }
        r.phase[r.phase_n % PHASE_MEDIAN] = deg;
        r.phase_n += 1;
        if r.phase_n < PHASE_MEDIAN {
            return;
        }
        let mut sorted = r.phase;
        sorted.sort_unstable_by(f64::total_cmp);
        let median = sorted[PHASE_MEDIAN / 2];
        let limit = self
            .machine
            .spindle
            .as_ref()
            .and_then(|s| s.thread_phase_limit_deg)
            .unwrap_or(THREAD_PHASE_LIMIT_DEG);
        if median.abs() > limit {
            // how late the axis follows its setpoints
            let v = sync.lead_sign * (p1[sync.lead] - p0[sync.lead]) / dt;
            let late = sync.ahead - median / 360.0 * sync.pitch / v;
            let why = format!(
                "line {}: the {} axis is {:.1}° {} the thread line: the machine follows its setpoints {:.1} ms after their instant, not the {:.1} ms the thread leads by (interpolation.setpoint_delay_ms and the servo's lag); the thread stopped",
                line,
                ["X", "Y", "Z"][sync.lead.min(2)],
                median.abs(),
                if median < 0.0 { "behind" } else { "ahead of" },
                late * 1e3,
                sync.ahead * 1e3,
            );
            r.stopping = true;
            r.exec.stop(why);
        }
    }

    /// Decelerates along the path (a thread under control, at its lead
    /// acceleration), then ends the job.
    pub fn abort(&mut self) -> Result<String, String> {
        match self.job.as_mut() {
            Some(r) => {
                r.aborting = true;
                r.exec.abort();
                Ok(format!("job {} stopping", r.id))
            }
            None => Ok("no job running".into()),
        }
    }

    /// The feed override in percent, 0..=200 (0 stops on the path like a
    /// hold, but the state stays running); it applies to the running job
    /// at once and to later jobs. Anything else is refused and changes
    /// nothing.
    pub fn set_feed_override(&mut self, percent: f64) -> Result<(), String> {
        let max = cnc_core::exec::MAX_OVERRIDE * 100.0;
        if !(percent.is_finite() && (0.0..=max).contains(&percent)) {
            return Err(format!(
                "feed override {percent} % refused: expected 0 to {max} %"
            ));
        }
        self.feed_override = percent / 100.0;
        if let Some(r) = self.job.as_mut() {
            if !r.aborting && self.state != State::Hold {
                r.exec.set_feed_target(self.feed_override);
            }
        }
        Ok(())
    }

    /// `true`: decelerate and hold on the path; `false`: resume.
    pub fn feed_hold(&mut self, on: bool) -> Result<String, String> {
        let ovr = self.feed_override;
        match self.job.as_mut() {
            Some(r) if r.aborting => Err(format!("job {} is being aborted", r.id)),
            Some(r) => {
                r.exec.set_feed_target(if on { 0.0 } else { ovr });
                self.state = if on { State::Hold } else { State::Running };
                Ok(if on { "holding" } else { "resumed" }.into())
            }
            None if on => Err("no job running".into()),
            None => Ok("no job running".into()),
        }
    }

    /// One interpolation cycle: the sample for time `now_ns` (consecutive
    /// calls one period apart; the first of a job fixes its time base).
    pub fn tick(&mut self, now_ns: i64) -> Tick {
        let before = (self.state, self.line);
        let dt = self.machine.dt();
        if let Some(r) = self.job.as_mut() {
            match r.t0_ns {
                None => {
                    // sample 0: the readings so far, in the job's time
                    r.t0_ns = Some(now_ns);
                    for i in (0..self.recent_len).rev() {
                        let e = self.recent[(self.recent_head + RECENT - i) % RECENT];
                        r.exec.encoder(reading(e, now_ns));
                    }
                }
                Some(t0) => {
                    let off = (now_ns - t0) as f64 * 1e-9 - r.k as f64 * dt;
                    if off.abs() > 0.5 * dt {
                        // cycles were lost: the samples no longer stand for
                        // their instants (a thread would leave its groove)
                        self.end_job(&format!(
                            "the control loop fell {:.0} ms behind (cycles skipped)",
                            off * 1000.0
                        ));
                        return self.output(before);
                    }
                }
            }
            match r.exec.next_sample() {
                Some(s) => {
                    for (j, &i) in self.joints.iter().enumerate() {
                        self.positions[j] = s.pos[i];
                    }
                    self.spindle_rpm = s.spindle_rpm;
                    self.tool = s.tool;
                    self.line = s.src.line;
                    self.block = s.src.block_no;
                    self.gcodes = Some(r.exec.modal().gcodes());
                    let slot = (r.k % HISTORY as u64) as usize;
                    let entry = (s.pos, s.sync.filter(|y| y.on_line));
                    if entry.1.is_none() {
                        r.line_since = None;
                    } else if r.line_since.is_none() {
                        r.line_since = Some(r.k);
                    }
                    if slot < r.hist.len() {
                        r.hist[slot] = entry;
                    } else {
                        r.hist.push(entry);
                    }
                    r.k += 1;
                    self.progress = (r.k as f64 / r.ticks as f64).min(1.0);
                    let stopped = r.exec.at_rest();
                    if let (true, Some(why)) = (s.last || (r.stopping && stopped), r.exec.fault()) {
                        // the executor stopped the axes under control
                        let why = why.to_string();
                        self.fail(why);
                    } else if r.aborting && (stopped || s.last) {
                        self.last_error = format!("job {} aborted at line {}", r.id, s.src.line);
                        self.spindle_rpm = 0.0;
                        self.finish();
                    } else if s.last {
                        self.progress = 1.0;
                        self.finish();
                    }
                }
                None => match r.exec.fault().map(str::to_string) {
                    Some(why) => self.fail(why),
                    None => self.finish(),
                },
            }
        }
        self.output(before)
    }

    /// Joint positions as `X100 Z20` (mm, each exactly, in the shortest
    /// text that reads back as the same f64).
    fn joint_text(&self, p: &[f64]) -> String {
        self.joints
            .iter()
            .zip(p)
            .map(|(&i, v)| format!("{}{v}", ["X", "Y", "Z"].get(i).copied().unwrap_or("?")))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// This cycle's output, `before`: (state, line) at its start.
    fn output(&self, before: (State, u32)) -> Tick {
        Tick {
            positions: self.positions,
            n: self.joints.len(),
            spindle_rpm: self.spindle_rpm,
            state: self.state,
            changed: (self.state, self.line) != before,
        }
    }

    /// Why the running job's executor stops, if it does (it is still
    /// decelerating; the job ends in [`State::Error`] with this text).
    pub fn fault(&self) -> Option<&str> {
        self.job.as_ref().and_then(|r| r.exec.fault())
    }

    fn finish(&mut self) {
        self.job = None;
        self.state = State::Idle;
    }

    /// Ends the running job where it stands, in the error state, for a
    /// reason the control loop found (`why`, completed by the line and
    /// "the job ended where it stood"); nothing without a job.
    pub fn end_job(&mut self, why: &str) {
        if self.job.is_some() {
            let why = format!("line {}: {why}; the job ended where it stood", self.line);
            self.fail(why);
        }
    }

    /// Ends the job in the error state (lost signal, fault).
    pub fn fail(&mut self, why: String) {
        self.job = None;
        self.state = State::Error;
        self.spindle_rpm = 0.0;
        self.last_error = why;
    }

    /// The line, block and progress of the running (or last) job.
    pub fn place(&self) -> Place {
        Place {
            line: self.line,
            block: self.block.map_or(-1, |b| b as i64),
            progress: self.progress,
        }
    }

    pub fn status(&self) -> Status {
        let place = self.place();
        Status {
            state: self.state,
            job_id: self.last_job,
            source_line: place.line,
            block_number: place.block,
            active_g_codes: self
                .gcodes
                .map_or_else(Vec::new, |g| g.iter().map(|s| s.to_string()).collect()),
            active_tool: self.tool as i32,
            spindle_rpm: self.spindle_rpm,
            feed_override: self.feed_override,
            progress: place.progress,
            last_error: self.last_error.clone(),
        }
    }
}

/// An encoder sample in the executor's time base: seconds since the job's
/// sample 0 at `t0_ns`.
fn reading(e: EncoderSample, t0_ns: i64) -> EncoderReading {
    EncoderReading {
        t: (e.stamp_ns - t0_ns) as f64 * 1e-9,
        count: e.count,
        counts_per_rev: e.counts_per_rev,
        index_count: e.index_count,
        count_at_index: e.count_at_index,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    fn job(id: u32, text: &str, start: Vec<f64>) -> Job {
        Job {
            id,
            text: text.as_bytes().to_vec(),
            dialect: Dialect::Cnc836,
            ticks: 1,
            start,
        }
    }

    /// Ticks until the controller is idle again; the last setpoints.
    fn run_out(ctl: &mut Controller) -> Vec<f64> {
        let mut k = 0;
        while ctl.state() == State::Running && k < 100_000 {
            k += 1;
            ctl.tick(k * MS);
        }
        assert_eq!(ctl.state(), State::Idle, "{}", ctl.status().last_error);
        ctl.positions().to_vec()
    }

    #[test]
    fn a_job_starts_only_from_where_it_was_checked() {
        let mut ctl = Controller::new(Machine::builtin_mill());
        assert_eq!(ctl.positions(), [0.0, 0.0, 0.0]);
        ctl.start(job(1, "G01 X10 Y5 F6000\n", vec![0.0, 0.0, 0.0]))
            .unwrap();
        assert_eq!(run_out(&mut ctl), [10.0, 5.0, 0.0]);
        // checked at home, but the machine stands at X10 Y5 now
        let e = ctl
            .start(job(2, "G91 G01 X10 F600\n", vec![0.0, 0.0, 0.0]))
            .unwrap_err();
        assert_eq!(
            e,
            "the machine moved since the program was checked: checked from X0 Y0 Z0, now at X10 Y5 Z0 (mm); send it again"
        );
        assert_eq!(ctl.state(), State::Idle);
        assert_eq!(ctl.status().job_id, 1, "job 2 never started");
        assert_eq!(ctl.tick(1_000 * MS).positions, [10.0, 5.0, 0.0]);
        // a difference far below a display's resolution counts too
        let near = vec![10.0, 5.0 + 1e-12, 0.0];
        let e = ctl.start(job(2, "G91 G01 X10 F600\n", near)).unwrap_err();
        assert!(
            e.contains("checked from X10 Y5.000000000001 Z0, now at X10 Y5 Z0"),
            "{e}"
        );
        // a start of the wrong length never matches
        assert!(ctl
            .start(job(2, "G91 G01 X10 F600\n", vec![10.0, 5.0]))
            .is_err());
        // checked from where it stands: starts, and runs from there
        ctl.start(job(2, "G91 G01 X10 F600\n", vec![10.0, 5.0, 0.0]))
            .unwrap();
        assert_eq!(run_out(&mut ctl), [20.0, 5.0, 0.0]);
    }
}
