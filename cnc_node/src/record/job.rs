//! The live job recorder of the node: [`JobRecorder`].

use super::writer::{ChannelId, RecordSummary, Recorder, RecordingInfo, LIVE_CHUNK_SPAN_NS};
use crate::convert::{
    push_point, stamp_ns, tool_pose, tool_tf, toolpath_cloud, topics, POSE_EVERY,
    TOOLPATH_MAX_POINTS,
};
use cnc_core::Machine;
use cnc_msgs::{ControllerStatus, Float64, JointState, PointCloud2, PoseStamped, TFMessage};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// A job recorded live by the node: the setpoints, spindle command and
/// status as the node publishes them, and the simulator's joint states
/// and encoder as the node receives them, stamped with their header times.
/// The tool path (`/tf`, `/cnc/tool_pose` every 10th setpoint,
/// `/cnc/toolpath` at the end) is derived from the setpoints, so Rerun
/// shows the job in 3D as it shows offline recordings. The toolpath cloud
/// covers the whole job however long it runs ([`LivePath`]: every setpoint
/// up to [`TOOLPATH_MAX_POINTS`], then every 2nd, 4th, ... and the last).
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

/// The tool path of a live job of unknown length, thinned as it grows:
/// setpoint k is kept when k is a multiple of the stride (1 at first); when
/// [`TOOLPATH_MAX_POINTS`] − 1 points are kept, every other one is dropped
/// and the stride doubles, so the cloud always spans the whole job with
/// evenly spaced samples (a 1 kHz job: every setpoint up to 100 s, every
/// 2nd up to 200 s, every 4th up to 400 s, ...), and the last setpoint
/// ends it ([`finish`](Self::finish)): at most [`TOOLPATH_MAX_POINTS`].
#[derive(Debug, Default)]
pub struct LivePath {
    /// x, y, z float32 per point (the cloud's data)
    data: Vec<u8>,
    /// log2 of the stride
    shift: u32,
    /// the last point seen, if it was not kept
    last: Option<[f64; 3]>,
}

impl LivePath {
    /// Setpoint number `k` (from 0) at `p` (m).
    pub fn push(&mut self, k: u64, p: [f64; 3]) {
        if k & ((1u64 << self.shift) - 1) != 0 {
            self.last = Some(p);
            return;
        }
        if self.len() as u64 >= TOOLPATH_MAX_POINTS - 1 {
            // keep points 0, 2, 4, ...: the multiples of the doubled stride
            let n = self.len();
            for (w, i) in (0..n).step_by(2).enumerate() {
                self.data.copy_within(i * 12..i * 12 + 12, w * 12);
            }
            self.data.truncate(n.div_ceil(2) * 12);
            self.shift += 1;
            if k & ((1u64 << self.shift) - 1) != 0 {
                self.last = Some(p);
                return;
            }
        }
        push_point(&mut self.data, p);
        self.last = None;
    }

    /// points kept so far
    pub fn len(&self) -> usize {
        self.data.len() / 12
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// setpoints between two kept points
    pub fn stride(&self) -> u64 {
        1 << self.shift
    }

    /// The cloud's data: the kept points and the last setpoint.
    pub fn finish(mut self) -> Vec<u8> {
        if let Some(p) = self.last.take() {
            push_point(&mut self.data, p);
        }
        self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(data: &[u8]) -> Vec<f32> {
        data.chunks(12)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn a_long_live_path_is_thinned_evenly_and_keeps_its_end() {
        // 250.5 s at 1 kHz: x = k / 1000 (m)
        let n = 250_500u64;
        let mut path = LivePath::default();
        for k in 0..n {
            path.push(k, [k as f64 / 1000.0, 0.0, 0.0]);
            assert!((path.len() as u64) < TOOLPATH_MAX_POINTS);
        }
        // 100 s, 200 s: the stride doubled twice
        assert_eq!(path.stride(), 4);
        let xs = points(&path.finish());
        assert!(xs.len() as u64 <= TOOLPATH_MAX_POINTS);
        assert_eq!(xs.len() as u64, (n - 1) / 4 + 1 + 1);
        // the whole job: from the start, every 4th setpoint, and the last
        assert_eq!(xs[0], 0.0);
        assert!(xs
            .windows(2)
            .take(xs.len() - 2)
            .all(|w| (w[1] - w[0] - 0.004).abs() < 1e-4));
        assert_eq!(*xs.last().unwrap(), ((n - 1) as f64 / 1000.0) as f32);
    }

    #[test]
    fn a_short_live_path_keeps_every_setpoint() {
        let mut path = LivePath::default();
        for k in 0..1000 {
            path.push(k, [0.0, k as f64, 0.0]);
        }
        assert_eq!(path.stride(), 1);
        assert_eq!(path.finish().len(), 1000 * 12);
    }
}
