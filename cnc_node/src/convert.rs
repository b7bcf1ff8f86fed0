//! The controller's output as the node's ROS messages: setpoints in metres
//! (`sensor_msgs/JointState`), the spindle command in rad/s
//! (`std_msgs/Float64`), the status (`cnc_msgs/ControllerStatus`) and
//! stamps in the controller's clock. The controller works in mm and rpm.

use crate::controller::{Status, Tick};
use cnc_msgs::{ControllerStatus, Float64, Header, JointState, Time};

/// The status topic's message of `s`, stamped `stamp`.
pub fn status(s: &Status, stamp: Time) -> ControllerStatus {
    ControllerStatus {
        header: header(stamp),
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
        header: header(stamp),
        name: names.to_vec(),
        position: tick.positions[..n].iter().map(|p| p / 1000.0).collect(),
        velocity: Vec::new(),
        effort: Vec::new(),
    }
}

/// The spindle command of `rpm` (signed), in rad/s.
pub fn spindle_command(rpm: f64) -> Float64 {
    Float64 {
        data: rpm_to_rad_s(rpm),
    }
}

/// rpm to rad/s.
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * std::f64::consts::TAU / 60.0
}

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

fn header(stamp: Time) -> Header {
    Header {
        stamp,
        frame_id: String::new(),
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
