//! The `execute_program` action (`docs/ros_interface.md` §4.4): a job as a
//! ROS 2 action goal, next to the `run_program` service.
//!
//! [`Goals`] keeps the goals and decides what each one sees, without DDS:
//! - a new goal goes to the node's check worker as the `run_program`
//!   request it is (admission, `admit.rs`); the send_goal request is
//!   answered once the check and the start are done ([`Goals::checked`]).
//!   The protocol's rejection carries no text, so a refused goal is
//!   accepted and ends at once ABORTED, its result's `message` saying why
//!   (the check's errors, "job 3 is running ..."); nothing moved. A dry run
//!   succeeds at once with the estimate.
//! - the goal's job is followed in the control loop's samples
//!   ([`Goals::cycle`]): feedback every [`FEEDBACK_PERIOD_NS`] and once at
//!   the end; the job ending idle succeeds the goal, ending in error (or
//!   aborted by someone else: `abort`, `cnc abort`) aborts it;
//! - a cancel ([`Goals::cancel`]) aborts the goal's job, which stops under
//!   control along its path; the goal ends CANCELED where the axes stopped;
//! - results are kept for the last [`KEEP_DONE`] goals that ended; a result
//!   asked for before the end is sent at the end;
//! - the statuses go out at every change and every [`STATUS_PERIOD_NS`]
//!   while a goal runs.
//!
//! [`ExecuteProgram`] is the action server on the wire: ros2-client's
//! `ActionServer` (its three services and two topics, with rclpy's type
//! names), polled by the node's DDS thread; it implements [`Wire`].

use crate::admit::{fit_reply, MAX_REPLY_TEXT};
use crate::controller::{Place, State, Status, Tick};
use cnc_msgs::ros;
use cnc_msgs::{
    ExecuteProgramFeedback, ExecuteProgramGoal, ExecuteProgramResult, RunProgramRequest,
    RunProgramResponse,
};
use ros2_client::action::{
    ActionServer, CancelGoalRequest, CancelGoalResponse, GoalId, GoalInfo, GoalStatusEnum,
};
use ros2_client::action_msgs::{CancelGoalResponseEnum, GoalStatus, GoalStatusArray};
use ros2_client::builtin_interfaces::Time as RosTime;
use ros2_client::RmwRequestId;
use std::collections::VecDeque;

/// A goal's id (`unique_identifier_msgs/UUID`).
pub type GoalKey = [u8; 16];

/// Feedback of a running goal at most this often (20 Hz), in the
/// samples' time.
pub const FEEDBACK_PERIOD_NS: i64 = 50_000_000;

/// While a goal runs, the goals' statuses are published again this often
/// (500 ms), in the samples' time, besides at every change: rclpy's
/// action client drops a status that arrives before it has handled the
/// goal's acceptance (another topic), and its goal handle would stay
/// UNKNOWN (`ros2 action send_goal` then does not cancel on Ctrl-C).
pub const STATUS_PERIOD_NS: i64 = 500_000_000;

/// Goals that ended are kept (for their results) up to this many.
pub const KEEP_DONE: usize = 16;

/// Jobs that ended are remembered up to this many: a goal learns its
/// job's number after the job started, and a short job may have ended by
/// then.
const KEEP_JOBS: usize = 8;

/// Where a [`Goals`] sends what it decides: the action server's services
/// and topics ([`ExecuteProgram`]), or a recorder in tests.
pub trait Wire {
    /// The reply to a send_goal request.
    fn goal_response(&mut self, req: RmwRequestId, accepted: bool, stamp_ns: i64);
    /// The reply to a get_result request.
    fn result(&mut self, req: RmwRequestId, status: GoalStatusEnum, result: &ExecuteProgramResult);
    /// The reply to a cancel_goal request: the goals now canceling, with
    /// their acceptance stamps.
    fn cancel_response(
        &mut self,
        req: RmwRequestId,
        code: CancelGoalResponseEnum,
        canceling: &[(GoalKey, i64)],
    );
    fn feedback(&mut self, goal: GoalKey, feedback: ExecuteProgramFeedback);
    /// Every accepted goal kept: id, acceptance stamp, status.
    fn statuses(&mut self, list: &[(GoalKey, i64, GoalStatusEnum)]);
}

/// One control cycle's output, as the DDS thread hands it on.
#[derive(Clone, Copy, Debug)]
pub struct Cycle<'a> {
    /// the instant the sample is for, ns
    pub stamp_ns: i64,
    pub tick: &'a Tick,
    /// the running job, 0 if none (0 at a job's last sample)
    pub job: u32,
    pub place: Place,
    /// the status, when the cycle published one
    pub status: Option<&'a Status>,
}

enum Phase {
    /// at the check; the send_goal request waits for it
    Checking(RmwRequestId),
    /// its job runs
    Running {
        job: u32,
        estimate: f64,
        recording: String,
        canceling: bool,
        next_feedback_ns: i64,
    },
    Done(GoalStatusEnum, ExecuteProgramResult),
}

struct Goal {
    key: GoalKey,
    /// when it was accepted, ns (0 while checked)
    accepted_ns: i64,
    phase: Phase,
    /// get_result requests waiting for the end
    waiting: Vec<RmwRequestId>,
}

impl Goal {
    fn status(&self) -> GoalStatusEnum {
        match &self.phase {
            Phase::Checking(_) => GoalStatusEnum::Unknown,
            Phase::Running { canceling, .. } if *canceling => GoalStatusEnum::Canceling,
            Phase::Running { .. } => GoalStatusEnum::Executing,
            Phase::Done(s, _) => *s,
        }
    }
}

/// A job that ended, as the samples showed it.
#[derive(Clone, Debug)]
struct Ended {
    job: u32,
    state: State,
    /// the status's `last_error` at the end; `None` until a status came
    error: Option<String>,
    /// from its first sample to its last, s
    cycle_time: f64,
    /// the last setpoints, mm
    position: [f64; 3],
    place: Place,
}

/// The last cycle seen.
#[derive(Clone, Copy, Debug)]
struct Last {
    stamp_ns: i64,
    positions: [f64; 3],
    state: State,
}

/// The goals of the action, and the jobs as the samples show them.
pub struct Goals {
    joints: Vec<String>,
    goals: Vec<Goal>,
    /// the running job and the stamp of its first sample
    running: Option<(u32, i64)>,
    ended: VecDeque<Ended>,
    last: Option<Last>,
    /// when the statuses are published again while a goal runs
    next_status_ns: i64,
}

impl Goals {
    /// Goals of a machine whose joints are `joints` (in joint order).
    pub fn new(joints: Vec<String>) -> Self {
        Goals {
            joints,
            goals: Vec::new(),
            running: None,
            ended: VecDeque::new(),
            last: None,
            next_status_ns: i64::MIN,
        }
    }

    /// A send_goal request for goal `key`: true when it is to be checked
    /// (answer with [`Goals::checked`]); a goal id already in use is
    /// rejected.
    pub fn goal(&mut self, req: RmwRequestId, key: GoalKey, wire: &mut impl Wire) -> bool {
        if self.goals.iter().any(|g| g.key == key) {
            wire.goal_response(req, false, 0);
            return false;
        }
        self.goals.push(Goal {
            key,
            accepted_ns: 0,
            phase: Phase::Checking(req),
            waiting: Vec::new(),
        });
        true
    }

    /// The check worker's answer for goal `key` at `now_ns` (the wall
    /// clock): the goal is accepted; it runs when its job started, and
    /// ends at once when it was refused or a dry run.
    pub fn checked(
        &mut self,
        key: GoalKey,
        resp: RunProgramResponse,
        now_ns: i64,
        wire: &mut impl Wire,
    ) {
        let (state, position) = self.now();
        let joints = self.joints.clone();
        let Some(g) = self.goals.iter_mut().find(|g| g.key == key) else {
            return;
        };
        let Phase::Checking(req) = g.phase else {
            return;
        };
        g.accepted_ns = now_ns;
        wire.goal_response(req, true, now_ns);
        let result = |message: &str| ExecuteProgramResult {
            state: state as u8,
            message: message.to_string(),
            job_id: 0,
            cycle_time: 0.0,
            estimated_duration: resp.estimated_duration,
            recording: String::new(),
            joint_names: joints.clone(),
            position: metres(&position[..joints.len().min(3)]),
        };
        g.phase = if !resp.accepted {
            Phase::Done(GoalStatusEnum::Aborted, result(&resp.message))
        } else if resp.job_id == 0 {
            Phase::Done(GoalStatusEnum::Succeeded, result(""))
        } else {
            Phase::Running {
                job: resp.job_id,
                estimate: resp.estimated_duration,
                recording: resp.recording,
                canceling: false,
                next_feedback_ns: i64::MIN,
            }
        };
        // a short job may have ended before its number came
        self.finish_ended(wire);
        self.answer_done(wire);
        self.publish_statuses(wire);
    }

    /// A cancel_goal request for goal `key` (all zero: any) and the goals
    /// accepted at or before `stamp_ns` (0: none by time; both zero: every
    /// goal). Answers it; returns the jobs to abort.
    pub fn cancel(
        &mut self,
        req: RmwRequestId,
        key: GoalKey,
        stamp_ns: i64,
        wire: &mut impl Wire,
    ) -> Vec<u32> {
        let all = key == [0; 16] && stamp_ns == 0;
        let mut canceling = Vec::new();
        let mut abort = Vec::new();
        for g in self.goals.iter_mut().filter(|g| g.accepted_ns > 0) {
            let chosen = all || g.key == key || (stamp_ns != 0 && g.accepted_ns <= stamp_ns);
            if let (
                true,
                Phase::Running {
                    job, canceling: c, ..
                },
            ) = (chosen, &mut g.phase)
            {
                if !*c && !self.ended.iter().any(|e| e.job == *job) {
                    abort.push(*job);
                }
                *c = true;
                canceling.push((g.key, g.accepted_ns));
            }
        }
        let named = self
            .goals
            .iter()
            .find(|g| g.key == key && g.accepted_ns > 0);
        let code = match named {
            _ if !canceling.is_empty() => CancelGoalResponseEnum::None,
            None if key != [0; 16] => CancelGoalResponseEnum::UnknownGoal,
            Some(g) if matches!(g.phase, Phase::Done(..)) => CancelGoalResponseEnum::GoalTerminated,
            _ => CancelGoalResponseEnum::None,
        };
        wire.cancel_response(req, code, &canceling);
        if !canceling.is_empty() {
            self.publish_statuses(wire);
        }
        abort
    }

    /// A get_result request for goal `key`: answered now when the goal has
    /// ended (or is unknown: status UNKNOWN), else at its end.
    pub fn result_request(&mut self, req: RmwRequestId, key: GoalKey, wire: &mut impl Wire) {
        match self.goals.iter_mut().find(|g| g.key == key) {
            Some(Goal {
                phase: Phase::Done(s, r),
                ..
            }) => wire.result(req, *s, r),
            Some(g) => g.waiting.push(req),
            None => wire.result(
                req,
                GoalStatusEnum::Unknown,
                &ExecuteProgramResult::default(),
            ),
        }
    }

    /// One control cycle: follows the jobs, sends the running goals'
    /// feedback and ends the goals whose jobs ended.
    pub fn cycle(&mut self, c: Cycle, wire: &mut impl Wire) {
        let t = c.tick;
        let speed = self.last.map_or(0.0, |l| {
            let dt = (c.stamp_ns - l.stamp_ns) as f64 * 1e-9;
            let d2: f64 = (0..t.n.min(3))
                .map(|j| (t.positions[j] - l.positions[j]).powi(2))
                .sum();
            if dt > 0.0 {
                d2.sqrt() / 1000.0 / dt
            } else {
                0.0
            }
        });
        self.last = Some(Last {
            stamp_ns: c.stamp_ns,
            positions: t.positions,
            state: t.state,
        });
        if let Some((job, t0)) = self.running.filter(|(j, _)| *j != c.job) {
            self.ended.push_back(Ended {
                job,
                state: t.state,
                error: None,
                // (to the µs: the stamps are the wall clock's, a few ns
                // off the period's multiples)
                cycle_time: ((c.stamp_ns - t0) as f64 / 1e3).round() / 1e6,
                position: t.positions,
                place: c.place,
            });
            if self.ended.len() > KEEP_JOBS {
                self.ended.pop_front();
            }
            self.running = None;
        }
        if c.job != 0 && self.running.is_none() {
            self.running = Some((c.job, c.stamp_ns));
        }
        // the job's fault, or the abort, is in the status published at its
        // end (a later one, if that cycle's output was dropped)
        if let Some(s) = c.status {
            for e in self.ended.iter_mut() {
                if e.error.is_none() && s.job_id == e.job {
                    e.error = Some(s.last_error.clone());
                }
            }
        }
        self.finish_ended(wire);
        // feedback of the running goals
        let running = self.running.map(|(j, _)| j);
        for g in &mut self.goals {
            if let Phase::Running {
                job,
                next_feedback_ns,
                ..
            } = &mut g.phase
            {
                if Some(*job) == running && c.stamp_ns >= *next_feedback_ns {
                    *next_feedback_ns = c.stamp_ns.saturating_add(FEEDBACK_PERIOD_NS);
                    let f = feedback(*job, &self.joints, &t.positions, c.place, speed, t.state);
                    wire.feedback(g.key, f);
                }
            }
        }
        let runs = |g: &Goal| matches!(g.phase, Phase::Running { .. });
        if c.stamp_ns >= self.next_status_ns && self.goals.iter().any(runs) {
            self.next_status_ns = c.stamp_ns.saturating_add(STATUS_PERIOD_NS);
            self.publish_statuses(wire);
        }
    }

    /// The controller's state and setpoints (mm) as the last cycle showed
    /// them.
    fn now(&self) -> (State, [f64; 3]) {
        self.last
            .map_or((State::Idle, [0.0; 3]), |l| (l.state, l.positions))
    }

    /// Ends the running goals whose jobs have ended (and whose end status
    /// has come): a last feedback, then the result.
    fn finish_ended(&mut self, wire: &mut impl Wire) {
        let mut changed = false;
        for g in &mut self.goals {
            let Phase::Running {
                job,
                estimate,
                recording,
                canceling,
                ..
            } = &mut g.phase
            else {
                continue;
            };
            let Some(e) = self.ended.iter().find(|e| e.job == *job) else {
                continue;
            };
            let Some(error) = &e.error else {
                continue;
            };
            // the axes stand: the job ended
            let f = feedback(e.job, &self.joints, &e.position, e.place, 0.0, e.state);
            wire.feedback(g.key, f);
            let (status, message) = if e.state == State::Error {
                (GoalStatusEnum::Aborted, error.clone())
            } else if *canceling {
                (
                    GoalStatusEnum::Canceled,
                    format!("job {} canceled at line {}", e.job, e.place.line),
                )
            } else if !error.is_empty() {
                (GoalStatusEnum::Aborted, error.clone())
            } else {
                (GoalStatusEnum::Succeeded, String::new())
            };
            let recording = std::mem::take(recording);
            let message = fit_reply(&message, MAX_REPLY_TEXT - recording.len().min(500));
            let n = self.joints.len().min(3);
            let result = ExecuteProgramResult {
                state: e.state as u8,
                message,
                job_id: e.job,
                cycle_time: e.cycle_time,
                estimated_duration: *estimate,
                recording,
                joint_names: self.joints.clone(),
                position: metres(&e.position[..n]),
            };
            g.phase = Phase::Done(status, result);
            changed = true;
        }
        if changed {
            self.answer_done(wire);
            self.publish_statuses(wire);
        }
    }

    /// Sends the results asked for of the goals that ended, and forgets
    /// the oldest ended goals beyond [`KEEP_DONE`].
    fn answer_done(&mut self, wire: &mut impl Wire) {
        for g in &mut self.goals {
            if let Phase::Done(s, r) = &g.phase {
                for req in g.waiting.drain(..) {
                    wire.result(req, *s, r);
                }
            }
        }
        let done = |g: &Goal| matches!(g.phase, Phase::Done(..));
        let mut extra = self
            .goals
            .iter()
            .filter(|g| done(g))
            .count()
            .saturating_sub(KEEP_DONE);
        self.goals.retain(|g| {
            let drop = extra > 0 && done(g);
            extra -= usize::from(drop);
            !drop
        });
    }

    fn publish_statuses(&self, wire: &mut impl Wire) {
        let list: Vec<(GoalKey, i64, GoalStatusEnum)> = self
            .goals
            .iter()
            .filter(|g| g.accepted_ns > 0)
            .map(|g| (g.key, g.accepted_ns, g.status()))
            .collect();
        wire.statuses(&list);
    }
}

/// mm to m, value by value.
fn metres(v: &[f64]) -> Vec<f64> {
    v.iter().map(|p| p / 1000.0).collect()
}

fn feedback(
    job: u32,
    joints: &[String],
    position: &[f64; 3],
    place: Place,
    speed: f64,
    state: State,
) -> ExecuteProgramFeedback {
    ExecuteProgramFeedback {
        job_id: job,
        source_line: place.line,
        block_number: place.block,
        progress: place.progress,
        joint_names: joints.to_vec(),
        position: metres(&position[..joints.len().min(3)]),
        path_speed: speed,
        state: state as u8,
    }
}

type Server = ActionServer<ExecuteProgramGoal, ExecuteProgramResult, ExecuteProgramFeedback>;

/// The action server `<ns>/execute_program` on the node's DDS thread.
pub struct ExecuteProgram {
    server: Server,
    goals: Goals,
}

/// What the wire says of a cancel request (`action_msgs/GoalInfo`):
/// ros2-client keeps the request's fields to itself, so they are read
/// back from its CDR.
#[derive(serde::Deserialize)]
struct CancelInfo {
    goal_id: GoalKey,
    sec: i32,
    nanosec: u32,
}

/// The goal id and stamp (ns) of a cancel request.
fn cancel_info(c: &CancelGoalRequest) -> Option<(GoalKey, i64)> {
    let bytes = cdr_encoding::to_vec::<_, byteorder::LittleEndian>(c).ok()?;
    let (i, _) = cdr_encoding::from_bytes::<CancelInfo, byteorder::LittleEndian>(&bytes).ok()?;
    Some((
        i.goal_id,
        i64::from(i.sec) * 1_000_000_000 + i64::from(i.nanosec),
    ))
}

fn goal_id(key: GoalKey) -> GoalId {
    GoalId {
        uuid: uuid::Uuid::from_bytes(key),
    }
}

fn wall_ns() -> i64 {
    crate::convert::time_ns(&ros::wall_stamp())
}

/// [`Wire`] on the action server.
struct Dds<'a>(&'a Server);

impl Wire for Dds<'_> {
    fn goal_response(&mut self, req: RmwRequestId, accepted: bool, stamp_ns: i64) {
        let resp = ros2_client::action::SendGoalResponse {
            accepted,
            stamp: RosTime::from_nanos(stamp_ns),
        };
        let _ = self.0.send_goal_response(req, resp);
    }

    fn result(&mut self, req: RmwRequestId, status: GoalStatusEnum, result: &ExecuteProgramResult) {
        let resp = ros2_client::action::GetResultResponse {
            status,
            result: result.clone(),
        };
        let _ = self.0.send_result(req, resp);
    }

    fn cancel_response(
        &mut self,
        req: RmwRequestId,
        code: CancelGoalResponseEnum,
        canceling: &[(GoalKey, i64)],
    ) {
        let resp = CancelGoalResponse {
            return_code: code,
            goals_canceling: canceling
                .iter()
                .map(|&(k, ns)| GoalInfo {
                    goal_id: goal_id(k),
                    stamp: RosTime::from_nanos(ns),
                })
                .collect(),
        };
        let _ = self.0.send_cancel_response(req, resp);
    }

    fn feedback(&mut self, goal: GoalKey, feedback: ExecuteProgramFeedback) {
        let _ = self.0.send_feedback(goal_id(goal), feedback);
    }

    fn statuses(&mut self, list: &[(GoalKey, i64, GoalStatusEnum)]) {
        let status_list = list
            .iter()
            .map(|&(k, ns, status)| GoalStatus {
                goal_info: GoalInfo {
                    goal_id: goal_id(k),
                    stamp: RosTime::from_nanos(ns),
                },
                status,
            })
            .collect();
        let _ = self.0.send_goal_statuses(GoalStatusArray { status_list });
    }
}

impl ExecuteProgram {
    /// The action `ns/execute_program` of a machine with `joints`.
    pub fn new(
        node: &mut ros2_client::Node,
        ns: &str,
        joints: Vec<String>,
    ) -> Result<Self, String> {
        Ok(ExecuteProgram {
            server: ros::action_server(node, ns, "execute_program")?,
            goals: Goals::new(joints),
        })
    }

    /// The new goals, each as the request to check (answer with
    /// [`ExecuteProgram::checked`]).
    pub fn new_goals(&mut self) -> Vec<(GoalKey, RunProgramRequest)> {
        let mut out = Vec::new();
        while let Ok(Some((req, g))) = ros::receive_now(self.server.goal_server()) {
            let key = *g.goal_id.uuid.as_bytes();
            if self.goals.goal(req, key, &mut Dds(&self.server)) {
                out.push((key, g.goal));
            }
        }
        out
    }

    /// The check worker's answer for goal `key`.
    pub fn checked(&mut self, key: GoalKey, resp: RunProgramResponse) {
        self.goals
            .checked(key, resp, wall_ns(), &mut Dds(&self.server));
    }

    /// Answers cancel and result requests; `abort` is called with each job
    /// a cancel stops.
    pub fn serve(&mut self, mut abort: impl FnMut(u32)) {
        while let Ok(Some((req, c))) = ros::receive_now(self.server.cancel_server()) {
            let Some((key, stamp)) = cancel_info(&c) else {
                continue;
            };
            for job in self.goals.cancel(req, key, stamp, &mut Dds(&self.server)) {
                abort(job);
            }
        }
        while let Ok(Some((req, r))) = ros::receive_now(self.server.result_server()) {
            let key = *r.goal_id.uuid.as_bytes();
            self.goals.result_request(req, key, &mut Dds(&self.server));
        }
    }

    /// One control cycle's output (every one, in order).
    pub fn cycle(&mut self, c: Cycle) {
        self.goals.cycle(c, &mut Dds(&self.server));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The goal id and stamp of a cancel request as rclpy sends it (CDR of
    /// `action_msgs/srv/CancelGoal_Request`), read back.
    #[test]
    fn a_cancel_request_says_which_goal() {
        let key: GoalKey = std::array::from_fn(|i| i as u8 * 7 + 1);
        let mut wire = key.to_vec();
        wire.extend_from_slice(&1_795_000_000i32.to_le_bytes());
        wire.extend_from_slice(&250_000_000u32.to_le_bytes());
        let (req, _) =
            cdr_encoding::from_bytes::<CancelGoalRequest, byteorder::LittleEndian>(&wire).unwrap();
        assert_eq!(cancel_info(&req), Some((key, 1_795_000_000_250_000_000)));
        assert_eq!(goal_id(key).uuid.as_bytes(), &key);
    }
}
