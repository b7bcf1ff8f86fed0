//! The controller as a ROS 2 node (`docs/ros_interface.md`).
//!
//! Four threads, so the control loop never waits on a file or a check, nor
//! for a message, and the DDS thread never on a file:
//! - control (`cnc_node/control.rs`): at the interpolation rate (on the instants of a fixed grid,
//!   catching up after a late wake-up) it takes commands and the spindle
//!   encoder's readings without blocking (the readings straight from their
//!   subscription's cache, as the simulator's loop takes its setpoints),
//!   computes one sample, publishes its setpoints (and the spindle
//!   command) and hands it to the DDS thread through a bounded queue
//!   (`try_send`: a full queue drops, it never blocks);
//! - check worker: reads and checks programs, answers run_program and the
//!   goals of execute_program;
//! - main (DDS): services, the action (`cnc_node::action`), the status,
//!   the observer's topics; takes the control loop's samples a few at a
//!   time while a job runs ([`SERVICE_POLL`]); hands a recorded job's
//!   messages to
//! - recorder (`cnc_node/recording.rs`): writes the job's recording (an
//!   unbounded queue, so the DDS thread never waits and no message is
//!   lost), at normal priority.
//!
//! With `--rt-priority P` the control loop runs under SCHED_FIFO P and the
//! DDS threads (started by the main thread, which DDS's own threads
//! inherit from) under P − 20; the check worker and the
//! recorder run at normal priority.
//!
//! Time: the control loop stamps each cycle's setpoints with the instant
//! its sample is meant for, in the system clock (`ros::WallClock` of its
//! grid instant); `sim_axes` stamps its encoder readings the same way
//! with the instant each simulated step stands for. Both nodes must run on
//! the same host (or on hosts whose clocks are synchronized far better than
//! a count of the encoder takes to pass, e.g. PTP), and the system clock
//! must not be stepped while a thread is cut. A job's executor gets a
//! reading stamped `s` at `t = s − (stamp of the job's sample 0)`.

use cnc_core::Machine;
use cnc_msgs::ros;
use cnc_msgs::*;
use cnc_node::action::{Cycle, ExecuteProgram, GoalKey};
use cnc_node::admit::{admit, fit_run_reply, recorder, RecordOpts, Refusal};
use cnc_node::controller::{ActualSample, Job, Place, State, Status, Tick};
use cnc_node::convert::{self, stamp_ns, time_ns};
use cnc_node::files::load_machine;
use cnc_node::observe::{self, Observer};
use cnc_node::params::{self as node_params, Args, Live, Setup};
use cnc_node::record::JobRecorder;
use cnc_node::rt_queue::{self, CmdTx, Gone};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[path = "cnc_node/control.rs"]
mod control;
#[path = "cnc_node/phase.rs"]
mod phase;
use control::{control_loop, Commands, Readings};
#[path = "cnc_node/recording.rs"]
mod recording;
use recording::{Msg, Recording};

type Rec = Box<JobRecorder>;

enum Cmd {
    /// a checked job, with its recorder when it is recorded
    Start(Job, Option<Rec>, Sender<Result<(), String>>),
    Abort(Sender<Result<String, String>>),
    Hold(bool, Sender<Result<String, String>>),
    /// feed override, percent
    Override(f64),
}

/// Who a check is for: a run_program request or an execute_program goal.
enum Asker {
    Service(ros2_client::RmwRequestId),
    Goal(GoalKey),
}

struct Out {
    stamp: Time,
    tick: Tick,
    place: Place,
    status: Option<Status>,
    /// the running job, 0 if none
    job: u32,
    /// a job's recorder, handed on with the job's first sample
    recorder: Option<(u32, Rec)>,
}

fn main() {
    if let Err(e) = node_params::from_env().and_then(run) {
        ros_error!("{e}");
        std::process::exit(2);
    }
}

fn program_dir(args: &Args, m: &Machine) -> PathBuf {
    if let Some(d) = &args.program_dir {
        return d.clone();
    }
    let base = Path::new(&args.machine)
        .parent()
        .filter(|_| Path::new(&args.machine).exists())
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("config"));
    base.join(m.program_dir.as_deref().unwrap_or("."))
}

fn run(setup: Setup) -> Result<(), String> {
    let args = &setup.args;
    let mut machine = load_machine(&args.machine)?;
    // recordings attach the machine file as written (or, for a bundled
    // machine, as the core reads it)
    let machine_text = std::fs::read_to_string(&args.machine)
        .or_else(|_| cnc_node::record::machine_toml(&machine))?;
    if let Some(r) = args.rate {
        if !(r.is_finite() && (10.0..=20_000.0).contains(&r)) {
            return Err(format!("--rate {r}: must be between 10 and 20000 Hz"));
        }
        machine.interpolation.rate_hz = r;
        machine
            .validate()
            .map_err(|e| format!("--rate {}: {e}", cnc_core::diag::num(r)))?;
    }
    let dir = program_dir(args, &machine);
    let domain = args.domain.unwrap_or_else(ros::domain_from_env);
    // (before any thread starts, so that every one takes it)
    ros::affinity::pin_process(&args.cpu_affinity).map_err(|e| format!("--cpu-affinity: {e}"))?;
    // DDS's threads start in join and inherit this thread's policy: real
    // time below the control loop, so a busy machine does not hold up the
    // encoder readings (the check worker goes back to normal)
    let dds_rt = ros::dds_priority(args.rt_priority);
    if dds_rt > 0 {
        if let Err(e) = ros::set_realtime(dds_rt) {
            ros_warn!("DDS threads stay at normal priority (SCHED_FIFO {dds_rt}: {e})");
        }
    }
    // (the thread that hands the signal on starts here, with this policy:
    // at normal priority it waited for seconds while the loops held both
    // CPUs, and SIGTERM seemed ignored)
    if let Err(e) = ros::shutdown::catch_signals() {
        ros_warn!("{e}");
    }
    let no_own_params = ros2_client::NodeOptions::new()
        .enable_rosout(false)
        .start_parameter_services(false);
    let (ctx, mut node) =
        ros::join_with(domain, &args.namespace, &setup.start.name, no_own_params)?;
    let (live, _params) = node_params::serve(
        &ctx,
        &mut node,
        &setup,
        machine.interpolation.rate_hz,
        &dir,
        machine_text.clone(),
    )?;
    cnc_msgs::rosout::init(&ctx, &mut node, &args.namespace, &setup.start.name)?;
    let ns = args.namespace.as_str();
    // a subscriber that dies must not stop the setpoints for the others
    let window = ros::lease_window(machine.interpolation.rate_hz);
    let pub_set =
        ros::publisher_with_window::<JointState>(&ctx, &mut node, ns, "joint_setpoints", window)?;
    let pub_spin = ros::publisher::<Float64>(&mut node, ns, "spindle_command")?;
    let pub_status = ros::publisher::<ControllerStatus>(&mut node, ns, "status")?;
    let sub_js =
        ros::subscription_stream::<JointState>(&mut node, &args.sim_namespace, "joint_states")?;
    let sub_enc = ros::subscription_stream::<SpindleEncoder>(
        &mut node,
        &args.sim_namespace,
        "spindle_encoder",
    )?;
    let srv_run =
        ros::server::<RunProgramRequest, RunProgramResponse>(&mut node, ns, "run_program")?;
    let srv_abort = ros::server::<TriggerRequest, TriggerResponse>(&mut node, ns, "abort")?;
    let srv_hold = ros::server::<SetBoolRequest, SetBoolResponse>(&mut node, ns, "feed_hold")?;
    let sub_ovr = ros::subscription::<Float64>(&mut node, ns, "feed_override")?;
    let mut obs = Observer::new(&mut node, ns, &machine)?;

    // where the machine stands (f64 bits per joint), for checks of new jobs
    let here: Arc<[AtomicU64; 3]> = Arc::new(Default::default());
    let home = machine.home();
    for (j, &i) in machine.joint_indices().iter().enumerate() {
        here[j].store(home[i].to_bits(), Ordering::Relaxed);
    }
    let state = Arc::new(AtomicU32::new(State::Idle as u32));
    // a request is being checked: the loop publishes every cycle meanwhile
    let checking = Arc::new(AtomicBool::new(false));

    // (between the control loop and the threads below it, queues that
    // never make the loop wait: rt_queue.rs)
    let (cmd_tx, cmd_rx) = rt_queue::commands::<Cmd>();
    let (out_tx, mut out_rx) = rt_queue::spsc::<Out>(8192);
    let out_tx = out_tx.wake(std::thread::current());
    let (chk_tx, chk_rx) = mpsc::channel();
    let (resp_tx, resp_rx) = mpsc::channel();
    // the encoder readings the control loop takes, on to this thread for
    // the observer and recordings: bounded, never blocking
    let (enc_rec_tx, mut enc_rec_rx) = rt_queue::spsc::<SpindleEncoder>(256);
    let readings = Readings {
        sub: sub_enc,
        to_dds: enc_rec_tx,
    };
    // the machine's joint states to the control loop (a thread's phase
    // is watched against them): bounded, never blocking
    let (mut act_tx, act_rx) = rt_queue::spsc::<ActualSample>(256);
    let names: Vec<String> = machine.axes.iter().map(|a| a.name.clone()).collect();
    let commands = Commands::new(pub_set, pub_spin, names.clone(), machine.dt());
    {
        let m = machine.clone();
        let here = here.clone();
        let state = state.clone();
        let stats = live.clone();
        let checking = checking.clone();
        let rt = args.rt_priority;
        std::thread::Builder::new()
            .name("control".into())
            .spawn(move || {
                if rt > 0 {
                    if let Err(e) = ros::lock_memory() {
                        ros_warn!("memory not locked (mlockall: {e})");
                    }
                    if let Err(e) = ros::set_realtime(rt) {
                        ros_warn!("control loop stays at normal priority (SCHED_FIFO {rt}: {e})");
                    }
                }
                control_loop(
                    m,
                    cmd_rx,
                    (readings, act_rx),
                    (out_tx, commands),
                    here,
                    (state, checking),
                    stats,
                )
            })
            .map_err(|e| e.to_string())?;
    }
    {
        let m = machine.clone();
        let cmd_tx = cmd_tx.clone();
        let rec_opts = live.clone();
        std::thread::Builder::new()
            .name("check".into())
            .spawn(move || {
                if dds_rt > 0 {
                    let _ = ros::set_normal();
                }
                check_worker(m, dir, rec_opts, chk_rx, resp_tx, cmd_tx, here, checking)
            })
            .map_err(|e| e.to_string())?;
    }
    let mut action = ExecuteProgram::new(&mut node, ns, names.clone())?;
    ros_info!(
        "{} ({}), {} Hz, domain {domain}, serving {}/run_program",
        machine.name,
        names.join(" "),
        machine.interpolation.rate_hz,
        ns.trim_end_matches('/')
    );
    // the spindle speed last recorded (recordings hold its changes)
    let mut last_spindle = f64::NAN;
    // the stamp of the last sample taken, ns
    let mut last_stamp = 0i64;
    // the recording of a job, written on a thread of its own
    let mut recording = Recording::start(dds_rt > 0)?;
    let mut polled = Instant::now();
    let mut stopping: Option<Instant> = None;
    loop {
        // SIGINT/SIGTERM: a running job stops under control along its path
        // and its recording is closed, then the node ends (exit status 0)
        if ros::shutdown::requested() {
            let since = *stopping.get_or_insert_with(|| {
                ros_info!("SIGINT/SIGTERM: stopping");
                let _ = ask(&cmd_tx, Cmd::Abort);
                Instant::now()
            });
            let s = state.load(Ordering::Relaxed);
            let moving = s == State::Running as u32 || s == State::Hold as u32;
            if (!moving && recording.job().is_none()) || since.elapsed() >= SHUTDOWN_GRACE {
                recording.close();
                ros_info!("shut down");
                return Ok(());
            }
        }
        obs.poll();
        // services and the override, every SERVICE_POLL (as the joint
        // states below, taken from their caches without draining the
        // readers' notification channels: a system call each)
        if polled.elapsed() >= SERVICE_POLL {
            polled = Instant::now();
            while let Ok(Some((id, req))) = ros::receive_now(&srv_run) {
                let _ = chk_tx.send((Asker::Service(id), req));
            }
            for (goal, req) in action.new_goals() {
                let _ = chk_tx.send((Asker::Goal(goal), req));
            }
            action.serve(|_job| {
                let _ = ask(&cmd_tx, Cmd::Abort);
            });
            while let Ok(Some((id, _))) = ros::receive_now(&srv_abort) {
                let (success, message) = ask(&cmd_tx, Cmd::Abort);
                let _ = srv_abort.send_response(id, TriggerResponse { success, message });
            }
            while let Ok(Some((id, req))) = ros::receive_now(&srv_hold) {
                let (success, message) = ask(&cmd_tx, |tx| Cmd::Hold(req.data, tx));
                let _ = srv_hold.send_response(id, SetBoolResponse { success, message });
            }
            while let Ok(Some((m, _))) = ros::take_now(&sub_ovr) {
                match live.feed_override(m.data) {
                    Ok(p) => {
                        let _ = cmd_tx.send(Cmd::Override(p));
                    }
                    Err(e) => ros_warn!("{e}"),
                }
            }
        }
        if let Some(p) = live.take_clamp() {
            let _ = cmd_tx.send(Cmd::Override(p));
        }
        while let Ok((asker, resp)) = resp_rx.try_recv() {
            match asker {
                Asker::Service(id) => {
                    let _ = srv_run.send_response(id, resp);
                }
                Asker::Goal(goal) => action.checked(goal, resp),
            }
        }
        while let Ok(Some(m)) = enc_rec_rx.pop() {
            obs.encoder(&m);
            recording.send(Msg::Encoder(m));
        }
        while let Ok(Some((m, _))) = ros::take_now(&sub_js) {
            let mut a = ActualSample {
                stamp_ns: time_ns(&m.header.stamp),
                n: names.len().min(3),
                ..ActualSample::default()
            };
            let mut all = true;
            for (j, name) in names.iter().take(3).enumerate() {
                match m
                    .name
                    .iter()
                    .position(|x| x == name)
                    .and_then(|i| m.position.get(i))
                {
                    Some(p) if p.is_finite() => a.positions[j] = p * 1000.0,
                    _ => all = false,
                }
            }
            if all {
                act_tx.push(a);
            }
            recording.send(Msg::Joints(m));
        }
        // samples from the control loop (which published their setpoints),
        // every one recorded: at rest this waits for the next one, up to
        // REST_WAIT; while they come every cycle, it takes those of
        // SERVICE_POLL at a time (below)
        let mut streaming = false;
        drain(&mut out_rx, REST_WAIT, |mut o| {
            let ns = time_ns(&o.stamp);
            streaming |= ns - last_stamp < STREAMING_GAP_NS;
            last_stamp = ns;
            if let Some((id, rec)) = o.recorder.take() {
                recording.send(Msg::Start(id, rec));
                // the recording starts with the spindle command in force
                last_spindle = f64::NAN;
            }
            let t = &o.tick;
            obs.sample(o.stamp, t, o.status.as_ref());
            let status = o.status.as_ref().map(|s| convert::status(s, o.stamp));
            if let Some(id) = recording.job() {
                let js = convert::joint_setpoints(t, &names, o.stamp);
                recording.send(Msg::Setpoints(js));
                if t.spindle_rpm != last_spindle {
                    last_spindle = t.spindle_rpm;
                    let f = convert::spindle_command(t.spindle_rpm);
                    recording.send(Msg::Spindle(stamp_ns(&o.stamp), f));
                }
                if let Some(s) = &status {
                    recording.send(Msg::Status(s.clone()));
                }
                // (the job's recording holds the first sample after it)
                if o.job != id {
                    recording.send(Msg::Finish);
                }
            }
            action.cycle(Cycle {
                stamp_ns: ns,
                tick: &o.tick,
                job: o.job,
                place: o.place,
                status: o.status.as_ref(),
            });
            if let Some(s) = status {
                let _ = pub_status.publish(s);
            }
        })
        .map_err(|_| "the control loop stopped".to_string())?;
        recording.flush_due();
        if streaming {
            // (the samples of the cycles meanwhile wait in the queue)
            std::thread::sleep(SERVICE_POLL.saturating_sub(polled.elapsed()));
        }
    }
}

/// Hands `f` every sample waiting on `rx`, in order, after waiting up to
/// `wait` for the first; Err once the control loop is gone and its last
/// sample was handed on (rt_queue.rs: the end is told only by a queue
/// found empty, so a sample pushed just before it is never lost; the
/// recordings lacked one sample now and then, tests/ros/test_faults.py).
fn drain<T>(rx: &mut rt_queue::Rx<T>, wait: Duration, mut f: impl FnMut(T)) -> Result<(), Gone> {
    let mut next = rx.wait(wait)?;
    while let Some(o) = next {
        f(o);
        next = rx.pop()?;
    }
    Ok(())
}

/// How long a SIGINT/SIGTERM waits for a running job to stop (`ros2
/// launch` sends SIGTERM 5 s after SIGINT).
const SHUTDOWN_GRACE: Duration = Duration::from_secs(4);

/// How often the DDS thread looks for service requests and the feed
/// override, and takes the control loop's samples and the joint states,
/// while samples come every cycle (a job, and the second after one): a
/// wake-up every 4 ms, not one for each sample (the setpoints went out
/// from the control loop already); at rest it looks at every resting
/// sample, [`REST_WAIT`].
const SERVICE_POLL: Duration = Duration::from_millis(4);
/// Samples this close together (ns) come every cycle, not at the resting
/// rate (`ros::REST_RATE_HZ`, 20 ms apart).
const STREAMING_GAP_NS: i64 = 10_000_000;

/// How long the DDS thread waits for a sample at most: at rest one comes
/// every 1 / `ros::REST_RATE_HZ` (20 ms), so it then wakes about 50 times
/// a second instead of every [`SERVICE_POLL`] (250: 2.4–2.6 % of a core
/// idle on a slow host, BENCHMARKS.md "CPU per machine"). A request at rest is
/// answered up to 20 ms later; while samples come every cycle this wait
/// never runs out, and nothing changes.
const REST_WAIT: Duration = Duration::from_micros((1e6 / ros::REST_RATE_HZ) as u64);

/// Sends a command to the control loop and waits (briefly) for its answer.
fn ask(
    cmds: &CmdTx<Cmd>,
    make: impl FnOnce(Sender<Result<String, String>>) -> Cmd,
) -> (bool, String) {
    let (tx, rx) = mpsc::channel();
    if cmds.send(make(tx)).is_err() {
        return (false, "the control loop is not running".into());
    }
    match rx.recv_timeout(Duration::from_millis(500)) {
        Ok(Ok(m)) => (true, m),
        Ok(Err(m)) => (false, m),
        Err(_) => (false, "the control loop did not answer".into()),
    }
}

/// Closes a job's recording (on the recorder thread, `recording.rs`).
fn finish_recording(id: u32, rec: Rec, err: Option<String>) {
    let file = rec.file.clone();
    match err.map_or_else(|| rec.finish(), Err) {
        Ok(s) => ros_info!(
            "job {id} recorded to {} ({} messages, {} bytes)",
            file.display(),
            s.messages,
            s.bytes
        ),
        Err(e) => ros_error!("recording of job {id} to {} failed: {e}", file.display()),
    }
}

#[allow(clippy::too_many_arguments)]
fn check_worker(
    machine: Machine,
    dir: PathBuf,
    live: Arc<Live>,
    reqs: Receiver<(Asker, RunProgramRequest)>,
    resps: Sender<(Asker, RunProgramResponse)>,
    cmds: CmdTx<Cmd>,
    here: Arc<[AtomicU64; 3]>,
    checking: Arc<AtomicBool>,
) {
    let mut next_id = 1u32;
    while let Ok((id, req)) = reqs.recv() {
        let rec = live.record_opts();
        checking.store(true, Ordering::Relaxed);
        let resp = handle_run(&machine, &dir, &rec, &req, &mut next_id, &cmds, &here);
        checking.store(false, Ordering::Relaxed);
        observe::log_run(&req, &resp);
        let _ = resps.send((id, fit_run_reply(resp)));
    }
}

fn refuse(message: &str) -> RunProgramResponse {
    Refusal(message.to_string()).reply()
}

fn handle_run(
    machine: &Machine,
    dir: &Path,
    rec_opts: &RecordOpts,
    req: &RunProgramRequest,
    next_id: &mut u32,
    cmds: &CmdTx<Cmd>,
    here: &Arc<[AtomicU64; 3]>,
) -> RunProgramResponse {
    // checked from where the machine stands now; the job carries that
    // start, and the control loop refuses it if the machine has moved
    let now: Vec<f64> = here
        .iter()
        .map(|h| f64::from_bits(h.load(Ordering::Relaxed)))
        .collect();
    let admitted = match admit(req, machine, &now, dir) {
        Ok(a) => a,
        Err(r) => return r.reply(),
    };
    if admitted.dry_run {
        return admitted.reply(0, String::new());
    }
    let job_id = *next_id;
    let recorder = match recorder(&admitted, job_id, machine, rec_opts) {
        Ok(r) => r.map(Box::new),
        Err(r) => return r.reply(),
    };
    let recording = recorder
        .as_ref()
        .map(|r| r.file.display().to_string())
        .unwrap_or_default();
    let accepted = admitted.reply(job_id, recording);
    let (tx, rx) = mpsc::channel();
    if cmds
        .send(Cmd::Start(admitted.job(job_id), recorder, tx))
        .is_err()
    {
        return refuse("the control loop is not running");
    }
    match rx.recv_timeout(Duration::from_secs(2)) {
        Ok(Ok(())) => {
            *next_id += 1;
            accepted
        }
        Ok(Err(m)) => refuse(&m),
        Err(_) => refuse("the control loop did not answer"),
    }
}

#[cfg(test)]
mod tests {
    use super::drain;
    use cnc_node::rt_queue::{self, Gone};
    use std::time::Duration;

    /// A producer as fast as it goes (the control loop catching up, waiting
    /// when the queue is full) and a consumer draining as the node's DDS
    /// thread does: every sample arrives once, in order, and the end is
    /// told after the last. (A drain that asked for the end with one more
    /// receive lost a sample in most runs of this test.)
    #[test]
    fn every_sample_of_the_loop_is_handed_on_in_order() {
        for round in 0..20 {
            let n = 50_000u64;
            let (tx, mut rx) = rt_queue::spsc::<u64>(8192);
            let mut tx = tx.wake(std::thread::current());
            let producer = std::thread::spawn(move || {
                let mut k = 0;
                while k < n {
                    if tx.push(k) {
                        k += 1;
                    } else {
                        std::thread::yield_now();
                    }
                    if k % 97 == 0 {
                        std::thread::yield_now();
                    }
                }
            });
            let mut got = Vec::with_capacity(n as usize);
            let end = loop {
                if let Err(e) = drain(&mut rx, Duration::from_millis(2), |k| got.push(k)) {
                    break e;
                }
            };
            producer.join().expect("producer");
            assert_eq!(end, Gone);
            assert_eq!(got.len() as u64, n, "round {round}");
            assert!(
                got.iter().enumerate().all(|(i, &k)| i as u64 == k),
                "round {round}"
            );
        }
    }
}
