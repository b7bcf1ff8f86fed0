//! MCAP recordings in the ROS 2 profile, written the way rosbag2's MCAP
//! storage plugin (`ros2 bag record -s mcap`) writes them, so that
//! `ros2 bag play`/`ros2 bag info`, Foxglove and Rerun open them unchanged.
//!
//! What a file holds:
//! - Header: profile `ros2`, library [`LIBRARY`].
//! - Metadata `cnc` (first, before any message): program_name, dialect,
//!   machine_name, rate_hz, controller_version; in the node's recordings
//!   also setpoint_delay_ms (the drives' delay G33 leads by; offline runs
//!   have none).
//! - One Schema per message type: name `pkg/msg/Type`, encoding `ros2msg`,
//!   data the complete definition as rosbag2 concatenates it
//!   ([`cnc_msgs::schema`]).
//! - One Channel per topic: message encoding `cdr`, metadata
//!   `offered_qos_profiles` (rosbag2's YAML, [`qos_yaml`]) and
//!   `topic_type_hash` (empty: not computed).
//! - Messages: CDR little endian behind the encapsulation header
//!   `00 01 00 00`; log time = publish time = the stamp, ns since the Unix
//!   epoch; a sequence number per channel counting from 1.
//! - At the first message: the program and the machine file as
//!   Attachments (`program.nc`, `machine.toml`, text/plain) and as one
//!   `std_msgs/msg/String` message each on `/cnc/program` and
//!   `/cnc/machine_file` (transient local, depth 1: latched for
//!   `ros2 bag play`).
//! - At [`Recorder::finish`]: Metadata `rosbag2` with `serialized_metadata`
//!   (rosbag2's `BagMetadata`, version 9, as its `update_metadata` writes it:
//!   the YAML map itself, no `rosbag2_bagfile_information:` root, which
//!   rosbag2's reader would not accept) and `ROS_DISTRO`; then the summary.
//!
//! Chunks are zstd-compressed, about [`CHUNK_SIZE`] each before
//! compression. Each chunk is written to the OS as soon as it is closed
//! (its header is patched in place, then the file buffer is flushed), so
//! a killed process loses at most the open chunk; `cnc bag recover`
//! ([`crate::recover`]) turns what was written into a complete file. Live
//! recordings ([`JobRecorder`], `cnc bag record`) also close a chunk once
//! it spans [`LIVE_CHUNK_SPAN_NS`] of log time, so at low data rates a
//! kill loses about a second, not minutes; offline recordings are chunked
//! by size alone. Compression is single-threaded, so equal inputs give
//! byte-identical files on every machine.
//!
//! The parts: `writer` ([`Recorder`]: the MCAP file), `cdr` (the codec),
//! `rosbag2` (its metadata and QoS YAML), `sim` ([`SimRecorder`]: the
//! recording of an offline run), `job` ([`JobRecorder`]: the node's
//! live recording of a job) and `path` (the tool path growing over the
//! recording, [`GrowingPath`], which both write). The ROS messages they record, their topics,
//! frames and stamps are built in [`crate::convert`] (re-exported here:
//! [`topics`], [`time_from_ns`], [`stamp_ns`], ...).
//!
//! ```no_run
//! use cnc_node::record::{Recorder, RecordingInfo};
//! let mut rec = Recorder::create("run.mcap".as_ref(), RecordingInfo::default())?;
//! let ch = rec.channel::<cnc_msgs::Float64>("/cnc/spindle_command")?;
//! rec.write(ch, 1_700_000_000_000_000_000, &cnc_msgs::Float64 { data: 1.0 })?;
//! let summary = rec.finish()?;
//! # Ok::<(), String>(())
//! ```
mod cdr;
mod job;
mod path;
mod rosbag2;
mod sim;
mod writer;

pub use crate::convert::{
    stamp_ns, time_from_ns, topics, POSE_EVERY, TOOLPATH_MAX_POINTS, TOOL_FRAME, WORLD_FRAME,
};
pub use cdr::{from_cdr, to_cdr, to_cdr_into, CDR_LE_HEADER};
pub use job::JobRecorder;
pub use path::{thin, GrowingPath, LivePath, GROWING_EVERY_NS, GROWING_MAX_POINTS, GROWING_STEPS};
pub use rosbag2::{
    bag_metadata_yaml, qos_yaml, BagTopic, Qos, BAG_METADATA_VERSION, MESSAGE_ENCODING, ROS_DISTRO,
};
pub use sim::{
    record_run, record_run_with, record_simulation, record_simulation_as, SimRecorder, EPOCH_NS,
};
pub use writer::{
    machine_toml, write_options, ChannelId, RecordSummary, Recorder, RecordingInfo, CHUNK_SIZE,
    LIBRARY, LIVE_CHUNK_SPAN_NS, PROFILE,
};
