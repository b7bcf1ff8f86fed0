//! `cnc run`: sends a program to a running controller node through
//! `<ns>/run_program`, follows `<ns>/status` to the end of the job and
//! reports it. A plain ROS 2 client: no ROS installation needed.

use cnc_msgs::ros;
use cnc_msgs::{ControllerStatus, RunProgramRequest, RunProgramResponse};
use std::time::{Duration, Instant};

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
}

fn timeout<T>(d: Duration, f: impl std::future::Future<Output = T>) -> Option<T> {
    smol::block_on(smol::future::or(async { Some(f.await) }, async {
        smol::Timer::after(d).await;
        None
    }))
}

pub fn run(req: RunRequest) -> Result<RunOutcome, String> {
    let (_ctx, mut node) = ros::join(req.domain, "/", &format!("cnc_cli_{}", std::process::id()))?;
    let ns = req.namespace.as_str();
    let client =
        ros::client::<RunProgramRequest, RunProgramResponse>(&mut node, ns, "run_program")?;
    let status = ros::subscription::<ControllerStatus>(&mut node, ns, "status")?;
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
    let limit = Duration::from_secs_f64(resp.estimated_duration * 3.0 + 30.0);
    let mut seen_running = false;
    let mut lines = 0u32;
    loop {
        while let Ok(Some((s, _))) = status.take() {
            if s.job_id != resp.job_id {
                continue;
            }
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
        if start.elapsed() > limit {
            return Err(format!(
                "job {} did not end within {:.0} s",
                resp.job_id,
                limit.as_secs_f64()
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}
