//! The ROS messages of a recording built from the controller's samples
//! and steps, in one place: the topics and frames they go on, headers,
//! joint states, the spindle command, the status, the tool's frame and
//! pose, and the tool path cloud. Positions come in mm (machine axes) and
//! go out in m, as ROS has them.

use crate::convert::time_from_ns;
use cnc_core::exec::Sample;
use cnc_msgs::{
    ControllerStatus, Float64, Header, JointState, Point, PointCloud2, PointField, Pose,
    PoseStamped, Quaternion, TFMessage, Transform, TransformStamped, Vector3,
};

/// Topics of an offline recording.
pub mod topics {
    pub const JOINT_SETPOINTS: &str = "/cnc/joint_setpoints";
    pub const JOINT_STATES: &str = "/sim/joint_states";
    pub const SPINDLE_COMMAND: &str = "/cnc/spindle_command";
    pub const STATUS: &str = "/cnc/status";
    pub const TF: &str = "/tf";
    pub const TOOL_POSE: &str = "/cnc/tool_pose";
    pub const SPINDLE_ENCODER: &str = "/sim/spindle_encoder";
    pub const TOOLPATH: &str = "/cnc/toolpath";
    pub const PROGRAM: &str = "/cnc/program";
    pub const MACHINE_FILE: &str = "/cnc/machine_file";
}

/// Frames of `/tf`, `/cnc/tool_pose` and `/cnc/toolpath`.
pub const WORLD_FRAME: &str = "world";
pub const TOOL_FRAME: &str = "tool";

/// Records `/tf` and `/cnc/tool_pose` every this many samples.
pub const POSE_EVERY: u64 = 10;

/// The most points of the `/cnc/toolpath` cloud.
pub const TOOLPATH_MAX_POINTS: u64 = 100_000;

/// A header stamped `ns` (since the Unix epoch) in `frame`.
pub fn header(ns: u64, frame: &str) -> Header {
    Header {
        stamp: time_from_ns(ns),
        frame_id: frame.to_string(),
    }
}

/// mm to m, value by value.
fn metres(v: &[f64]) -> Vec<f64> {
    v.iter().map(|p| p / 1000.0).collect()
}

/// A joint state stamped `ns`: `names`, positions in mm (written in m),
/// velocities as given (m/s; empty: none).
pub fn joint_state(
    ns: u64,
    names: &[String],
    position_mm: &[f64],
    velocity: Vec<f64>,
) -> JointState {
    JointState {
        header: header(ns, ""),
        name: names.to_vec(),
        position: metres(position_mm),
        velocity,
        effort: Vec::new(),
    }
}

/// Velocities (m/s) as finite differences of positions `now` and `prev`
/// (mm) `dt` s apart; zeros when there is no previous position.
pub fn joint_velocities(now: &[f64], prev: &[f64], dt: f64) -> Vec<f64> {
    if prev.len() == now.len() {
        now.iter()
            .zip(prev)
            .map(|(a, p)| (a - p) / 1000.0 / dt)
            .collect()
    } else {
        vec![0.0; now.len()]
    }
}

/// `/cnc/spindle_command` of a speed in rpm: rad/s.
pub fn spindle_command(rpm: f64) -> Float64 {
    Float64 {
        data: rpm * std::f64::consts::TAU / 60.0,
    }
}

/// `/cnc/status` of job 1 at sample `s` stamped `ns`: running, or idle at
/// the last sample; `progress` 0 to 1.
pub fn sample_status(ns: u64, s: &Sample, progress: f64) -> ControllerStatus {
    ControllerStatus {
        header: header(ns, ""),
        state: if s.last {
            ControllerStatus::STATE_IDLE
        } else {
            ControllerStatus::STATE_RUNNING
        },
        job_id: 1,
        source_line: s.src.line,
        block_number: s.src.block_no.map_or(-1, |b| b as i64),
        active_g_codes: Vec::new(),
        active_tool: s.tool as i32,
        spindle_speed_command: s.spindle_rpm,
        feed_override: 1.0,
        progress,
        last_error: String::new(),
    }
}

/// The tool position (m) of a sample: its commanded X, Y, Z.
pub fn tool_position(s: &Sample) -> [f64; 3] {
    [s.pos[0] / 1000.0, s.pos[1] / 1000.0, s.pos[2] / 1000.0]
}

/// `/tf`: `world` → `tool` at `[x, y, z]` (m).
pub fn tool_tf(ns: u64, [x, y, z]: [f64; 3]) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: header(ns, WORLD_FRAME),
            child_frame_id: TOOL_FRAME.to_string(),
            transform: Transform {
                translation: Vector3 { x, y, z },
                rotation: Quaternion::IDENTITY,
            },
        }],
    }
}

/// `/cnc/tool_pose` at `[x, y, z]` (m) in `world`.
pub fn tool_pose(ns: u64, [x, y, z]: [f64; 3]) -> PoseStamped {
    PoseStamped {
        header: header(ns, WORLD_FRAME),
        pose: Pose {
            position: Point { x, y, z },
            orientation: Quaternion::IDENTITY,
        },
    }
}

/// Appends one x, y, z float32 point (m) to a tool path cloud's data.
pub fn push_point(path: &mut Vec<u8>, p: [f64; 3]) {
    for v in p {
        path.extend_from_slice(&(v as f32).to_le_bytes());
    }
}

/// The `/cnc/toolpath` cloud of the points pushed by [`push_point`].
pub fn toolpath_cloud(data: Vec<u8>, ns: u64) -> PointCloud2 {
    let n = (data.len() / 12) as u32;
    let field = |name: &str, offset: u32| PointField {
        name: name.to_string(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    PointCloud2 {
        header: header(ns, WORLD_FRAME),
        height: 1,
        width: n,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        is_bigendian: false,
        point_step: 12,
        row_step: 12 * n,
        data,
        is_dense: true,
    }
}
