//! What the node shows of itself for ROS tools (RViz, Foxglove,
//! rqt_robot_monitor, rqt_console), on its DDS thread ([`Observer`]):
//!
//! - `<ns>/robot_description` (`std_msgs/String`, reliable, transient
//!   local, depth 1, as `robot_state_publisher`): the machine's URDF
//!   ([`crate::urdf`]), once at the start;
//! - `/tf_static` (transient local, depth 1, as tf2's static broadcaster):
//!   the model's fixed joints (`world` → `base_link`, the last slide →
//!   `tool`), once;
//! - `/tf` (reliable, volatile, depth 100, as tf2's broadcaster): the
//!   model's moving joints from the setpoints (each axis's slide) and the
//!   spindle's angle from the newest encoder reading, every
//!   [`TF_RUNNING_NS`] while a job runs or holds, every [`TF_REST_NS`] at
//!   rest, and at every change of state (so the end of a job is there at
//!   once);
//! - `/diagnostics` (`diagnostic_msgs/DiagnosticArray`) every
//!   [`crate::diagnostics::PERIOD`]: the control loop, the spindle encoder,
//!   the job;
//! - the job's log lines (held, resumed, finished, aborted, failed) on
//!   stderr and `/rosout`; `log_run` logs the answer to `run_program`
//!   (accepted, refused).

use crate::controller::{State, Status, Tick};
use crate::convert::{self, time_ns};
use crate::diagnostics::{EncoderWatch, JobWatch, LoopWindow, LOOP, PERIOD};
use crate::urdf::{Frame, Model};
use cnc_core::Machine;
use cnc_msgs::ros;
use cnc_msgs::{DiagnosticArray, SpindleEncoder, StringMsg, TFMessage, Time};
use ros2_client::{Node, Publisher};
use std::time::Instant;

/// `/tf` while a job runs: every 20 ms (50 Hz) of setpoint stamps.
pub const TF_RUNNING_NS: i64 = 20_000_000;
/// `/tf` at rest: every second.
pub const TF_REST_NS: i64 = 1_000_000_000;

/// The node's robot description, frames, diagnostics and job log (see the
/// module's text). Lives on the node's DDS thread.
pub struct Observer {
    model: Model,
    hardware_id: String,
    rate_hz: f64,
    tf: Publisher<TFMessage>,
    diagnostics: Publisher<DiagnosticArray>,
    encoder: EncoderWatch,
    job: JobWatch,
    last_tf_ns: Option<i64>,
    last_state: Option<State>,
    diag_since: Instant,
    /// kept alive: their transient-local history serves late subscribers
    _description: Publisher<StringMsg>,
    _tf_static: Publisher<TFMessage>,
}

fn frames(f: &[Frame]) -> impl Iterator<Item = (&str, &str, [f64; 3], [f64; 4])> {
    f.iter().map(|f| {
        (
            f.parent.as_str(),
            f.child.as_str(),
            f.translation,
            f.rotation,
        )
    })
}

impl Observer {
    /// Publishes the robot description and the static frames of `machine`
    /// for the node `ns`, and makes the other publishers.
    pub fn new(node: &mut Node, ns: &str, machine: &Machine) -> Result<Self, String> {
        let model = Model::of(machine);
        let latched = ros::qos_latched();
        let description =
            ros::publisher_with_qos::<StringMsg>(node, ns, "robot_description", &latched)?;
        let tf_static = ros::publisher_with_qos::<TFMessage>(node, "/", "tf_static", &latched)?;
        let tf = ros::publisher_with_qos::<TFMessage>(node, "/", "tf", &ros::qos_tf())?;
        let diagnostics = ros::publisher::<DiagnosticArray>(node, "/", "diagnostics")?;
        description
            .publish(StringMsg {
                data: model.to_urdf(),
            })
            .map_err(|e| format!("{ns}/robot_description: {e:?}"))?;
        tf_static
            .publish(convert::transforms(
                ros::wall_stamp(),
                frames(&model.fixed()),
            ))
            .map_err(|e| format!("/tf_static: {e:?}"))?;
        Ok(Observer {
            model,
            hardware_id: format!("{} ({})", machine.name, ns.trim_end_matches('/')),
            rate_hz: machine.interpolation.rate_hz,
            tf,
            diagnostics,
            encoder: EncoderWatch::new(machine),
            job: JobWatch::default(),
            last_tf_ns: None,
            last_state: None,
            diag_since: Instant::now(),
            _description: description,
            _tf_static: tf_static,
        })
    }

    /// A cycle's setpoints (and its status, when it has one), as published.
    pub fn sample(&mut self, stamp: Time, tick: &Tick, status: Option<&Status>) {
        let ns = time_ns(&stamp);
        if let Some(s) = status {
            if let Some((level, line)) = self.job.status(s, ns) {
                cnc_msgs::ros_log!(level, "{line}");
            }
        }
        let changed = self.last_state != Some(tick.state);
        self.last_state = Some(tick.state);
        let every = match tick.state {
            State::Running | State::Hold => TF_RUNNING_NS,
            State::Idle | State::Error => TF_REST_NS,
        };
        if changed || self.last_tf_ns.is_none_or(|t| ns - t >= every || ns < t) {
            self.last_tf_ns = Some(ns);
            let n = tick.n.min(tick.positions.len());
            let m: Vec<f64> = tick.positions[..n].iter().map(|p| p / 1000.0).collect();
            let moving = self.model.moving(&m, self.encoder.angle());
            let _ = self.tf.publish(convert::transforms(stamp, frames(&moving)));
        }
    }

    /// A spindle encoder reading, as received.
    pub fn encoder(&mut self, m: &SpindleEncoder) {
        self.encoder.reading(m, now_ns());
    }

    /// Publishes `/diagnostics` when a period has passed; call it every
    /// turn of the DDS thread's loop.
    pub fn poll(&mut self) {
        let now = now_ns();
        self.encoder.look(now);
        let period = self.diag_since.elapsed();
        if period < PERIOD {
            return;
        }
        self.diag_since = Instant::now();
        let p = period.as_secs_f64();
        let window: LoopWindow = LOOP.take();
        let array = DiagnosticArray {
            header: convert::header(convert::time_from_ns(now.max(0) as u64), ""),
            status: vec![
                window.status(self.rate_hz, p, &self.hardware_id),
                self.encoder.status(now, p, &self.hardware_id),
                self.job.diagnostic(&self.hardware_id),
            ],
        };
        let _ = self.diagnostics.publish(array);
    }
}

/// The system clock, ns since the Unix epoch (the clock of the stamps).
fn now_ns() -> i64 {
    time_ns(&ros::wall_stamp())
}

/// Logs the answer to a `run_program` request: the job accepted (INFO:
/// checked and started by the control loop; the check worker logs it, so
/// in a busy machine it may come a little after the job's first status),
/// a dry run checked (INFO), or the refusal with its message (ERROR: a
/// program's errors by line and column, a job running, ...).
pub fn log_run(req: &cnc_msgs::RunProgramRequest, resp: &cnc_msgs::RunProgramResponse) {
    let what = if req.program_path.is_empty() {
        format!("a program of {} bytes", req.program.len())
    } else {
        format!("{:?}", req.program_path)
    };
    let est = format!("estimated {:.3} s", resp.estimated_duration);
    match (resp.accepted, resp.job_id) {
        (true, 0) => cnc_msgs::ros_info!("dry run of {what}: checked, {est}"),
        (true, id) => {
            let rec = if resp.recording.is_empty() {
                String::new()
            } else {
                format!(", recording to {}", resp.recording)
            };
            cnc_msgs::ros_info!("job {id} accepted: {what}, {est}{rec}")
        }
        (false, _) => cnc_msgs::ros_error!("run_program refused ({what}): {}", resp.message),
    }
}
