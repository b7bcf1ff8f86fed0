//! The standard types against their `.msg` texts (as `drift.rs` does for
//! the package's own), and the complete schema texts of recordings.

use cnc_msgs::definitions_std as d;
use cnc_msgs::schema::{full_text, RosSchema, MESSAGE_DEFINITIONS, PRIMITIVE_TYPES, SEPARATOR};
use cnc_msgs::*;

mod common;
use common::{fields_of, parse, Pairs};

fn check<T: RosType + RosSchema>(text: &str) {
    assert_eq!(parse(text).0, fields_of::<T>(), "{}", T::ROS_NAME);
    assert_eq!(schema::msg_text(T::ROS_NAME), Some(text), "{}", T::ROS_NAME);
    assert!(T::schema().starts_with(text), "{}", T::ROS_NAME);
}

#[test]
fn std_types_match_their_definitions() {
    check::<Time>(d::TIME_MSG);
    check::<Header>(d::HEADER_MSG);
    check::<Float64>(d::FLOAT64_MSG);
    check::<StringMsg>(d::STRING_MSG);
    check::<JointState>(d::JOINT_STATE_MSG);
    check::<Vector3>(d::VECTOR3_MSG);
    check::<Quaternion>(d::QUATERNION_MSG);
    check::<Transform>(d::TRANSFORM_MSG);
    check::<TransformStamped>(d::TRANSFORM_STAMPED_MSG);
    check::<Point>(d::POINT_MSG);
    check::<Pose>(d::POSE_MSG);
    check::<PoseStamped>(d::POSE_STAMPED_MSG);
    check::<TFMessage>(d::TF_MESSAGE_MSG);
    check::<PointField>(d::POINT_FIELD_MSG);
    check::<PointCloud2>(d::POINT_CLOUD2_MSG);
    check::<Log>(d::LOG_MSG);
    check::<KeyValue>(d::KEY_VALUE_MSG);
    check::<DiagnosticStatus>(d::DIAGNOSTIC_STATUS_MSG);
    check::<DiagnosticArray>(d::DIAGNOSTIC_ARRAY_MSG);
    check::<ControllerStatus>(definitions::CONTROLLER_STATUS_MSG);
    check::<SpindleEncoder>(definitions::SPINDLE_ENCODER_MSG);
    let want: Pairs = PointField::CONSTANTS
        .iter()
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect();
    assert_eq!(parse(d::POINT_FIELD_MSG).1, want);
    let pairs = |c: &[(&str, u8)]| -> Pairs {
        c.iter()
            .map(|(n, v)| (n.to_string(), v.to_string()))
            .collect()
    };
    assert_eq!(parse(d::LOG_MSG).1, pairs(Log::CONSTANTS));
    assert_eq!(
        parse(d::DIAGNOSTIC_STATUS_MSG).1,
        pairs(DiagnosticStatus::CONSTANTS)
    );
}

/// Splits a complete definition into (package-qualified name, text) sections.
fn sections(root: &str, full: &str) -> Vec<(String, String)> {
    let delim = format!("\n{SEPARATOR}\nMSG: ");
    let mut parts = full.split(delim.as_str());
    let (pkg, ty) = schema::split_name(root).unwrap();
    let mut out = vec![(format!("{pkg}/{ty}"), parts.next().unwrap().to_string())];
    for p in parts {
        let (name, text) = p.split_once('\n').expect("a name line");
        out.push((name.to_string(), text.to_string()));
    }
    out
}

#[test]
fn every_field_type_of_a_schema_has_its_own_section() {
    for (root, _) in MESSAGE_DEFINITIONS {
        let full = full_text(root).unwrap();
        let secs = sections(root, &full);
        let names: Vec<&str> = secs.iter().map(|(n, _)| n.as_str()).collect();
        for (i, n) in names.iter().enumerate() {
            assert!(!names[i + 1..].contains(n), "{root}: {n} twice");
        }
        for (name, text) in &secs {
            let pkg = name.split('/').next().unwrap();
            for (field, ty) in parse(text).0 {
                let base = ty.split('[').next().unwrap();
                let base = base.split("<=").next().unwrap();
                if PRIMITIVE_TYPES.contains(&base) {
                    continue;
                }
                let qualified = if base.contains('/') {
                    base.to_string()
                } else {
                    format!("{pkg}/{base}")
                };
                assert!(
                    names[1..].contains(&qualified.as_str()),
                    "{root}: field {field} of {name} has type {qualified} without a MSG: section"
                );
                assert_eq!(
                    secs.iter()
                        .find(|(n, _)| *n == qualified)
                        .map(|(_, t)| t.as_str()),
                    schema::msg_text(&qualified),
                    "{root}: section {qualified}"
                );
            }
        }
    }
}

#[test]
fn point_cloud2_schema_text() {
    let sep = format!("\n{SEPARATOR}\n");
    assert_eq!(
        PointCloud2::schema(),
        format!(
            "{}{sep}MSG: sensor_msgs/PointField\n{}{sep}MSG: std_msgs/Header\n{}{sep}MSG: builtin_interfaces/Time\n{}",
            d::POINT_CLOUD2_MSG,
            d::POINT_FIELD_MSG,
            d::HEADER_MSG,
            d::TIME_MSG
        )
    );
    let status = ControllerStatus::schema();
    assert!(status.contains("\nMSG: std_msgs/Header\n"));
    assert!(status.ends_with(d::TIME_MSG));
}

/// The test peer's tf2_msgs package (scripts/ros_peer/tf2_msgs: PyPI has
/// no tf2_msgs wheel) builds the message from the same text as
/// geometry2's, so its type and hash are upstream's.
#[test]
fn the_test_peers_tf_message_is_geometry2s() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scripts/ros_peer/tf2_msgs/msg/TFMessage.msg");
    let text = std::fs::read_to_string(path).unwrap();
    assert_eq!(text, d::TF_MESSAGE_MSG);
}
