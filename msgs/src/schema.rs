//! Complete message definitions, the schema text of recordings.
//!
//! rosbag2 (`ros2 bag record`, MCAP storage) stores one schema per message
//! type: encoding `ros2msg`, name `pkg/msg/Type`, and as data the type's
//! `.msg` file followed by the file of every type it depends on, each after
//! a line of 80 `=` and a line `MSG: pkg/Type`. [`full_text`] builds that
//! text the way rosbag2's `LocalMessageDefinitionSource::get_full_text`
//! does, so a recording made here carries the same bytes as one made by
//! `ros2 bag record -s mcap` on a ROS 2 Kilted machine:
//!
//! - the `.msg` texts are the installed files, comments included
//!   ([`crate::definitions_std`], [`crate::definitions`]);
//! - dependencies are the field types found by rosbag2's regular expression
//!   `(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+` minus the primitive
//!   types, a type without a package taking the package of the file
//!   ([`dependencies`]);
//! - each file's dependencies are visited in sorted order (a `std::set`),
//!   depth first, each type once per schema, and every section is
//!   preceded by `"\n"` + 80 `=` + `"\nMSG: "` + the name as written in the
//!   field (`std_msgs/Header`, not `std_msgs/msg/Header`) + `"\n"`.

use crate::{definitions, definitions_std as std_defs, RosType};
use std::collections::{BTreeSet, HashSet};

/// The line before every dependent definition (80 `=`).
pub const SEPARATOR: &str =
    "================================================================================";

/// Schema encoding of [`full_text`] (MCAP well-known schema encoding).
pub const ENCODING: &str = "ros2msg";

/// The primitive field types of `.msg` files (as rosbag2 lists them).
pub const PRIMITIVE_TYPES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string",
];

/// rosbag2's recursion limit (`ROSBAG2_CPP_LOCAL_MESSAGE_DEFINITION_SOURCE_MAX_RECURSION_DEPTH`).
const MAX_DEPTH: u32 = 50;

/// Every message type whose `.msg` text this crate holds: (`pkg/msg/Type`, text).
pub const MESSAGE_DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/msg/Time", std_defs::TIME_MSG),
    ("std_msgs/msg/Header", std_defs::HEADER_MSG),
    ("std_msgs/msg/Float64", std_defs::FLOAT64_MSG),
    ("std_msgs/msg/String", std_defs::STRING_MSG),
    ("sensor_msgs/msg/JointState", std_defs::JOINT_STATE_MSG),
    ("sensor_msgs/msg/PointCloud2", std_defs::POINT_CLOUD2_MSG),
    ("sensor_msgs/msg/PointField", std_defs::POINT_FIELD_MSG),
    ("geometry_msgs/msg/Vector3", std_defs::VECTOR3_MSG),
    ("geometry_msgs/msg/Quaternion", std_defs::QUATERNION_MSG),
    ("geometry_msgs/msg/Transform", std_defs::TRANSFORM_MSG),
    (
        "geometry_msgs/msg/TransformStamped",
        std_defs::TRANSFORM_STAMPED_MSG,
    ),
    ("geometry_msgs/msg/Point", std_defs::POINT_MSG),
    ("geometry_msgs/msg/Pose", std_defs::POSE_MSG),
    ("geometry_msgs/msg/PoseStamped", std_defs::POSE_STAMPED_MSG),
    ("tf2_msgs/msg/TFMessage", std_defs::TF_MESSAGE_MSG),
    ("rcl_interfaces/msg/Log", std_defs::LOG_MSG),
    (
        "diagnostic_msgs/msg/DiagnosticArray",
        std_defs::DIAGNOSTIC_ARRAY_MSG,
    ),
    (
        "diagnostic_msgs/msg/DiagnosticStatus",
        std_defs::DIAGNOSTIC_STATUS_MSG,
    ),
    ("diagnostic_msgs/msg/KeyValue", std_defs::KEY_VALUE_MSG),
    (
        "cnc_msgs/msg/ControllerStatus",
        definitions::CONTROLLER_STATUS_MSG,
    ),
    (
        "cnc_msgs/msg/SpindleEncoder",
        definitions::SPINDLE_ENCODER_MSG,
    ),
];

/// `pkg/Type` or `pkg/msg/Type` → (`pkg`, `Type`), as rosbag2's
/// `^([a-zA-Z0-9_]+)/(?:msg/|srv/)?([a-zA-Z0-9_]+)$`; `None` for a service
/// or anything else.
pub fn split_name(name: &str) -> Option<(&str, &str)> {
    let word = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
    let mut parts = name.split('/');
    let (pkg, mid, ty) = (parts.next()?, parts.next()?, parts.next());
    if parts.next().is_some() {
        return None;
    }
    match ty {
        None if word(pkg) && word(mid) => Some((pkg, mid)),
        Some(ty) if mid == "msg" && word(pkg) && word(ty) => Some((pkg, ty)),
        _ => None,
    }
}

/// The `.msg` text of a message type (`pkg/msg/Type` or `pkg/Type`).
pub fn msg_text(name: &str) -> Option<&'static str> {
    let (pkg, ty) = split_name(name)?;
    MESSAGE_DEFINITIONS.iter().find_map(|(n, text)| {
        let (p, t) = split_name(n)?;
        (p == pkg && t == ty).then_some(*text)
    })
}

fn is_space(b: u8) -> bool {
    // ECMAScript \s on ASCII: space, \t, \n, \v, \f, \r
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

fn is_type_char(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_' || b == b'/'
}

/// Tries rosbag2's field-type pattern after its anchor (`^` or `\n`), at
/// byte `q`: `\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+`. Returns the type and
/// where the match ends.
fn match_field_type(b: &[u8], mut q: usize) -> Option<(&[u8], usize)> {
    while q < b.len() && is_space(b[q]) {
        q += 1;
    }
    let start = q;
    while q < b.len() && is_type_char(b[q]) {
        q += 1;
    }
    if q == start {
        return None;
    }
    let ty = &b[start..q];
    let spaces = |mut r: usize| {
        let from = r;
        while r < b.len() && is_space(b[r]) {
            r += 1;
        }
        (r > from).then_some(r)
    };
    if b.get(q) == Some(&b'[') {
        if let Some(close) = b[q..].iter().position(|&c| c == b']') {
            if let Some(end) = spaces(q + close + 1) {
                return Some((ty, end));
            }
        }
    }
    spaces(q).map(|end| (ty, end))
}

/// The non-primitive field types of a `.msg` text, as rosbag2 finds them
/// (regular-expression search over the whole text; names without a package
/// get `package`), sorted.
pub fn dependencies(text: &str, package: &str) -> BTreeSet<String> {
    let b = text.as_bytes();
    let mut deps = BTreeSet::new();
    // the next match is searched from where the last one ended
    let mut s = 0;
    while s < b.len() {
        // `^` matches only at the very start of the text
        let found = if s == 0 { match_field_type(b, 0) } else { None }.or_else(|| {
            if b[s] == b'\n' {
                match_field_type(b, s + 1)
            } else {
                None
            }
        });
        match found {
            Some((ty, end)) => {
                let ty = String::from_utf8_lossy(ty).into_owned();
                if !PRIMITIVE_TYPES.contains(&ty.as_str()) {
                    if ty.contains('/') {
                        deps.insert(ty);
                    } else {
                        deps.insert(format!("{package}/{ty}"));
                    }
                }
                s = end;
            }
            None => s += 1,
        }
    }
    deps
}

/// The complete definition of a message type in rosbag2's `ros2msg` form
/// (see the module documentation). Fails for a type (or a dependency)
/// whose `.msg` text this crate does not hold, and for services.
pub fn full_text(root: &str) -> Result<String, String> {
    fn append(
        name: &str,
        depth: u32,
        seen: &mut HashSet<String>,
        root: &str,
    ) -> Result<String, String> {
        if depth == 0 {
            return Err(format!(
                "reached max recursion depth resolving definition of {root}"
            ));
        }
        let (pkg, _) = split_name(name).ok_or_else(|| format!("{name}: not a message type"))?;
        let text = msg_text(name).ok_or_else(|| {
            format!("{name}: no .msg definition (needed by the schema of {root})")
        })?;
        let mut out = String::from(text);
        for dep in dependencies(text, pkg) {
            if seen.insert(dep.clone()) {
                out.push('\n');
                out.push_str(SEPARATOR);
                out.push_str("\nMSG: ");
                out.push_str(&dep);
                out.push('\n');
                out.push_str(&append(&dep, depth - 1, seen, root)?);
            }
        }
        Ok(out)
    }
    if root.contains("/srv/") {
        return Err(format!("{root}: services have no message schema"));
    }
    append(root, MAX_DEPTH, &mut HashSet::new(), root)
}

/// The schema text of a Rust message type: [`full_text`] of its ROS name.
pub fn schema_text<T: RosType>() -> Result<String, String> {
    full_text(T::ROS_NAME)
}

/// A message type with a schema: implemented for every type whose
/// definition (and dependencies) this crate holds.
pub trait RosSchema: RosType {
    /// `pkg/msg/Type`, the schema name in recordings
    fn schema_name() -> &'static str {
        Self::ROS_NAME
    }
    /// the complete `ros2msg` definition
    fn schema() -> String {
        // every implementor is covered by a test, so this cannot fail
        full_text(Self::ROS_NAME).unwrap_or_default()
    }
}

macro_rules! with_schema {
    ($($t:ident),* $(,)?) => { $(impl RosSchema for crate::$t {})* };
}

with_schema!(
    Time,
    Header,
    JointState,
    Float64,
    StringMsg,
    Vector3,
    Quaternion,
    Transform,
    TransformStamped,
    TFMessage,
    Point,
    Pose,
    PoseStamped,
    PointField,
    PointCloud2,
    Log,
    KeyValue,
    DiagnosticStatus,
    DiagnosticArray,
    ControllerStatus,
    SpindleEncoder,
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::JointState;

    #[test]
    fn names() {
        assert_eq!(
            split_name("std_msgs/msg/Header"),
            Some(("std_msgs", "Header"))
        );
        assert_eq!(split_name("std_msgs/Header"), Some(("std_msgs", "Header")));
        assert_eq!(split_name("std_srvs/srv/Trigger"), None);
        assert_eq!(split_name("Header"), None);
        assert_eq!(split_name("a/b/c/d"), None);
        assert!(msg_text("geometry_msgs/Vector3").is_some());
        assert!(msg_text("geometry_msgs/msg/Wrench").is_none());
    }

    #[test]
    fn dependencies_as_rosbag2_finds_them() {
        let d = dependencies(std_defs::POINT_CLOUD2_MSG, "sensor_msgs");
        let d: Vec<&str> = d.iter().map(|s| s.as_str()).collect();
        assert_eq!(d, ["sensor_msgs/PointField", "std_msgs/Header"]);
        let d = dependencies("Point position\n  # c\nfoo/Bar[3] b\nint32 INT=1\n", "p");
        let d: Vec<&str> = d.iter().map(|s| s.as_str()).collect();
        assert_eq!(d, ["foo/Bar", "p/Point"]);
        // the pattern needs whitespace after the type: none at the very end
        assert!(dependencies("Foo", "p").is_empty());
        assert!(dependencies(std_defs::TIME_MSG, "builtin_interfaces").is_empty());
    }

    #[test]
    fn joint_state_full_text() {
        let sep = format!("\n{SEPARATOR}\n");
        let want = format!(
            "{}{sep}MSG: std_msgs/Header\n{}{sep}MSG: builtin_interfaces/Time\n{}",
            std_defs::JOINT_STATE_MSG,
            std_defs::HEADER_MSG,
            std_defs::TIME_MSG
        );
        assert_eq!(full_text("sensor_msgs/msg/JointState").unwrap(), want);
        assert_eq!(JointState::schema(), want);
    }

    #[test]
    fn tf_message_is_depth_first_and_sorted() {
        let t = full_text("tf2_msgs/msg/TFMessage").unwrap();
        let order: Vec<&str> = t.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
        assert_eq!(
            order,
            [
                "geometry_msgs/TransformStamped",
                "geometry_msgs/Transform",
                "geometry_msgs/Quaternion",
                "geometry_msgs/Vector3",
                "std_msgs/Header",
                "builtin_interfaces/Time",
            ]
        );
    }

    #[test]
    fn unknown_types_and_services_fail() {
        assert!(full_text("geometry_msgs/msg/Wrench").is_err());
        assert!(full_text("cnc_msgs/srv/RunProgram").is_err());
    }
}
