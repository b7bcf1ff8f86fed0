//! Where the controller's samples, ticks and status become ROS messages,
//! in one place (and stamps go back to ns). The controller works in mm and
//! rpm; the messages carry m and rad/s, as ROS has them.
//!
//! - Topics ([`topics`]) and frames ([`WORLD_FRAME`], [`TOOL_FRAME`]) of
//!   recordings, how often the tool's pose is recorded ([`POSE_EVERY`])
//!   and the most points of the tool path ([`TOOLPATH_MAX_POINTS`]).
//! - Stamps: [`time_from_ns`] and back [`stamp_ns`] (ns since the Unix
//!   epoch, unsigned, as recordings have them), [`time_ns`] (signed, the
//!   controller's clock), and the [`header`] of every message.
//! - The node's messages of a control cycle: [`joint_setpoints`] of a
//!   [`Tick`], [`spindle_command`] (rad/s), [`status`] of a [`Status`];
//!   the machine model's frames on `/tf` and `/tf_static`
//!   ([`transforms`], of `urdf::Model`'s joints).
//! - The messages a recording derives from samples and setpoints:
//!   [`joint_state`] (with [`joint_velocities`]), [`sample_status`], the
//!   tool's frame and pose ([`tool_position`], [`tool_tf`], [`tool_pose`])
//!   and the tool path cloud ([`push_point`], [`toolpath_cloud`]).
//!
//! `record` builds its messages here; this module does not use `record`.

use crate::controller::{Status, Tick};
use cnc_core::exec::Sample;
use cnc_msgs::{
    ControllerStatus, Float64, Header, JointState, Point, PointCloud2, PointField, Pose,
    PoseStamped, Quaternion, TFMessage, Time, Transform, TransformStamped, Vector3,
};

/// Topics of a recording: the node's and the simulator's in their default
/// namespaces (`/cnc`, `/sim`); an offline recording has them all.
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

/// A stamp in nanoseconds of the controller's clock (signed: a stamp
/// before the epoch stays before it).
pub fn time_ns(t: &Time) -> i64 {
    i64::from(t.sec) * 1_000_000_000 + i64::from(t.nanosec)
}

/// A stamp from ns since the Unix epoch (seconds past `i32::MAX` stay
/// at `i32::MAX`).
pub fn time_from_ns(ns: u64) -> Time {
    Time {
        sec: (ns / 1_000_000_000).min(i32::MAX as u64) as i32,
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

/// ns since the Unix epoch of a stamp (unsigned: a stamp before the
/// epoch counts its seconds as 0, unlike [`time_ns`]).
pub fn stamp_ns(t: &Time) -> u64 {
    (t.sec.max(0) as u64) * 1_000_000_000 + t.nanosec as u64
}

/// A header stamped `stamp` in `frame` (`""`: no frame, as the joint
/// states and the status have).
pub fn header(stamp: Time, frame: &str) -> Header {
    Header {
        stamp,
        frame_id: frame.to_string(),
    }
}

/// mm to m, value by value.
fn metres(v: &[f64]) -> Vec<f64> {
    v.iter().map(|p| p / 1000.0).collect()
}

/// The status topic's message of `s`, stamped `stamp`.
pub fn status(s: &Status, stamp: Time) -> ControllerStatus {
    ControllerStatus {
        header: header(stamp, ""),
        state: s.state as u8,
        job_id: s.job_id,
        source_line: s.source_line,
        block_number: s.block_number,
        active_g_codes: s.active_g_codes.clone(),
        active_tool: s.active_tool,
        spindle_speed_command: s.spindle_rpm,
        feed_override: s.feed_override,
        progress: s.progress,
        last_error: s.last_error.clone(),
    }
}

/// A cycle's setpoints, m, named `names` (the joints', in joint order),
/// stamped `stamp`; no velocities or efforts.
pub fn joint_setpoints(tick: &Tick, names: &[String], stamp: Time) -> JointState {
    let n = tick.n.min(tick.positions.len());
    JointState {
        header: header(stamp, ""),
        name: names.to_vec(),
        position: metres(&tick.positions[..n]),
        velocity: Vec::new(),
        effort: Vec::new(),
    }
}

/// `/cnc/spindle_command` of a speed of `rpm` (signed): rad/s. The node
/// publishes it and both recorders record it.
pub fn spindle_command(rpm: f64) -> Float64 {
    Float64 {
        data: rpm_to_rad_s(rpm),
    }
}

/// rpm to rad/s.
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * std::f64::consts::TAU / 60.0
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
        header: header(time_from_ns(ns), ""),
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

/// `/cnc/status` of job 1 at sample `s` stamped `ns`: running, or idle at
/// the last sample; `progress` 0 to 1.
pub fn sample_status(ns: u64, s: &Sample, progress: f64) -> ControllerStatus {
    ControllerStatus {
        header: header(time_from_ns(ns), ""),
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

/// `/tf`: `world` → `tool` at `[x, y, z]` (m), stamped `ns`.
pub fn tool_tf(ns: u64, [x, y, z]: [f64; 3]) -> TFMessage {
    TFMessage {
        transforms: vec![TransformStamped {
            header: header(time_from_ns(ns), WORLD_FRAME),
            child_frame_id: TOOL_FRAME.to_string(),
            transform: Transform {
                translation: Vector3 { x, y, z },
                rotation: Quaternion::IDENTITY,
            },
        }],
    }
}

/// `/tf` (or `/tf_static`) of frames given as (parent, child,
/// translation m, rotation quaternion x, y, z, w), all stamped `stamp`:
/// the machine model's joints (`urdf::Model::moving`, `fixed`).
pub fn transforms<'a>(
    stamp: Time,
    frames: impl IntoIterator<Item = (&'a str, &'a str, [f64; 3], [f64; 4])>,
) -> TFMessage {
    TFMessage {
        transforms: frames
            .into_iter()
            .map(
                |(parent, child, [x, y, z], [qx, qy, qz, qw])| TransformStamped {
                    header: header(stamp, parent),
                    child_frame_id: child.to_string(),
                    transform: Transform {
                        translation: Vector3 { x, y, z },
                        rotation: Quaternion {
                            x: qx,
                            y: qy,
                            z: qz,
                            w: qw,
                        },
                    },
                },
            )
            .collect(),
    }
}

/// `/cnc/tool_pose` at `[x, y, z]` (m) in `world`, stamped `ns`.
pub fn tool_pose(ns: u64, [x, y, z]: [f64; 3]) -> PoseStamped {
    PoseStamped {
        header: header(time_from_ns(ns), WORLD_FRAME),
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

/// The `/cnc/toolpath` cloud of the points pushed by [`push_point`],
/// stamped `ns`.
pub fn toolpath_cloud(data: Vec<u8>, ns: u64) -> PointCloud2 {
    let n = (data.len() / 12) as u32;
    let field = |name: &str, offset: u32| PointField {
        name: name.to_string(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    PointCloud2 {
        header: header(time_from_ns(ns), WORLD_FRAME),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controller::State;

    const STAMP: Time = Time {
        sec: 1_795_000_000,
        nanosec: 250_000_000,
    };

    #[test]
    fn setpoints_are_in_metres_named_and_stamped() {
        let t = Tick {
            positions: [123.5, -40.25, 7.0],
            n: 2,
            spindle_rpm: 0.0,
            state: State::Running,
            changed: false,
        };
        let names = vec!["x".to_string(), "z".to_string()];
        let js = joint_setpoints(&t, &names, STAMP);
        assert_eq!(js.position, [0.1235, -0.04025]);
        assert_eq!(js.name, names);
        assert_eq!(js.header.stamp, STAMP);
        assert_eq!(js.header.frame_id, "");
        assert!(js.velocity.is_empty() && js.effort.is_empty());
        // three joints
        let t = Tick { n: 3, ..t };
        let js = joint_setpoints(&t, &["x".into(), "y".into(), "z".into()], STAMP);
        assert_eq!(js.position, [0.1235, -0.04025, 0.007]);
        // a count past the array never reads past it
        let t = Tick { n: 9, ..t };
        assert_eq!(joint_setpoints(&t, &[], STAMP).position.len(), 3);
    }

    #[test]
    fn the_spindle_command_is_in_rad_per_s() {
        // 60 rpm is one turn a second
        let r = spindle_command(60.0).data;
        assert!((r - std::f64::consts::TAU).abs() < 1e-12, "{r}");
        assert_eq!(rpm_to_rad_s(0.0), 0.0);
        let r = spindle_command(-3000.0).data;
        assert!((r + 314.159_265_358_979).abs() < 1e-9, "{r}");
        let r = rpm_to_rad_s(12_000.0);
        assert!((r - 1_256.637_061_435_917).abs() < 1e-9, "{r}");
    }

    #[test]
    fn the_status_message_carries_every_field() {
        let s = Status {
            state: State::Hold,
            job_id: 7,
            source_line: 12,
            block_number: 120,
            active_g_codes: vec!["G01".into(), "G17".into(), "G90".into(), "G94".into()],
            active_tool: 3,
            spindle_rpm: 2500.0,
            feed_override: 0.5,
            progress: 0.25,
            last_error: "none".into(),
        };
        let m = status(&s, STAMP);
        assert_eq!(m.header.stamp, STAMP);
        assert_eq!(m.header.frame_id, "");
        assert_eq!(m.state, 2);
        assert_eq!(m.state, ControllerStatus::STATE_HOLD);
        assert_eq!((m.job_id, m.source_line, m.block_number), (7, 12, 120));
        assert_eq!(m.active_g_codes, ["G01", "G17", "G90", "G94"]);
        assert_eq!(m.active_tool, 3);
        // the status keeps rpm, as the message's field says
        assert_eq!(m.spindle_speed_command, 2500.0);
        assert_eq!((m.feed_override, m.progress), (0.5, 0.25));
        assert_eq!(m.last_error, "none");
        for (st, v) in [
            (State::Idle, ControllerStatus::STATE_IDLE),
            (State::Running, ControllerStatus::STATE_RUNNING),
            (State::Error, ControllerStatus::STATE_ERROR),
        ] {
            assert_eq!(
                status(
                    &Status {
                        state: st,
                        ..s.clone()
                    },
                    STAMP
                )
                .state,
                v
            );
        }
    }

    #[test]
    fn stamps_in_nanoseconds() {
        assert_eq!(time_ns(&STAMP), 1_795_000_000_250_000_000);
        let before = Time {
            sec: -1,
            nanosec: 500_000_000,
        };
        assert_eq!(time_ns(&before), -500_000_000);
    }
}
