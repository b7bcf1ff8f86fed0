//! Recordings of offline runs: [`SimRecorder`] is the [`Sink`] that
//! records the steps of a run (`cnc simulate --mcap`, `cnc bag rerun`).

use super::path::{GrowingPath, LivePath, GROWING_MAX_POINTS};
use super::writer::{ChannelId, RecordSummary, Recorder, RecordingInfo};
use crate::convert::{
    joint_state, joint_velocities, push_point, sample_status, spindle_command, time_from_ns,
    tool_pose, tool_position, tool_tf, toolpath_cloud, topics, POSE_EVERY, TOOLPATH_MAX_POINTS,
};
use crate::offline::{check_text, run, run_with, SimSummary, Sink, Step};
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine};
use cnc_msgs::{
    ControllerStatus, Float64, JointState, PointCloud2, PoseStamped, SpindleEncoder, TFMessage,
};
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

/// Time of sample 0 in offline recordings: 1_700_000_000 s after the Unix
/// epoch, in ns (fixed, so that recordings are deterministic).
pub const EPOCH_NS: u64 = 1_700_000_000_000_000_000;

/// Runs `program_text` offline against the simulated machine (as `cnc
/// simulate` does) and records the run to `out`:
///
/// | topic | type | when |
/// |---|---|---|
/// | `/cnc/joint_setpoints` | sensor_msgs/JointState | every sample, m |
/// | `/sim/joint_states` | sensor_msgs/JointState | every sample, m and m/s (finite differences) |
/// | `/sim/spindle_encoder` | cnc_msgs/SpindleEncoder | every sample, a machine with a spindle: the simulated encoder after the step (what the executor was given) |
/// | `/cnc/spindle_command` | std_msgs/Float64 | first sample and on change, rad/s |
/// | `/cnc/status` | cnc_msgs/ControllerStatus | 10 Hz, on a line change, last sample (idle) |
/// | `/tf` | tf2_msgs/TFMessage | `world` → `tool` every 10th and the last sample |
/// | `/cnc/tool_pose` | geometry_msgs/PoseStamped | every 10th and the last sample |
/// | `/cnc/toolpath` | sensor_msgs/PointCloud2 | the path so far every second (thinned to 5 000 points, [`GrowingPath`]) and the whole path at the end: x, y, z float32, m |
/// | `/cnc/program`, `/cnc/machine_file` | std_msgs/String | once, at the first sample |
///
/// Sample k is stamped [`EPOCH_NS`] + k·dt, so equal inputs give
/// byte-identical files. The tool position is the commanded X, Y, Z in
/// metres (lathe: X is the radius, Y 0). The program must pass the check;
/// otherwise nothing is written and the errors are returned.
pub fn record_simulation(
    machine: &Machine,
    program_name: &str,
    program_text: &str,
    dialect: Dialect,
    out: &Path,
) -> Result<RecordSummary, String> {
    record_simulation_as(machine, None, program_name, program_text, dialect, out)
}

/// [`record_simulation`] attaching `machine_text` as the machine file (a
/// rerun's: the recording's own, as it was written); `None`: the machine
/// as read.
pub fn record_simulation_as(
    machine: &Machine,
    machine_text: Option<&str>,
    program_name: &str,
    program_text: &str,
    dialect: Dialect,
    out: &Path,
) -> Result<RecordSummary, String> {
    let report = check_text(
        machine,
        dialect,
        program_name,
        program_text,
        "nothing recorded",
    )?;
    let mut info = RecordingInfo::offline(machine, program_name, program_text, dialect)?;
    if let Some(text) = machine_text {
        // (a rerun attaches the machine file as the recording had it)
        info.machine_toml = text.to_string();
    }
    let mut rec = SimRecorder::create(out, info, machine, report.ticks)?;
    run(
        StrSource::new(program_text),
        dialect,
        machine,
        &mut [&mut rec],
    )?;
    rec.into_summary()
}

/// The recording of one offline run; `ticks` is the check's sample count
/// (for the progress and the decimation of the tool path).
pub fn record_run<W: Write + Seek>(
    rec: Recorder<W>,
    machine: &Machine,
    program_text: &str,
    dialect: Dialect,
    ticks: u64,
) -> Result<RecordSummary, String> {
    record_run_with(rec, machine, program_text, dialect, ticks, |_| {})
}

/// [`record_run`] with `alter` applied to every interpolator sample (see
/// [`crate::offline::simulate_with`]).
pub fn record_run_with<W: Write + Seek>(
    rec: Recorder<W>,
    machine: &Machine,
    program_text: &str,
    dialect: Dialect,
    ticks: u64,
    alter: impl FnMut(&mut cnc_core::exec::Sample),
) -> Result<RecordSummary, String> {
    let mut r = SimRecorder::new(rec, machine, ticks)?;
    run_with(
        StrSource::new(program_text),
        dialect,
        machine,
        alter,
        &mut [&mut r],
    )?;
    r.into_summary()
}

/// Records the steps of an offline run (the topics of
/// [`record_simulation`]); the recording is complete once the run has
/// finished the sink, and [`into_summary`](Self::into_summary) tells what
/// it holds.
pub struct SimRecorder<W: Write + Seek> {
    /// None once finished
    rec: Option<Recorder<W>>,
    summary: Option<RecordSummary>,
    /// what errors are prefixed with (the file)
    context: Option<String>,
    names: Vec<String>,
    setpoints: ChannelId<JointState>,
    joint_states: ChannelId<JointState>,
    /// a machine with a spindle
    encoder: Option<ChannelId<SpindleEncoder>>,
    spindle: ChannelId<Float64>,
    status: ChannelId<ControllerStatus>,
    tf: ChannelId<TFMessage>,
    tool_pose: ChannelId<PoseStamped>,
    toolpath: ChannelId<PointCloud2>,
    dt: f64,
    ticks: u64,
    status_every: u64,
    path_every: u64,
    prev_actual: Vec<f64>,
    last_spindle: Option<f64>,
    last_line: Option<u32>,
    path: Vec<u8>,
    /// the path so far for the growing clouds, thinned as it grows (so the
    /// first seconds of a run record the same whatever its length)
    so_far: LivePath,
    growing: GrowingPath,
    last_ns: u64,
}

impl SimRecorder<BufWriter<File>> {
    /// A recording of the job `info` into the file `out` (created,
    /// truncated); `ticks` is the check's sample count. Errors name the
    /// file.
    pub fn create(
        out: &Path,
        info: RecordingInfo,
        machine: &Machine,
        ticks: u64,
    ) -> Result<Self, String> {
        let rec = Recorder::create(out, info)?;
        let context = out.display().to_string();
        let mut r = SimRecorder::new(rec, machine, ticks).map_err(|e| format!("{context}: {e}"))?;
        r.context = Some(context);
        Ok(r)
    }
}

impl<W: Write + Seek> SimRecorder<W> {
    /// A recording of a run into `rec`; `ticks` is the check's sample
    /// count (the status's progress, the tool path's decimation).
    pub fn new(mut rec: Recorder<W>, machine: &Machine, ticks: u64) -> Result<Self, String> {
        let rate = machine.interpolation.rate_hz;
        let points = ticks.saturating_add(1);
        // every path_every-th sample and the last one: at most TOOLPATH_MAX_POINTS
        let path_every = if points <= TOOLPATH_MAX_POINTS {
            1
        } else {
            points.div_ceil(TOOLPATH_MAX_POINTS - 1)
        };
        Ok(SimRecorder {
            setpoints: rec.channel(topics::JOINT_SETPOINTS)?,
            joint_states: rec.channel(topics::JOINT_STATES)?,
            encoder: match machine.spindle {
                Some(_) => Some(rec.channel(topics::SPINDLE_ENCODER)?),
                None => None,
            },
            spindle: rec.channel(topics::SPINDLE_COMMAND)?,
            status: rec.channel(topics::STATUS)?,
            tf: rec.channel(topics::TF)?,
            tool_pose: rec.channel(topics::TOOL_POSE)?,
            toolpath: rec.channel(topics::TOOLPATH)?,
            rec: Some(rec),
            summary: None,
            context: None,
            names: machine.axes.iter().map(|a| a.name.clone()).collect(),
            dt: 1.0 / rate,
            ticks,
            status_every: ((rate / 10.0).round() as u64).max(1),
            path_every,
            prev_actual: Vec::new(),
            last_spindle: None,
            last_line: None,
            path: Vec::with_capacity(
                (points.div_ceil(path_every).min(TOOLPATH_MAX_POINTS) as usize + 1) * 12,
            ),
            so_far: LivePath::default(),
            growing: GrowingPath::default(),
            last_ns: EPOCH_NS,
        })
    }

    /// What the finished recording holds; an error if the run did not
    /// finish it (a failed step).
    pub fn into_summary(self) -> Result<RecordSummary, String> {
        let context = self.context;
        self.summary.ok_or_else(|| {
            let e = "the recording was not finished";
            match context {
                Some(c) => format!("{c}: {e}"),
                None => e.to_string(),
            }
        })
    }

    fn with_context(&self, e: String) -> String {
        match &self.context {
            Some(c) => format!("{c}: {e}"),
            None => e,
        }
    }

    fn record(&mut self, st: &Step) -> Result<(), String> {
        let Some(rec) = self.rec.as_mut() else {
            return Err("the recording is finished".into());
        };
        let s = st.sample;
        let ns = EPOCH_NS + (s.t * 1e9).round() as u64;
        self.last_ns = ns;
        rec.write(
            self.setpoints,
            ns,
            &joint_state(ns, &self.names, st.setpoints, Vec::new()),
        )?;
        let velocity = joint_velocities(st.actual, &self.prev_actual, self.dt);
        self.prev_actual.clear();
        self.prev_actual.extend_from_slice(st.actual);
        rec.write(
            self.joint_states,
            ns,
            &joint_state(ns, &self.names, st.actual, velocity),
        )?;
        if let (Some(ch), Some(sp)) = (self.encoder, st.spindle) {
            let e = sp.encoder();
            let m = SpindleEncoder {
                stamp: time_from_ns(ns),
                count: e.count,
                counts_per_rev: e.counts_per_rev,
                index_count: e.index_count,
                count_at_index: e.count_at_index,
                velocity: e.velocity,
            };
            rec.write(ch, ns, &m)?;
        }
        if self.last_spindle != Some(s.spindle_rpm) {
            self.last_spindle = Some(s.spindle_rpm);
            rec.write(self.spindle, ns, &spindle_command(s.spindle_rpm))?;
        }
        if s.k.is_multiple_of(self.status_every) || self.last_line != Some(s.src.line) || s.last {
            self.last_line = Some(s.src.line);
            let progress = if s.last || self.ticks == 0 {
                1.0
            } else {
                (s.k as f64 / self.ticks as f64).min(1.0)
            };
            rec.write(self.status, ns, &sample_status(ns, s, progress))?;
        }
        let p = tool_position(s);
        if s.k.is_multiple_of(POSE_EVERY) || s.last {
            rec.write(self.tf, ns, &tool_tf(ns, p))?;
            rec.write(self.tool_pose, ns, &tool_pose(ns, p))?;
        }
        if s.k.is_multiple_of(self.path_every) || s.last {
            push_point(&mut self.path, p);
        }
        // the path so far (the whole path follows at the end)
        self.so_far.push(s.k, p);
        if self.growing.due(ns) && !s.last {
            let cloud = toolpath_cloud(self.so_far.so_far(GROWING_MAX_POINTS, p), ns);
            rec.write(self.toolpath, ns, &cloud)?;
        }
        Ok(())
    }

    fn close(&mut self) -> Result<RecordSummary, String> {
        let Some(mut rec) = self.rec.take() else {
            return Err("the recording is finished".into());
        };
        let cloud = toolpath_cloud(std::mem::take(&mut self.path), self.last_ns);
        rec.write(self.toolpath, self.last_ns, &cloud)?;
        rec.finish()
    }
}

impl<W: Write + Seek> Sink for SimRecorder<W> {
    fn step(&mut self, st: &Step) -> Result<(), String> {
        self.record(st).map_err(|e| self.with_context(e))
    }

    fn finish(&mut self, _: &SimSummary) -> Result<(), String> {
        let summary = self.close().map_err(|e| self.with_context(e))?;
        self.summary = Some(summary);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convert::time_from_ns;
    use cnc_msgs::Time;

    #[test]
    fn stamps() {
        assert_eq!(
            time_from_ns(EPOCH_NS + 1_500_000_123),
            Time {
                sec: 1_700_000_001,
                nanosec: 500_000_123
            }
        );
    }
}
