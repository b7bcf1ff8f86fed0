//! What rosbag2 stores about a bag: the offered QoS of a topic as YAML
//! (channel metadata `offered_qos_profiles`) and the `serialized_metadata`
//! of its `BagMetadata` (the `rosbag2` metadata record).

use std::fmt::Write as _;

/// Message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "cdr";
/// ROS 2 distribution written into the metadata.
pub const ROS_DISTRO: &str = "kilted";
/// rosbag2 `BagMetadata` version written.
pub const BAG_METADATA_VERSION: u32 = 9;

/// The offered QoS of a topic, as rosbag2 stores it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Qos {
    /// keep-last depth
    pub depth: u32,
    /// reliable, else best effort
    pub reliable: bool,
    /// transient local ("latched"), else volatile
    pub transient_local: bool,
}

impl Qos {
    /// reliable, volatile, keep last 10 (rclcpp's default)
    pub const DEFAULT: Qos = Qos {
        depth: 10,
        reliable: true,
        transient_local: false,
    };
    /// reliable, transient local, keep last 1: a late subscriber gets the
    /// last message
    pub const LATCHED: Qos = Qos {
        depth: 1,
        reliable: true,
        transient_local: true,
    };
}

/// RMW_DURATION_INFINITE as rosbag2 writes it (what publishers offer for
/// deadline, lifespan and lease duration unless set).
const INFINITE: (u64, u64) = (9_223_372_036, 854_775_807);

/// One QoS profile as an item of a YAML block sequence (yaml-cpp's layout),
/// each line prefixed by `indent` spaces.
fn push_qos(out: &mut String, q: &Qos, indent: usize) {
    let p = " ".repeat(indent);
    let dur = |out: &mut String, key: &str| {
        let _ = write!(
            out,
            "{p}  {key}:\n{p}    sec: {}\n{p}    nsec: {}\n",
            INFINITE.0, INFINITE.1
        );
    };
    let _ = write!(
        out,
        "{p}- history: keep_last\n{p}  depth: {}\n{p}  reliability: {}\n{p}  durability: {}\n",
        q.depth,
        if q.reliable {
            "reliable"
        } else {
            "best_effort"
        },
        if q.transient_local {
            "transient_local"
        } else {
            "volatile"
        },
    );
    dur(out, "deadline");
    dur(out, "lifespan");
    let _ = writeln!(out, "{p}  liveliness: automatic");
    dur(out, "liveliness_lease_duration");
    let _ = writeln!(out, "{p}  avoid_ros_namespace_conventions: false");
}

/// The channel metadata `offered_qos_profiles`: rosbag2's
/// `serialize_rclcpp_qos_vector` (version 9) of one profile.
pub fn qos_yaml(q: &Qos) -> String {
    let mut s = String::new();
    push_qos(&mut s, q, 0);
    s.pop(); // YAML::Dump ends without a newline
    s
}

/// A YAML plain scalar, or a double-quoted one when plain would not read
/// back as the same string.
fn yaml_scalar(s: &str) -> String {
    let plain = !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"/_-.+".contains(&b))
        && !s.starts_with(['-', '.', '+'])
        && !matches!(s, "~" | "null" | "true" | "false" | "yes" | "no")
        && s.parse::<f64>().is_err();
    if plain {
        s.to_string()
    } else {
        let mut q = String::from("\"");
        for c in s.chars() {
            match c {
                '"' => q.push_str("\\\""),
                '\\' => q.push_str("\\\\"),
                c if (c as u32) < 0x20 => {
                    let _ = write!(q, "\\x{:02x}", c as u32);
                }
                c => q.push(c),
            }
        }
        q.push('"');
        q
    }
}

/// One topic of rosbag2's metadata.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BagTopic {
    pub name: String,
    /// `pkg/msg/Type`
    pub type_name: String,
    /// the channel's `offered_qos_profiles` ([`qos_yaml`])
    pub qos_yaml: String,
    pub count: u64,
}

/// rosbag2's `serialized_metadata` (`YAML::Dump` of its `BagMetadata`,
/// version [`BAG_METADATA_VERSION`]) of a single-file bag `file_name`
/// whose messages span `start_ns..=end_ns`.
pub fn bag_metadata_yaml(
    topics: &[BagTopic],
    start_ns: u64,
    end_ns: u64,
    file_name: &str,
) -> String {
    let start = start_ns;
    let duration = end_ns.saturating_sub(start);
    let total: u64 = topics.iter().map(|t| t.count).sum();
    let mut s = String::new();
    let _ = write!(
        s,
        "version: {BAG_METADATA_VERSION}\nstorage_identifier: mcap\nduration:\n  nanoseconds: {duration}\nstarting_time:\n  nanoseconds_since_epoch: {start}\nmessage_count: {total}\n"
    );
    if topics.is_empty() {
        s.push_str("topics_with_message_count: []\n");
    } else {
        s.push_str("topics_with_message_count:\n");
    }
    for t in topics {
        let _ = write!(
            s,
            "  - topic_metadata:\n      name: {}\n      type: {}\n      serialization_format: {MESSAGE_ENCODING}\n      offered_qos_profiles:\n",
            yaml_scalar(&t.name),
            yaml_scalar(&t.type_name)
        );
        for line in t.qos_yaml.lines() {
            let _ = writeln!(s, "        {line}");
        }
        let _ = write!(
            s,
            "      type_description_hash: \"\"\n    message_count: {}\n",
            t.count
        );
    }
    let f = yaml_scalar(file_name);
    let _ = write!(
        s,
        "compression_format: \"\"\ncompression_mode: \"\"\nrelative_file_paths:\n  - {f}\nfiles:\n  - path: {f}\n    starting_time:\n      nanoseconds_since_epoch: {start}\n    duration:\n      nanoseconds: {duration}\n    message_count: {total}\ncustom_data: ~\nros_distro: {ROS_DISTRO}"
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qos_yaml_has_rosbag2_shape() {
        let y = qos_yaml(&Qos::DEFAULT);
        assert!(y.starts_with(
            "- history: keep_last\n  depth: 10\n  reliability: reliable\n  durability: volatile\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"
        ));
        assert!(y.ends_with("  avoid_ros_namespace_conventions: false"));
        assert!(qos_yaml(&Qos::LATCHED).contains("durability: transient_local"));
    }

    #[test]
    fn yaml_scalars() {
        assert_eq!(yaml_scalar("/cnc/status"), "/cnc/status");
        assert_eq!(yaml_scalar("a b.mcap"), "\"a b.mcap\"");
        assert_eq!(yaml_scalar(""), "\"\"");
        assert_eq!(yaml_scalar("123"), "\"123\"");
        assert_eq!(yaml_scalar("x.mcap"), "x.mcap");
    }
}
