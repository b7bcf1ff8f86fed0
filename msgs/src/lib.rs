//! Rust types of the ROS 2 interfaces the controller speaks: `cnc_msgs`
//! (the `.msg`/`.srv`/`.action` files beside this crate) and the standard types it
//! uses. Each type is declared once, with its ROS field types, by
//! [`ros_message!`]; a test parses the interface files and fails if the two
//! drift apart. Field order is the CDR wire order.

pub mod options;
pub mod params;
pub mod params_file;
pub mod ros;
pub mod ros_args;
pub mod rosout;

use serde::{Deserialize, Serialize};

/// A ROS message type with its interface description.
pub trait RosType {
    /// `package/msg/Name` (or `package/srv/Name_Request`)
    const ROS_NAME: &'static str;
    /// (field name, ROS type) in wire order
    const FIELDS: &'static [(&'static str, &'static str)];
}

macro_rules! ros_message {
    ($(#[$meta:meta])* $name:ident = $ros:literal { $($(#[$fm:meta])* $field:ident : $ty:ty = $rt:literal),* $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
        pub struct $name { $($(#[$fm])* pub $field: $ty),* }
        impl RosType for $name {
            const ROS_NAME: &'static str = $ros;
            const FIELDS: &'static [(&'static str, &'static str)] = &[$((stringify!($field), $rt)),*];
        }
        impl ros2_client::Message for $name {}
    };
}

ros_message!(
    /// `builtin_interfaces/msg/Time`
    #[derive(Copy, Eq)]
    Time = "builtin_interfaces/msg/Time" { sec: i32 = "int32", nanosec: u32 = "uint32" }
);

impl Time {
    /// From seconds (non-negative).
    pub fn from_secs_f64(t: f64) -> Time {
        let t = t.max(0.0);
        let sec = t.floor();
        let mut nanosec = ((t - sec) * 1e9).round() as u32;
        let mut sec = sec as i64;
        if nanosec >= 1_000_000_000 {
            nanosec -= 1_000_000_000;
            sec += 1;
        }
        Time {
            sec: sec.min(i32::MAX as i64) as i32,
            nanosec,
        }
    }
    pub fn as_secs_f64(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }
}

ros_message!(
    /// `std_msgs/msg/Header`
    Header = "std_msgs/msg/Header" { stamp: Time = "builtin_interfaces/Time", frame_id: String = "string" }
);

ros_message!(
    /// `sensor_msgs/msg/JointState`
    JointState = "sensor_msgs/msg/JointState" {
        header: Header = "std_msgs/Header",
        name: Vec<String> = "string[]",
        position: Vec<f64> = "float64[]",
        velocity: Vec<f64> = "float64[]",
        effort: Vec<f64> = "float64[]",
    }
);

ros_message!(
    /// `std_msgs/msg/Float64`
    Float64 = "std_msgs/msg/Float64" { data: f64 = "float64" }
);

ros_message!(
    /// `std_srvs/srv/Trigger` request (an empty message carries one dummy byte)
    TriggerRequest = "std_srvs/srv/Trigger_Request" { structure_needs_at_least_one_member: u8 = "uint8" }
);
ros_message!(
    /// `std_srvs/srv/Trigger` response
    TriggerResponse = "std_srvs/srv/Trigger_Response" { success: bool = "bool", message: String = "string" }
);
ros_message!(
    /// `std_srvs/srv/SetBool` request
    SetBoolRequest = "std_srvs/srv/SetBool_Request" { data: bool = "bool" }
);
ros_message!(
    /// `std_srvs/srv/SetBool` response
    SetBoolResponse = "std_srvs/srv/SetBool_Response" { success: bool = "bool", message: String = "string" }
);

ros_message!(
    /// `cnc_msgs/srv/RunProgram` request
    RunProgramRequest = "cnc_msgs/srv/RunProgram_Request" {
        program: String = "string",
        program_path: String = "string",
        dialect: String = "string",
        dry_run: bool = "bool",
        record: bool = "bool",
    }
);
ros_message!(
    /// `cnc_msgs/srv/RunProgram` response
    RunProgramResponse = "cnc_msgs/srv/RunProgram_Response" {
        accepted: bool = "bool",
        message: String = "string",
        job_id: u32 = "uint32",
        estimated_duration: f64 = "float64",
        recording: String = "string",
    }
);

ros_message!(
    /// `cnc_msgs/srv/SetDelay` request
    SetDelayRequest = "cnc_msgs/srv/SetDelay_Request" { delay_ms: f64 = "float64" }
);
ros_message!(
    /// `cnc_msgs/srv/SetDelay` response
    SetDelayResponse = "cnc_msgs/srv/SetDelay_Response" {
        success: bool = "bool",
        message: String = "string",
    }
);

ros_message!(
    /// `cnc_msgs/msg/SpindleEncoder`: an incremental encoder with an index channel
    SpindleEncoder = "cnc_msgs/msg/SpindleEncoder" {
        stamp: Time = "builtin_interfaces/Time",
        count: i64 = "int64",
        counts_per_rev: u32 = "uint32",
        index_count: i64 = "int64",
        count_at_index: i64 = "int64",
        velocity: f64 = "float64",
    }
);

ros_message!(
    /// `cnc_msgs/msg/ControllerStatus`
    ControllerStatus = "cnc_msgs/msg/ControllerStatus" {
        header: Header = "std_msgs/Header",
        state: u8 = "uint8",
        job_id: u32 = "uint32",
        source_line: u32 = "uint32",
        block_number: i64 = "int64",
        active_g_codes: Vec<String> = "string[]",
        active_tool: i32 = "int32",
        spindle_speed_command: f64 = "float64",
        feed_override: f64 = "float64",
        progress: f64 = "float64",
        last_error: String = "string",
    }
);

impl ControllerStatus {
    pub const STATE_IDLE: u8 = 0;
    pub const STATE_RUNNING: u8 = 1;
    pub const STATE_HOLD: u8 = 2;
    pub const STATE_ERROR: u8 = 3;
    /// (name, value) of the constants, as in the .msg file
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("STATE_IDLE", 0),
        ("STATE_RUNNING", 1),
        ("STATE_HOLD", 2),
        ("STATE_ERROR", 3),
    ];
}

/// `cnc_msgs/action/ExecuteProgram` goal: `RunProgram`'s request, field
/// for field (the same wire; `tests/drift.rs` holds the two files to it).
pub type ExecuteProgramGoal = RunProgramRequest;

ros_message!(
    /// `cnc_msgs/action/ExecuteProgram` result
    ExecuteProgramResult = "cnc_msgs/action/ExecuteProgram_Result" {
        state: u8 = "uint8",
        message: String = "string",
        job_id: u32 = "uint32",
        cycle_time: f64 = "float64",
        estimated_duration: f64 = "float64",
        recording: String = "string",
        joint_names: Vec<String> = "string[]",
        position: Vec<f64> = "float64[]",
    }
);
ros_message!(
    /// `cnc_msgs/action/ExecuteProgram` feedback
    ExecuteProgramFeedback = "cnc_msgs/action/ExecuteProgram_Feedback" {
        job_id: u32 = "uint32",
        source_line: u32 = "uint32",
        block_number: i64 = "int64",
        progress: f64 = "float64",
        joint_names: Vec<String> = "string[]",
        position: Vec<f64> = "float64[]",
        path_speed: f64 = "float64",
        state: u8 = "uint8",
    }
);

/// The interface files of the package, embedded (also what recordings
/// store as schema text).
pub mod definitions {
    pub const RUN_PROGRAM_SRV: &str = include_str!("../srv/RunProgram.srv");
    pub const SET_DELAY_SRV: &str = include_str!("../srv/SetDelay.srv");
    pub const SPINDLE_ENCODER_MSG: &str = include_str!("../msg/SpindleEncoder.msg");
    pub const CONTROLLER_STATUS_MSG: &str = include_str!("../msg/ControllerStatus.msg");
    pub const EXECUTE_PROGRAM_ACTION: &str = include_str!("../action/ExecuteProgram.action");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_conversion() {
        assert_eq!(
            Time::from_secs_f64(1.5),
            Time {
                sec: 1,
                nanosec: 500_000_000
            }
        );
        assert_eq!(
            Time::from_secs_f64(2.999_999_999_9),
            Time { sec: 3, nanosec: 0 }
        );
        assert_eq!(Time::from_secs_f64(-1.0), Time { sec: 0, nanosec: 0 });
        assert!(
            (Time {
                sec: 3,
                nanosec: 250_000_000
            }
            .as_secs_f64()
                - 3.25)
                .abs()
                < 1e-12
        );
    }
}

// ---------------------------------------------------------------------------
// Standard types of recordings (MCAP, `ros2 bag`, Foxglove, Rerun): texts in
// `definitions_std`, complete schema texts in `schema`.

pub mod definitions_std;
pub mod schema;

ros_message!(
    /// `std_msgs/msg/String` (named `StringMsg` so that it does not shadow `String`)
    StringMsg = "std_msgs/msg/String" { data: String = "string" }
);

ros_message!(
    /// `geometry_msgs/msg/Vector3`
    #[derive(Copy)]
    Vector3 = "geometry_msgs/msg/Vector3" { x: f64 = "float64", y: f64 = "float64", z: f64 = "float64" }
);

ros_message!(
    /// `geometry_msgs/msg/Quaternion`. The .msg default is the identity
    /// (w = 1); `Default` here gives all zeros: use [`Quaternion::IDENTITY`].
    #[derive(Copy)]
    Quaternion = "geometry_msgs/msg/Quaternion" {
        x: f64 = "float64",
        y: f64 = "float64",
        z: f64 = "float64",
        w: f64 = "float64",
    }
);

impl Quaternion {
    /// No rotation (the .msg file's default value).
    pub const IDENTITY: Quaternion = Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

ros_message!(
    /// `geometry_msgs/msg/Transform`
    #[derive(Copy)]
    Transform = "geometry_msgs/msg/Transform" { translation: Vector3 = "Vector3", rotation: Quaternion = "Quaternion" }
);

ros_message!(
    /// `geometry_msgs/msg/TransformStamped`: `child_frame_id` in `header.frame_id`
    TransformStamped = "geometry_msgs/msg/TransformStamped" {
        header: Header = "std_msgs/Header",
        child_frame_id: String = "string",
        transform: Transform = "Transform",
    }
);

ros_message!(
    /// `tf2_msgs/msg/TFMessage` (the `/tf` and `/tf_static` topics)
    TFMessage = "tf2_msgs/msg/TFMessage" { transforms: Vec<TransformStamped> = "geometry_msgs/TransformStamped[]" }
);

ros_message!(
    /// `geometry_msgs/msg/Point`
    #[derive(Copy)]
    Point = "geometry_msgs/msg/Point" { x: f64 = "float64", y: f64 = "float64", z: f64 = "float64" }
);

ros_message!(
    /// `geometry_msgs/msg/Pose`
    #[derive(Copy)]
    Pose = "geometry_msgs/msg/Pose" { position: Point = "Point", orientation: Quaternion = "Quaternion" }
);

ros_message!(
    /// `geometry_msgs/msg/PoseStamped`
    PoseStamped = "geometry_msgs/msg/PoseStamped" { header: Header = "std_msgs/Header", pose: Pose = "Pose" }
);

ros_message!(
    /// `sensor_msgs/msg/PointField`: one channel of a [`PointCloud2`] point
    PointField = "sensor_msgs/msg/PointField" {
        name: String = "string",
        offset: u32 = "uint32",
        datatype: u8 = "uint8",
        count: u32 = "uint32",
    }
);

impl PointField {
    pub const INT8: u8 = 1;
    pub const UINT8: u8 = 2;
    pub const INT16: u8 = 3;
    pub const UINT16: u8 = 4;
    pub const INT32: u8 = 5;
    pub const UINT32: u8 = 6;
    pub const FLOAT32: u8 = 7;
    pub const FLOAT64: u8 = 8;
    /// (name, value) of the constants, as in the .msg file
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("INT8", 1),
        ("UINT8", 2),
        ("INT16", 3),
        ("UINT16", 4),
        ("INT32", 5),
        ("UINT32", 6),
        ("FLOAT32", 7),
        ("FLOAT64", 8),
    ];
}

ros_message!(
    /// `sensor_msgs/msg/PointCloud2`: points as a binary blob laid out by `fields`
    PointCloud2 = "sensor_msgs/msg/PointCloud2" {
        header: Header = "std_msgs/Header",
        height: u32 = "uint32",
        width: u32 = "uint32",
        fields: Vec<PointField> = "PointField[]",
        is_bigendian: bool = "bool",
        point_step: u32 = "uint32",
        row_step: u32 = "uint32",
        data: Vec<u8> = "uint8[]",
        is_dense: bool = "bool",
    }
);

ros_message!(
    /// `rcl_interfaces/msg/Log`: a line on `/rosout` (see [`rosout`])
    Log = "rcl_interfaces/msg/Log" {
        stamp: Time = "builtin_interfaces/Time",
        level: u8 = "uint8",
        name: String = "string",
        msg: String = "string",
        file: String = "string",
        function: String = "string",
        line: u32 = "uint32",
    }
);

impl Log {
    pub const DEBUG: u8 = 10;
    pub const INFO: u8 = 20;
    pub const WARN: u8 = 30;
    pub const ERROR: u8 = 40;
    pub const FATAL: u8 = 50;
    /// (name, value) of the constants, as in the .msg file
    pub const CONSTANTS: &'static [(&'static str, u8)] = &[
        ("DEBUG", 10),
        ("INFO", 20),
        ("WARN", 30),
        ("ERROR", 40),
        ("FATAL", 50),
    ];
}

ros_message!(
    /// `diagnostic_msgs/msg/KeyValue`
    KeyValue = "diagnostic_msgs/msg/KeyValue" { key: String = "string", value: String = "string" }
);

impl KeyValue {
    /// `key` = `value` (as text).
    pub fn new(key: &str, value: impl ToString) -> KeyValue {
        KeyValue {
            key: key.to_string(),
            value: value.to_string(),
        }
    }
}

/// A number as diagnostics show it: at most `digits` decimals, no
/// trailing zeros (`12.5`, `1000`, `0.8`).
pub fn short_num(v: f64, digits: usize) -> String {
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

ros_message!(
    /// `diagnostic_msgs/msg/DiagnosticStatus`: one component's level, message and values
    DiagnosticStatus = "diagnostic_msgs/msg/DiagnosticStatus" {
        level: u8 = "byte",
        name: String = "string",
        message: String = "string",
        hardware_id: String = "string",
        values: Vec<KeyValue> = "KeyValue[]",
    }
);

impl DiagnosticStatus {
    pub const OK: u8 = 0;
    pub const WARN: u8 = 1;
    pub const ERROR: u8 = 2;
    pub const STALE: u8 = 3;
    /// (name, value) of the constants, as in the .msg file
    pub const CONSTANTS: &'static [(&'static str, u8)] =
        &[("OK", 0), ("WARN", 1), ("ERROR", 2), ("STALE", 3)];
}

ros_message!(
    /// `diagnostic_msgs/msg/DiagnosticArray` (the `/diagnostics` topic)
    DiagnosticArray = "diagnostic_msgs/msg/DiagnosticArray" {
        header: Header = "std_msgs/Header",
        status: Vec<DiagnosticStatus> = "DiagnosticStatus[]",
    }
);
