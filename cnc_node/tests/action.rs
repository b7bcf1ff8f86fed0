//! The execute_program action's goals without DDS, driven as the node
//! drives them: a goal is admitted (`admit`) and its job started in a
//! `Controller`, whose ticks (1 kHz, with the status on a state change)
//! go to `Goals::cycle`; what the goals send is recorded.

use cnc_core::Machine;
use cnc_msgs::{ExecuteProgramFeedback, ExecuteProgramResult, RunProgramRequest};
use cnc_node::action::{
    Cycle, GoalKey, Goals, Wire, FEEDBACK_PERIOD_NS, KEEP_DONE, STATUS_PERIOD_NS,
};
use cnc_node::admit::{admit, Refusal};
use cnc_node::controller::{Controller, State};
use ros2_client::action::GoalStatusEnum;
use ros2_client::action_msgs::CancelGoalResponseEnum;
use ros2_client::RmwRequestId;
use std::path::Path;

const MS: i64 = 1_000_000;
const T0: i64 = 1_795_000_000 * 1_000_000_000;

#[derive(Debug, Clone, PartialEq)]
enum Sent {
    GoalResponse(i64, bool),
    Result(i64, GoalStatusEnum, ExecuteProgramResult),
    Cancel(i64, CancelGoalResponseEnum, Vec<GoalKey>),
    Feedback(GoalKey, ExecuteProgramFeedback),
    Statuses(Vec<(GoalKey, GoalStatusEnum)>),
}

#[derive(Default)]
struct Rec(Vec<Sent>);

impl Wire for Rec {
    fn goal_response(&mut self, req: RmwRequestId, accepted: bool, _stamp_ns: i64) {
        self.0
            .push(Sent::GoalResponse(req.sequence_number, accepted));
    }
    fn result(&mut self, req: RmwRequestId, status: GoalStatusEnum, r: &ExecuteProgramResult) {
        self.0
            .push(Sent::Result(req.sequence_number, status, r.clone()));
    }
    fn cancel_response(
        &mut self,
        req: RmwRequestId,
        code: CancelGoalResponseEnum,
        canceling: &[(GoalKey, i64)],
    ) {
        let keys = canceling.iter().map(|(k, _)| *k).collect();
        self.0.push(Sent::Cancel(req.sequence_number, code, keys));
    }
    fn feedback(&mut self, goal: GoalKey, f: ExecuteProgramFeedback) {
        self.0.push(Sent::Feedback(goal, f));
    }
    fn statuses(&mut self, list: &[(GoalKey, i64, GoalStatusEnum)]) {
        self.0.push(Sent::Statuses(
            list.iter().map(|&(k, _, s)| (k, s)).collect(),
        ));
    }
}

fn req(n: i64) -> RmwRequestId {
    RmwRequestId {
        sequence_number: n,
        ..Default::default()
    }
}

fn key(n: u8) -> GoalKey {
    [n; 16]
}

/// The node's loop, check worker and DDS thread in one.
struct Rig {
    m: Machine,
    ctl: Controller,
    goals: Goals,
    wire: Rec,
    k: i64,
    next_job: u32,
}

impl Rig {
    fn new() -> Self {
        let m = Machine::builtin_mill();
        Rig {
            ctl: Controller::new(m.clone()),
            goals: Goals::new(vec!["x".into(), "y".into(), "z".into()]),
            m,
            wire: Rec::default(),
            k: 0,
            next_job: 1,
        }
    }

    /// Goal `n` (its send_goal request numbered `n` too) received and
    /// checked, its job started when admitted; the check's estimate.
    fn send(&mut self, n: u8, program: &str, dry_run: bool) -> f64 {
        assert!(self.goals.goal(req(n.into()), key(n), &mut self.wire));
        let (resp, est) = self.check(program, dry_run);
        let now = T0 + self.k * MS;
        self.goals.checked(key(n), resp, now, &mut self.wire);
        est
    }

    /// The check worker: admission, then the start.
    fn check(&mut self, program: &str, dry_run: bool) -> (cnc_msgs::RunProgramResponse, f64) {
        let r = RunProgramRequest {
            program: program.into(),
            dry_run,
            ..Default::default()
        };
        let a = match admit(&r, &self.m, self.ctl.positions(), Path::new(".")) {
            Ok(a) => a,
            Err(e) => return (e.reply(), 0.0),
        };
        let est = a.estimated_duration_s;
        if a.dry_run {
            return (a.reply(0, String::new()), est);
        }
        let reply = a.reply(self.next_job, String::new());
        match self.ctl.start(a.job(self.next_job)) {
            Ok(()) => {
                self.next_job += 1;
                (reply, est)
            }
            Err(m) => (Refusal(m).reply(), est),
        }
    }

    /// One cycle, as the node's control loop and DDS thread run it.
    fn tick(&mut self) {
        let prev = self.ctl.state();
        let tick = self.ctl.tick(T0 + self.k * MS);
        let status = (tick.state != prev || self.k % 100 == 0).then(|| self.ctl.status());
        let c = Cycle {
            stamp_ns: T0 + self.k * MS,
            tick: &tick,
            job: self.ctl.job_id(),
            place: self.ctl.place(),
            status: status.as_ref(),
        };
        self.goals.cycle(c, &mut self.wire);
        self.k += 1;
    }

    fn ticks(&mut self, n: usize) {
        for _ in 0..n {
            self.tick();
        }
    }

    /// Ticks until the controller is idle (or in error) again.
    fn run_out(&mut self) {
        for _ in 0..200_000 {
            self.tick();
            if !matches!(self.ctl.state(), State::Running | State::Hold) {
                return;
            }
        }
        panic!("the job did not end");
    }

    fn feedback(&self, n: u8) -> Vec<ExecuteProgramFeedback> {
        self.wire
            .0
            .iter()
            .filter_map(|s| match s {
                Sent::Feedback(k, f) if *k == key(n) => Some(f.clone()),
                _ => None,
            })
            .collect()
    }

    fn results(&self, request: i64) -> Vec<(GoalStatusEnum, ExecuteProgramResult)> {
        self.wire
            .0
            .iter()
            .filter_map(|s| match s {
                Sent::Result(r, st, res) if *r == request => Some((*st, res.clone())),
                _ => None,
            })
            .collect()
    }

    fn last_statuses(&self) -> Vec<(GoalKey, GoalStatusEnum)> {
        self.wire
            .0
            .iter()
            .rev()
            .find_map(|s| match s {
                Sent::Statuses(l) => Some(l.clone()),
                _ => None,
            })
            .unwrap_or_default()
    }
}

#[test]
fn a_goal_runs_to_its_end_with_feedback_and_its_cycle_time() {
    let mut r = Rig::new();
    r.ticks(10);
    let prog = "N10 G90 G01 X10 Y10 F3000\nN20 G01 X40 F1200\nN30 Y30\nN40 M30\n";
    let est = r.send(1, prog, false);
    assert_eq!(r.wire.0[0], Sent::GoalResponse(1, true));
    assert_eq!(
        r.last_statuses(),
        [(key(1), GoalStatusEnum::Executing)],
        "accepted and running"
    );
    // the result asked for at once is sent at the end
    r.goals.result_request(req(100), key(1), &mut r.wire);
    assert!(r.results(100).is_empty());
    r.run_out();
    let res = r.results(100);
    assert_eq!(res.len(), 1);
    let (status, res) = &res[0];
    assert_eq!(*status, GoalStatusEnum::Succeeded);
    assert_eq!((res.state, res.message.as_str(), res.job_id), (0, "", 1));
    // the cycle time is the estimate: the same timeline, to the tick
    assert!(
        (res.cycle_time - est).abs() < 1e-9,
        "{} {est}",
        res.cycle_time
    );
    assert_eq!(res.estimated_duration, est);
    assert_eq!(res.position, [0.04, 0.03, 0.0]);
    assert_eq!(res.joint_names, ["x", "y", "z"]);
    // feedback every 50 ms from the first sample, and once at the end
    let f = r.feedback(1);
    let period = (FEEDBACK_PERIOD_NS / MS) as f64 / 1000.0;
    assert_eq!(f.len(), (est / period).floor() as usize + 2, "{est}");
    assert!(f.windows(2).all(|w| w[1].progress >= w[0].progress));
    assert!(f.windows(2).all(|w| w[1].source_line >= w[0].source_line));
    let lines: std::collections::BTreeSet<u32> = f.iter().map(|m| m.source_line).collect();
    assert_eq!(lines.into_iter().collect::<Vec<_>>(), [1, 2, 3]);
    assert!(f
        .iter()
        .all(|m| m.block_number == 10 * i64::from(m.source_line)));
    // F1200 on lines 2 and 3: 0.02 m/s
    let v: Vec<f64> = f
        .iter()
        .filter(|m| m.source_line == 3)
        .map(|m| m.path_speed)
        .collect();
    assert!(v.iter().any(|v| (v - 0.02).abs() < 1e-9), "{v:?}");
    assert!(v.iter().all(|v| *v <= 0.02 + 1e-9), "{v:?}");
    let last = f.last().unwrap();
    assert_eq!((last.state, last.path_speed, last.progress), (0, 0.0, 1.0));
    assert_eq!(last.position, res.position);
    assert!(f[..f.len() - 1].iter().all(|m| m.state == 1));
    assert_eq!(r.last_statuses(), [(key(1), GoalStatusEnum::Succeeded)]);
    // asked again after the end: at once
    r.goals.result_request(req(101), key(1), &mut r.wire);
    assert_eq!(r.results(101)[0].0, GoalStatusEnum::Succeeded);
    // nothing more once it ended
    let n = r.wire.0.len();
    r.ticks(200);
    assert_eq!(r.wire.0.len(), n);
}

#[test]
fn a_cancel_stops_the_job_on_its_path_and_the_goal_ends_canceled() {
    let mut r = Rig::new();
    r.ticks(5);
    r.send(1, "G90 G01 X100 Y50 F600\nM30\n", false);
    r.ticks(2000);
    // cancel every goal (zero id, zero stamp): the job to abort
    let abort = r.goals.cancel(req(7), [0; 16], 0, &mut r.wire);
    assert_eq!(abort, [1]);
    assert!(r
        .wire
        .0
        .contains(&Sent::Cancel(7, CancelGoalResponseEnum::None, vec![key(1)])));
    assert_eq!(r.last_statuses(), [(key(1), GoalStatusEnum::Canceling)]);
    // asked again while it stops: canceling, nothing more to abort
    assert!(r.goals.cancel(req(8), key(1), 0, &mut r.wire).is_empty());
    r.ctl.abort().unwrap();
    r.run_out();
    r.goals.result_request(req(9), key(1), &mut r.wire);
    let (status, res) = r.results(9).remove(0);
    assert_eq!(status, GoalStatusEnum::Canceled);
    assert_eq!(res.message, "job 1 canceled at line 1");
    assert_eq!(res.state, 0);
    // on the line from home to (100, 50), short of its end
    let [x, y, z] = [res.position[0], res.position[1], res.position[2]];
    assert!((y - x / 2.0).abs() < 1e-12 && z == 0.0, "{x} {y}");
    assert!(0.015 < x && x < 0.03, "{x}");
    let last = r.feedback(1).pop().unwrap();
    assert_eq!((last.state, last.path_speed), (0, 0.0));
    // the goal has ended; an unknown one was never there
    r.goals.cancel(req(10), key(1), 0, &mut r.wire);
    r.goals.cancel(req(11), key(9), 0, &mut r.wire);
    assert!(r.wire.0.contains(&Sent::Cancel(
        10,
        CancelGoalResponseEnum::GoalTerminated,
        vec![]
    )));
    assert!(r.wire.0.contains(&Sent::Cancel(
        11,
        CancelGoalResponseEnum::UnknownGoal,
        vec![]
    )));
    // and the next goal runs from where it stopped
    r.send(2, "G91 G01 X1 F600\n", false);
    r.run_out();
    r.goals.result_request(req(12), key(2), &mut r.wire);
    let (status, res) = r.results(12).remove(0);
    assert_eq!((status, res.job_id), (GoalStatusEnum::Succeeded, 2));
    assert!((res.position[0] - x - 0.001).abs() < 1e-12);
}

#[test]
fn refused_goals_end_at_once_with_the_reason_and_dry_runs_with_the_estimate() {
    let mut r = Rig::new();
    r.ticks(5);
    r.send(1, "N10 G00 X10\nN20 G01 X20\n", false);
    assert_eq!(r.wire.0[0], Sent::GoalResponse(1, true));
    r.goals.result_request(req(50), key(1), &mut r.wire);
    let (status, res) = r.results(50).remove(0);
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert!(
        res.message
            .starts_with("line 2, column 5: block N20: missing feed"),
        "{}",
        res.message
    );
    assert_eq!((res.job_id, res.cycle_time, res.state), (0, 0.0, 0));
    assert_eq!(res.position, [0.0, 0.0, 0.0]);
    assert!(r.feedback(1).is_empty());
    // a job runs: a second goal is refused with its number
    r.send(2, "G90 G01 X50 F600\n", false);
    r.ticks(100);
    r.send(3, "G90 G01 X5 F600\n", false);
    r.goals.result_request(req(51), key(3), &mut r.wire);
    let (status, res) = r.results(51).remove(0);
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert_eq!(
        res.message,
        "job 1 is running; wait for its end or abort it (nothing was queued)"
    );
    assert_eq!(res.state, 1, "the controller was running");
    // a dry run while it runs: the estimate, nothing started
    let est = r.send(4, "G90 G01 X5 F600\n", true);
    r.goals.result_request(req(52), key(4), &mut r.wire);
    let (status, res) = r.results(52).remove(0);
    assert_eq!(status, GoalStatusEnum::Succeeded);
    assert_eq!((res.job_id, res.estimated_duration), (0, est));
    assert!(est > 0.0);
    r.run_out();
    r.goals.result_request(req(53), key(2), &mut r.wire);
    assert_eq!(r.results(53)[0].0, GoalStatusEnum::Succeeded);
    // a goal id in use is rejected
    assert!(!r.goals.goal(req(60), key(2), &mut r.wire));
    assert_eq!(r.wire.0.last(), Some(&Sent::GoalResponse(60, false)));
}

#[test]
fn a_job_that_ended_before_its_goal_heard_of_it_ends_the_goal() {
    let mut r = Rig::new();
    r.ticks(5);
    // the check worker started the job; the DDS thread saw it run out
    // before the answer came
    assert!(r.goals.goal(req(1), key(1), &mut r.wire));
    let (resp, est) = r.check("G90 G01 X1 F6000\n", false);
    r.run_out();
    r.ticks(3);
    r.goals.checked(key(1), resp, T0, &mut r.wire);
    r.goals.result_request(req(2), key(1), &mut r.wire);
    let (status, res) = r.results(2).remove(0);
    assert_eq!(status, GoalStatusEnum::Succeeded);
    assert!((res.cycle_time - est).abs() < 1e-9 && res.position[0] == 0.001);
}

#[test]
fn a_fault_or_an_abort_from_elsewhere_aborts_the_goal() {
    let mut r = Rig::new();
    r.ticks(5);
    r.send(1, "G90 G01 X100 F600\n", false);
    r.ticks(500);
    r.ctl.fail("the encoder went quiet".into());
    // (failed between ticks: no state change in a cycle, so the end waits
    // for the next status, 100 ms later)
    r.tick();
    r.goals.result_request(req(2), key(1), &mut r.wire);
    assert!(r.results(2).is_empty());
    r.ticks(100);
    let (status, res) = r.results(2).remove(0);
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert_eq!(
        (res.state, res.message.as_str()),
        (3, "the encoder went quiet")
    );
    // the abort service (not the action's cancel)
    r.send(2, "G90 G01 X0 F600\n", false);
    r.ticks(500);
    r.ctl.abort().unwrap();
    r.run_out();
    r.goals.result_request(req(3), key(2), &mut r.wire);
    let (status, res) = r.results(3).remove(0);
    assert_eq!(status, GoalStatusEnum::Aborted);
    assert_eq!(res.state, 0);
    assert_eq!(res.message, "job 2 aborted at line 1");
}

#[test]
fn results_are_kept_for_the_last_goals() {
    let mut r = Rig::new();
    r.ticks(5);
    let n = KEEP_DONE as u8 + 3;
    for g in 1..=n {
        r.send(g, "G90 G01 X1 F600\n", true);
    }
    assert_eq!(r.last_statuses().len(), KEEP_DONE);
    r.goals.result_request(req(100), key(n), &mut r.wire);
    assert_eq!(r.results(100)[0].0, GoalStatusEnum::Succeeded);
    // the oldest were forgotten: unknown now
    r.goals.result_request(req(101), key(1), &mut r.wire);
    assert_eq!(r.results(101)[0].0, GoalStatusEnum::Unknown);
}

#[test]
fn a_feed_hold_keeps_the_goal_executing_with_the_hold_in_its_feedback() {
    let mut r = Rig::new();
    r.ticks(5);
    r.send(1, "G90 G01 X100 F600\n", false);
    r.ticks(500);
    r.ctl.feed_hold(true).unwrap();
    let before = r.wire.0.len();
    r.ticks(1000);
    let f = r.feedback(1).pop().unwrap();
    assert_eq!((f.state, f.path_speed), (2, 0.0), "{f:?}");
    assert_eq!(r.last_statuses(), [(key(1), GoalStatusEnum::Executing)]);
    // the statuses again, every 500 ms while it runs
    let again = r.wire.0[before..]
        .iter()
        .filter(|s| matches!(s, Sent::Statuses(_)))
        .count();
    assert_eq!(again as i64, 1000 * MS / STATUS_PERIOD_NS);
    r.ctl.feed_hold(false).unwrap();
    r.run_out();
    r.goals.result_request(req(2), key(1), &mut r.wire);
    let (status, res) = r.results(2).remove(0);
    assert_eq!(status, GoalStatusEnum::Succeeded);
    // the hold's time counts
    assert!(res.cycle_time > res.estimated_duration + 0.25, "{res:?}");
}
