//! `cnc run`: sends a program to a running controller node through
//! `<ns>/run_program`, follows `<ns>/status` to the end of the job and
//! reports it; Ctrl-C aborts the job (`<ns>/abort`). `cnc abort`, `hold`,
//! `resume`, `override` and `status` act on a running controller. A plain
//! ROS 2 client: no ROS installation needed.

use cnc_msgs::ros;
use cnc_msgs::{
    ControllerStatus, Float64, RunProgramRequest, RunProgramResponse, SetBoolRequest,
    SetBoolResponse, TriggerRequest, TriggerResponse,
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A job is given up only when the controller stops reporting for this
/// long (its status comes at least every 100 ms): a feed hold of any
/// length keeps `cnc run` waiting.
pub const SILENCE_LIMIT: Duration = Duration::from_secs(10);

/// Which controller a command talks to.
#[derive(Clone, Debug)]
pub struct Target {
    pub namespace: String,
    pub domain: u16,
    /// how long to wait for the controller to appear
    pub wait: Duration,
}

fn join(domain: u16) -> Result<(ros2_client::Context, ros2_client::Node), String> {
    ros::join(domain, "/", &format!("cnc_cli_{}", std::process::id()))
}

fn no_controller(t: &Target, what: &str) -> String {
    format!(
        "no controller answers at {}/{what} (is cnc_node running on domain {}?)",
        t.namespace, t.domain
    )
}

/// Calls `<ns>/abort`: the running job decelerates along its path and ends.
pub fn abort(t: &Target) -> Result<(bool, String), String> {
    let (_ctx, mut node) = join(t.domain)?;
    let c = ros::client::<TriggerRequest, TriggerResponse>(&mut node, &t.namespace, "abort")?;
    timeout(t.wait, c.wait_for_service(&node)).ok_or_else(|| no_controller(t, "abort"))?;
    let r = timeout(
        Duration::from_secs(10),
        c.async_call_service(TriggerRequest::default()),
    )
    .ok_or("the controller did not answer within 10 s")?
    .map_err(|e| format!("service call: {e:?}"))?;
    Ok((r.success, r.message))
}

/// Calls `<ns>/feed_hold`: true holds (decelerating along the path),
/// false resumes.
pub fn hold(t: &Target, on: bool) -> Result<(bool, String), String> {
    let (_ctx, mut node) = join(t.domain)?;
    let c = ros::client::<SetBoolRequest, SetBoolResponse>(&mut node, &t.namespace, "feed_hold")?;
    timeout(t.wait, c.wait_for_service(&node)).ok_or_else(|| no_controller(t, "feed_hold"))?;
    let r = timeout(
        Duration::from_secs(10),
        c.async_call_service(SetBoolRequest { data: on }),
    )
    .ok_or("the controller did not answer within 10 s")?
    .map_err(|e| format!("service call: {e:?}"))?;
    Ok((r.success, r.message))
}

/// The controller's next status message.
pub fn status(t: &Target) -> Result<ControllerStatus, String> {
    let (_ctx, mut node) = join(t.domain)?;
    let sub = ros::subscription::<ControllerStatus>(&mut node, &t.namespace, "status")?;
    let end = Instant::now() + t.wait;
    while Instant::now() < end {
        if let Ok(Some((s, _))) = sub.take() {
            return Ok(s);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Err(format!(
        "no status from {}/status within {:.0} s (is cnc_node running on domain {}?)",
        t.namespace,
        t.wait.as_secs_f64(),
        t.domain
    ))
}

/// Publishes the feed override on `<ns>/feed_override` (percent, 0..200)
/// until the controller's status shows it in force; its status then.
pub fn set_override(t: &Target, percent: f64) -> Result<ControllerStatus, String> {
    if !(0.0..=200.0).contains(&percent) {
        return Err(format!(
            "feed override {percent} %: must be between 0 and 200 %"
        ));
    }
    let (_ctx, mut node) = join(t.domain)?;
    let publisher = ros::publisher::<Float64>(&mut node, &t.namespace, "feed_override")?;
    let sub = ros::subscription::<ControllerStatus>(&mut node, &t.namespace, "status")?;
    let end = Instant::now() + t.wait;
    let mut next = Instant::now();
    while Instant::now() < end {
        if Instant::now() >= next {
            let _ = publisher.publish(Float64 { data: percent });
            next = Instant::now() + Duration::from_millis(100);
        }
        while let Ok(Some((s, _))) = sub.take() {
            if (s.feed_override - percent / 100.0).abs() < 1e-9 {
                return Ok(s);
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Err(format!(
        "the controller at {} did not take the override within {:.0} s",
        t.namespace,
        t.wait.as_secs_f64()
    ))
}

/// A state's name as the status message numbers it.
pub fn state_name(state: u8) -> &'static str {
    match state {
        ControllerStatus::STATE_IDLE => "IDLE",
        ControllerStatus::STATE_RUNNING => "RUNNING",
        ControllerStatus::STATE_HOLD => "HOLD",
        ControllerStatus::STATE_ERROR => "ERROR",
        _ => "UNKNOWN",
    }
}

/// What to send.
pub struct RunRequest {
    pub namespace: String,
    pub domain: u16,
    pub program: String,
    pub program_path: String,
    pub dialect: String,
    pub dry_run: bool,
    /// ask the node to record the job
    pub record: bool,
    /// how long to wait for the service to appear
    pub connect_timeout: Duration,
}

/// How the job went.
#[derive(Debug)]
pub enum RunOutcome {
    Refused(String),
    Checked {
        estimated: f64,
    },
    Done {
        job_id: u32,
        estimated: f64,
        wall: f64,
        lines: u32,
        /// the node's recording of the job, if it was recorded
        recording: String,
    },
    Failed {
        job_id: u32,
        error: String,
    },
    /// Ctrl-C: the job was aborted (it stopped along its path)
    Aborted {
        job_id: u32,
        lines: u32,
    },
}

fn timeout<T>(d: Duration, f: impl std::future::Future<Output = T>) -> Option<T> {
    smol::block_on(smol::future::or(async { Some(f.await) }, async {
        smol::Timer::after(d).await;
        None
    }))
}

/// Runs a job to its end. `progress` sees every status of the job (a
/// progress bar). Ctrl-C (SIGINT, SIGTERM) while the job runs aborts it
/// through `<ns>/abort` and waits for it to stop.
pub fn run(
    req: RunRequest,
    mut progress: impl FnMut(&ControllerStatus),
) -> Result<RunOutcome, String> {
    let (_ctx, mut node) = join(req.domain)?;
    let ns = req.namespace.as_str();
    let client =
        ros::client::<RunProgramRequest, RunProgramResponse>(&mut node, ns, "run_program")?;
    let abort_client = ros::client::<TriggerRequest, TriggerResponse>(&mut node, ns, "abort")?;
    let status = ros::subscription::<ControllerStatus>(&mut node, ns, "status")?;
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupted.clone();
        // (a second handler in one process is refused: then Ctrl-C just ends cnc)
        let _ = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst));
    }
    if timeout(req.connect_timeout, client.wait_for_service(&node)).is_none() {
        return Err(format!(
            "no controller answers at {ns}/run_program (is cnc_node running on domain {}?)",
            req.domain
        ));
    }
    let request = RunProgramRequest {
        program: req.program,
        program_path: req.program_path,
        dialect: req.dialect,
        dry_run: req.dry_run,
        record: req.record,
    };
    let resp = timeout(Duration::from_secs(60), client.async_call_service(request))
        .ok_or("the controller did not answer within 60 s")?
        .map_err(|e| format!("service call: {e:?}"))?;
    if !resp.accepted {
        return Ok(RunOutcome::Refused(resp.message));
    }
    if req.dry_run {
        return Ok(RunOutcome::Checked {
            estimated: resp.estimated_duration,
        });
    }
    let start = Instant::now();
    let mut heard = Instant::now();
    let mut seen_running = false;
    let mut aborted = false;
    let mut lines = 0u32;
    loop {
        if interrupted.load(Ordering::SeqCst) && !aborted {
            aborted = true;
            let answer = timeout(
                Duration::from_secs(10),
                abort_client.async_call_service(TriggerRequest::default()),
            );
            if !matches!(answer, Some(Ok(TriggerResponse { success: true, .. }))) {
                return Err(format!(
                    "job {}: Ctrl-C, but the controller did not take the abort: {answer:?}",
                    resp.job_id
                ));
            }
        }
        while let Ok(Some((s, _))) = status.take() {
            heard = Instant::now();
            if s.job_id != resp.job_id {
                continue;
            }
            progress(&s);
            lines = lines.max(s.source_line);
            match s.state {
                ControllerStatus::STATE_RUNNING | ControllerStatus::STATE_HOLD => {
                    seen_running = true
                }
                ControllerStatus::STATE_ERROR => {
                    return Ok(RunOutcome::Failed {
                        job_id: resp.job_id,
                        error: s.last_error,
                    });
                }
                ControllerStatus::STATE_IDLE if aborted => {
                    return Ok(RunOutcome::Aborted {
                        job_id: resp.job_id,
                        lines,
                    });
                }
                ControllerStatus::STATE_IDLE if seen_running || s.progress >= 1.0 => {
                    if !s.last_error.is_empty() {
                        return Ok(RunOutcome::Failed {
                            job_id: resp.job_id,
                            error: s.last_error,
                        });
                    }
                    return Ok(RunOutcome::Done {
                        job_id: resp.job_id,
                        estimated: resp.estimated_duration,
                        wall: start.elapsed().as_secs_f64(),
                        lines,
                        recording: resp.recording.clone(),
                    });
                }
                _ => {}
            }
        }
        if heard.elapsed() > SILENCE_LIMIT {
            return Err(format!(
                "job {}: the controller stopped reporting (no status for {:.0} s)",
                resp.job_id,
                SILENCE_LIMIT.as_secs_f64()
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}
