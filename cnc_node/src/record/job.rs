//! The live job recorder of the node: [`JobRecorder`].

use super::path::{GrowingPath, LivePath, GROWING_MAX_POINTS};
use super::writer::{ChannelId, RecordSummary, Recorder, RecordingInfo, LIVE_CHUNK_SPAN_NS};
use crate::convert::{stamp_ns, tool_pose, tool_tf, toolpath_cloud, topics, POSE_EVERY};
use cnc_core::Machine;
use cnc_msgs::{ControllerStatus, Float64, JointState, PointCloud2, PoseStamped, TFMessage};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// A job recorded live by the node: the setpoints, spindle command and
/// status as the node publishes them, and the simulator's joint states
/// and encoder as the node receives them, stamped with their header times.
/// The tool path (`/tf`, `/cnc/tool_pose` every 10th setpoint,
/// `/cnc/toolpath` growing every second and whole at the end) is derived
/// from the setpoints, so Rerun shows the job in 3D as it shows offline
/// recordings. The toolpath cloud covers the whole job however long it
/// runs ([`LivePath`]: every setpoint up to [`TOOLPATH_MAX_POINTS`], then
/// every 2nd, 4th, ... and the last); the growing ones are that path so
/// far, thinned ([`GrowingPath`]).
pub struct JobRecorder {
    rec: Recorder<BufWriter<File>>,
    setpoints: ChannelId<JointState>,
    joint_states: ChannelId<JointState>,
    spindle: ChannelId<Float64>,
    status: ChannelId<ControllerStatus>,
    encoder: ChannelId<cnc_msgs::SpindleEncoder>,
    tf: ChannelId<TFMessage>,
    tool_pose: ChannelId<PoseStamped>,
    toolpath: ChannelId<PointCloud2>,
    /// machine coordinate (0 X, 1 Y, 2 Z) of each joint
    joints: Vec<usize>,
    k: u64,
    path: LivePath,
    growing: GrowingPath,
    last_ns: u64,
    /// where the file is
    pub file: std::path::PathBuf,
}

impl JobRecorder {
    pub fn create(file: &Path, info: RecordingInfo, machine: &Machine) -> Result<Self, String> {
        let mut rec = Recorder::create(file, info)?;
        rec.set_max_chunk_span(Some(LIVE_CHUNK_SPAN_NS));
        Ok(JobRecorder {
            setpoints: rec.channel(topics::JOINT_SETPOINTS)?,
            joint_states: rec.channel(topics::JOINT_STATES)?,
            spindle: rec.channel(topics::SPINDLE_COMMAND)?,
            status: rec.channel(topics::STATUS)?,
            encoder: rec.channel(topics::SPINDLE_ENCODER)?,
            tf: rec.channel(topics::TF)?,
            tool_pose: rec.channel(topics::TOOL_POSE)?,
            toolpath: rec.channel(topics::TOOLPATH)?,
            rec,
            joints: machine.joint_indices(),
            k: 0,
            path: LivePath::default(),
            growing: GrowingPath::default(),
            last_ns: 0,
            file: file.to_path_buf(),
        })
    }

    /// One published setpoint sample (m).
    pub fn setpoints(&mut self, m: &JointState) -> Result<(), String> {
        let ns = stamp_ns(&m.header.stamp);
        self.last_ns = self.last_ns.max(ns);
        self.rec.write(self.setpoints, ns, m)?;
        let mut p = [0.0; 3];
        for (&i, v) in self.joints.iter().zip(&m.position) {
            if let Some(c) = p.get_mut(i) {
                *c = *v;
            }
        }
        if self.k.is_multiple_of(POSE_EVERY) {
            self.rec.write(self.tf, ns, &tool_tf(ns, p))?;
            self.rec.write(self.tool_pose, ns, &tool_pose(ns, p))?;
        }
        self.path.push(self.k, p);
        self.k += 1;
        if self.growing.due(ns) {
            let cloud = toolpath_cloud(self.path.so_far(GROWING_MAX_POINTS, p), ns);
            self.rec.write(self.toolpath, ns, &cloud)?;
        }
        Ok(())
    }

    pub fn joint_states(&mut self, m: &JointState) -> Result<(), String> {
        self.rec
            .write(self.joint_states, stamp_ns(&m.header.stamp), m)
    }

    pub fn encoder(&mut self, m: &cnc_msgs::SpindleEncoder) -> Result<(), String> {
        self.rec.write(self.encoder, stamp_ns(&m.stamp), m)
    }

    pub fn spindle(&mut self, ns: u64, m: &Float64) -> Result<(), String> {
        self.rec.write(self.spindle, ns, m)
    }

    pub fn status(&mut self, m: &ControllerStatus) -> Result<(), String> {
        self.rec.write(self.status, stamp_ns(&m.header.stamp), m)
    }

    /// Writes the tool path and the summary.
    pub fn finish(mut self) -> Result<RecordSummary, String> {
        let cloud = toolpath_cloud(std::mem::take(&mut self.path).finish(), self.last_ns);
        self.rec.write(self.toolpath, self.last_ns, &cloud)?;
        self.rec.finish()
    }
}
