//! MCAP recordings in the ROS 2 profile, written the way rosbag2's MCAP
//! storage plugin (`ros2 bag record -s mcap`) writes them, so that
//! `ros2 bag play`/`ros2 bag info`, Foxglove and Rerun open them unchanged.
//!
//! What a file holds:
//! - Header: profile `ros2`, library [`LIBRARY`].
//! - Metadata `cnc` (first, before any message): program_name, dialect,
//!   machine_name, rate_hz, controller_version.
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
//! ```no_run
//! use cnc_node::record::{Recorder, RecordingInfo};
//! let mut rec = Recorder::create("run.mcap".as_ref(), RecordingInfo::default())?;
//! let ch = rec.channel::<cnc_msgs::Float64>("/cnc/spindle_command")?;
//! rec.write(ch, 1_700_000_000_000_000_000, &cnc_msgs::Float64 { data: 1.0 })?;
//! let summary = rec.finish()?;
//! # Ok::<(), String>(())
//! ```

use crate::offline::{simulate_with, Step};
use byteorder::LittleEndian;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use cnc_msgs::schema::{RosSchema, ENCODING};
use cnc_msgs::{
    ControllerStatus, Float64, Header, JointState, Point, PointCloud2, PointField, Pose,
    PoseStamped, Quaternion, StringMsg, TFMessage, Time, Transform, TransformStamped, Vector3,
};
use serde::Serialize;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::marker::PhantomData;
use std::path::Path;

/// MCAP header profile.
pub const PROFILE: &str = "ros2";
/// MCAP header library string.
pub const LIBRARY: &str = concat!("cnc_node/", env!("CARGO_PKG_VERSION"), " mcap-rust/0.26");
/// Message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "cdr";
/// CDR little endian, plain (XCDR1) encapsulation, no options.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// ROS 2 distribution written into the metadata.
pub const ROS_DISTRO: &str = "kilted";
/// rosbag2 `BagMetadata` version written.
pub const BAG_METADATA_VERSION: u32 = 9;
/// Target chunk size before compression, bytes.
pub const CHUNK_SIZE: u64 = 1 << 20;
/// Live recordings close a chunk once its messages span this much log
/// time (1 s), so that a killed node loses at most about a second.
pub const LIVE_CHUNK_SPAN_NS: u64 = 1_000_000_000;

/// The MCAP writer options of every recording this crate writes (profile,
/// library, zstd, single-threaded compression); `chunk_size` None: the
/// caller closes chunks itself.
pub fn write_options(chunk_size: Option<u64>) -> mcap::WriteOptions {
    mcap::WriteOptions::new()
        .profile(PROFILE)
        .library(LIBRARY)
        .compression(Some(mcap::Compression::Zstd))
        .chunk_size(chunk_size)
        .compression_threads(0)
}

/// Bytes of a record's opcode and length prefix.
const RECORD_PREFIX: u64 = 1 + 8;
/// Bytes of a Message record before its data: prefix, channel id,
/// sequence, log time, publish time.
const MESSAGE_OVERHEAD: u64 = RECORD_PREFIX + 2 + 4 + 8 + 8;
/// Time of sample 0 in offline recordings: 1_700_000_000 s after the Unix
/// epoch, in ns (fixed, so that recordings are deterministic).
pub const EPOCH_NS: u64 = 1_700_000_000_000_000_000;

/// The job a recording is of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordingInfo {
    /// the program's file name (or another name for it)
    pub program_name: String,
    pub program_text: String,
    /// `cnc836` or `heidenhain`
    pub dialect: String,
    /// the machine file (TOML) the job ran with
    pub machine_toml: String,
    pub machine_name: String,
    /// interpolation rate, Hz
    pub rate_hz: f64,
}

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

/// `data` in CDR (little endian) behind the encapsulation header, appended
/// to `buf`.
pub fn to_cdr_into<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<(), String> {
    buf.extend_from_slice(&CDR_LE_HEADER);
    // alignment counts from the first byte after the header
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut *buf, msg)
        .map_err(|e| format!("CDR serialization: {e}"))
}

/// A message in CDR (little endian) with the encapsulation header.
pub fn to_cdr<T: Serialize>(msg: &T) -> Result<Vec<u8>, String> {
    let mut buf = Vec::with_capacity(64);
    to_cdr_into(&mut buf, msg)?;
    Ok(buf)
}

/// A message from CDR with the encapsulation header (little or big endian).
pub fn from_cdr<T: serde::de::DeserializeOwned>(data: &[u8]) -> Result<T, String> {
    let (head, body) = data
        .split_at_checked(4)
        .ok_or("CDR: shorter than the encapsulation header")?;
    let r = match head[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => return Err(format!("CDR: unsupported encapsulation {head:02x?}")),
    };
    r.map(|(v, _)| v).map_err(|e| format!("CDR: {e}"))
}

/// A stamp from ns since the Unix epoch.
pub fn time_from_ns(ns: u64) -> Time {
    Time {
        sec: (ns / 1_000_000_000).min(i32::MAX as u64) as i32,
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

/// A channel of a [`Recorder`] carrying messages of type `T`.
pub struct ChannelId<T> {
    index: usize,
    id: u16,
    _t: PhantomData<fn(&T)>,
}

impl<T> Clone for ChannelId<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for ChannelId<T> {}
impl<T> std::fmt::Debug for ChannelId<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ChannelId({})", self.id)
    }
}

impl<T> ChannelId<T> {
    /// the MCAP channel id
    pub fn id(&self) -> u16 {
        self.id
    }
}

struct Topic {
    name: String,
    type_name: &'static str,
    qos: Qos,
    channel: u16,
    count: u64,
    sequence: u32,
}

/// What is written at the first message (its time is the stamp).
struct Pending {
    program: String,
    machine: String,
    program_ch: ChannelId<StringMsg>,
    machine_ch: ChannelId<StringMsg>,
}

/// What a finished recording holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordSummary {
    /// (topic, messages) in the order the channels were added
    pub topics: Vec<(String, u64)>,
    pub messages: u64,
    /// size of the file, bytes
    pub bytes: u64,
    pub chunks: u32,
    /// first and last message time, ns since the Unix epoch (0 if none)
    pub start_ns: u64,
    pub end_ns: u64,
}

impl RecordSummary {
    /// messages on a topic (0 for an unknown one)
    pub fn count(&self, topic: &str) -> u64 {
        self.topics
            .iter()
            .find(|(t, _)| t == topic)
            .map_or(0, |(_, n)| *n)
    }
}

fn mcap_err(what: &str) -> impl Fn(mcap::McapError) -> String + '_ {
    move |e| format!("{what}: {e}")
}

/// Writes one MCAP recording. Every method returns I/O and encoding errors
/// instead of panicking. A recorder dropped without [`finish`](Self::finish)
/// still closes the file as a readable MCAP, without the `rosbag2` metadata.
pub struct Recorder<W: Write + Seek> {
    mcap: mcap::Writer<W>,
    file_name: String,
    topics: Vec<Topic>,
    pending: Option<Pending>,
    start_ns: Option<u64>,
    end_ns: u64,
    buf: Vec<u8>,
    /// schema names written so far
    schemas: Vec<&'static str>,
    /// uncompressed bytes of the open chunk (as the MCAP writer counts
    /// them), 0 when none is open
    chunk_bytes: u64,
    /// log time of the open chunk's first message
    chunk_start_ns: Option<u64>,
    /// close a chunk once its messages span this much log time
    max_chunk_span_ns: Option<u64>,
}

impl Recorder<BufWriter<File>> {
    /// Creates (truncates) the file `path`.
    pub fn create(path: &Path, info: RecordingInfo) -> Result<Self, String> {
        let f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        Recorder::new(BufWriter::with_capacity(1 << 16, f), &name, info)
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}

impl<W: Write + Seek> Recorder<W> {
    /// A recording into any seekable writer; `file_name` is what the
    /// rosbag2 metadata lists as the file.
    pub fn new(w: W, file_name: &str, info: RecordingInfo) -> Result<Self, String> {
        // chunks are closed here (see `put`), not by the writer, so that
        // each closed chunk is flushed at once and a time span can close one
        let mut mcap = write_options(None)
            .create(w)
            .map_err(mcap_err("writing the MCAP header"))?;
        let mut cnc = BTreeMap::new();
        cnc.insert("program_name".into(), info.program_name.clone());
        cnc.insert("dialect".into(), info.dialect.clone());
        cnc.insert("machine_name".into(), info.machine_name.clone());
        cnc.insert("rate_hz".into(), format!("{}", info.rate_hz));
        cnc.insert(
            "controller_version".into(),
            env!("CARGO_PKG_VERSION").to_string(),
        );
        mcap.write_metadata(&mcap::records::Metadata {
            name: "cnc".into(),
            metadata: cnc,
        })
        .map_err(mcap_err("writing metadata"))?;
        let mut rec = Recorder {
            mcap,
            file_name: file_name.to_string(),
            topics: Vec::new(),
            pending: None,
            start_ns: None,
            end_ns: 0,
            buf: Vec::with_capacity(256),
            schemas: Vec::new(),
            chunk_bytes: 0,
            chunk_start_ns: None,
            max_chunk_span_ns: None,
        };
        let program_ch = rec.channel_with_qos::<StringMsg>("/cnc/program", Qos::LATCHED)?;
        let machine_ch = rec.channel_with_qos::<StringMsg>("/cnc/machine_file", Qos::LATCHED)?;
        rec.pending = Some(Pending {
            program: info.program_text,
            machine: info.machine_toml,
            program_ch,
            machine_ch,
        });
        Ok(rec)
    }

    /// The channel of `topic` with the default QoS (reliable, volatile,
    /// keep last 10); the same channel again for a topic already added
    /// with the same type.
    pub fn channel<T: RosSchema + Serialize>(
        &mut self,
        topic: &str,
    ) -> Result<ChannelId<T>, String> {
        self.channel_with_qos(topic, Qos::DEFAULT)
    }

    /// The channel of `topic` with the given offered QoS.
    pub fn channel_with_qos<T: RosSchema + Serialize>(
        &mut self,
        topic: &str,
        qos: Qos,
    ) -> Result<ChannelId<T>, String> {
        let type_name = T::schema_name();
        if let Some((index, t)) = self
            .topics
            .iter()
            .enumerate()
            .find(|(_, t)| t.name == topic)
        {
            if t.type_name != type_name {
                return Err(format!(
                    "{topic}: already recorded as {}, not {type_name}",
                    t.type_name
                ));
            }
            return Ok(ChannelId {
                index,
                id: t.channel,
                _t: PhantomData,
            });
        }
        let text = cnc_msgs::schema::full_text(type_name)?;
        let schema = self
            .mcap
            .add_schema(type_name, ENCODING, text.as_bytes())
            .map_err(mcap_err(topic))?;
        if !self.schemas.contains(&type_name) {
            // a new schema record goes into the open chunk
            self.schemas.push(type_name);
            self.chunk_bytes +=
                RECORD_PREFIX + 2 + str_len(type_name) + str_len(ENCODING) + 4 + text.len() as u64;
        }
        let mut meta = BTreeMap::new();
        meta.insert("offered_qos_profiles".to_string(), qos_yaml(&qos));
        meta.insert("topic_type_hash".to_string(), String::new());
        let channel = self
            .mcap
            .add_channel(schema, topic, MESSAGE_ENCODING, &meta)
            .map_err(mcap_err(topic))?;
        self.chunk_bytes += RECORD_PREFIX
            + 2
            + 2
            + str_len(topic)
            + str_len(MESSAGE_ENCODING)
            + 4
            + meta
                .iter()
                .map(|(k, v)| str_len(k) + str_len(v))
                .sum::<u64>();
        self.topics.push(Topic {
            name: topic.to_string(),
            type_name,
            qos,
            channel,
            count: 0,
            sequence: 0,
        });
        Ok(ChannelId {
            index: self.topics.len() - 1,
            id: channel,
            _t: PhantomData,
        })
    }

    /// Writes one message stamped `time_ns` (ns since the Unix epoch; log
    /// and publish time).
    pub fn write<T: Serialize>(
        &mut self,
        ch: ChannelId<T>,
        time_ns: u64,
        msg: &T,
    ) -> Result<(), String> {
        if let Some(p) = self.pending.take() {
            self.write_job(&p, time_ns, true)?;
        }
        self.put(ch, time_ns, msg)
    }

    /// The program and the machine file as attachments and (`latched`) as
    /// messages.
    fn write_job(&mut self, p: &Pending, time_ns: u64, latched: bool) -> Result<(), String> {
        // an attachment closes the open chunk (the schemas and channels):
        // flush it, as `put` does with every chunk it closes
        self.close_chunk()?;
        for (name, text) in [("program.nc", &p.program), ("machine.toml", &p.machine)] {
            self.mcap
                .attach(&mcap::Attachment {
                    log_time: time_ns,
                    create_time: time_ns,
                    name: name.into(),
                    media_type: "text/plain".into(),
                    data: Cow::Borrowed(text.as_bytes()),
                })
                .map_err(mcap_err(name))?;
        }
        if latched {
            self.put(
                p.program_ch,
                time_ns,
                &StringMsg {
                    data: p.program.clone(),
                },
            )?;
            self.put(
                p.machine_ch,
                time_ns,
                &StringMsg {
                    data: p.machine.clone(),
                },
            )?;
        }
        Ok(())
    }

    fn put<T: Serialize>(&mut self, ch: ChannelId<T>, time_ns: u64, msg: &T) -> Result<(), String> {
        let t = match self.topics.get_mut(ch.index) {
            Some(t) if t.channel == ch.id => t,
            _ => return Err(format!("{ch:?}: not a channel of this recording")),
        };
        self.buf.clear();
        to_cdr_into(&mut self.buf, msg).map_err(|e| format!("{}: {e}", t.name))?;
        t.sequence = t.sequence.wrapping_add(1);
        t.count += 1;
        let header = mcap::records::MessageHeader {
            channel_id: t.channel,
            sequence: t.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        // the MCAP writer's rule (close the chunk before a message once it
        // holds more than CHUNK_SIZE), or the open chunk spans the time bound
        let span_over = match (self.chunk_start_ns, self.max_chunk_span_ns) {
            (Some(start), Some(span)) => time_ns.saturating_sub(start) >= span,
            _ => false,
        };
        if self.chunk_bytes > CHUNK_SIZE || span_over {
            let name = t.name.clone();
            self.close_chunk()
                .map_err(|e| format!("writing {name}: {e}"))?;
        }
        let t = &self.topics[ch.index];
        self.mcap
            .write_to_known_channel(&header, &self.buf)
            .map_err(|e| format!("writing {}: {e}", t.name))?;
        self.chunk_bytes += MESSAGE_OVERHEAD + self.buf.len() as u64;
        self.chunk_start_ns.get_or_insert(time_ns);
        self.start_ns = Some(self.start_ns.map_or(time_ns, |s| s.min(time_ns)));
        self.end_ns = self.end_ns.max(time_ns);
        Ok(())
    }

    /// Messages written so far on the channel.
    pub fn count<T>(&self, ch: ChannelId<T>) -> u64 {
        self.topics.get(ch.index).map_or(0, |t| t.count)
    }

    /// Closes a chunk once its messages span `span_ns` of log time (None:
    /// by size alone, the default). Live recordings use
    /// [`LIVE_CHUNK_SPAN_NS`].
    pub fn set_max_chunk_span(&mut self, span_ns: Option<u64>) {
        self.max_chunk_span_ns = span_ns;
    }

    /// Closes the open chunk when its first message is at least the chunk
    /// span older than `now_ns` (for a live recorder whose topics went
    /// quiet); nothing without a span or an open chunk.
    pub fn close_stale_chunk(&mut self, now_ns: u64) -> Result<(), String> {
        match (self.chunk_start_ns, self.max_chunk_span_ns) {
            (Some(start), Some(span)) if now_ns.saturating_sub(start) >= span => self.close_chunk(),
            _ => Ok(()),
        }
    }

    /// Closes the open chunk (if any) and flushes everything written to
    /// the OS: what a kill after this leaves behind is readable.
    pub fn close_chunk(&mut self) -> Result<(), String> {
        self.mcap
            .flush()
            .map_err(mcap_err("writing the MCAP file"))?;
        self.chunk_bytes = 0;
        self.chunk_start_ns = None;
        Ok(())
    }

    /// rosbag2's `serialized_metadata`: `YAML::Dump` of its `BagMetadata`.
    fn bag_metadata_yaml(&self) -> String {
        let topics: Vec<BagTopic> = self
            .topics
            .iter()
            .map(|t| BagTopic {
                name: t.name.clone(),
                type_name: t.type_name.to_string(),
                qos_yaml: qos_yaml(&t.qos),
                count: t.count,
            })
            .collect();
        bag_metadata_yaml(
            &topics,
            self.start_ns.unwrap_or(0),
            self.end_ns,
            &self.file_name,
        )
    }

    /// Writes the `rosbag2` metadata and the summary, flushes, and returns
    /// what the file holds.
    pub fn finish(self) -> Result<RecordSummary, String> {
        self.finish_into_inner().map(|(s, _)| s)
    }

    /// As [`finish`](Self::finish), handing back the writer.
    pub fn finish_into_inner(mut self) -> Result<(RecordSummary, W), String> {
        if let Some(p) = self.pending.take() {
            // no message at all: the job still goes in, as attachments
            self.write_job(&p, 0, false)?;
        }
        let mut meta = BTreeMap::new();
        meta.insert("serialized_metadata".to_string(), self.bag_metadata_yaml());
        meta.insert("ROS_DISTRO".to_string(), ROS_DISTRO.to_string());
        self.mcap
            .write_metadata(&mcap::records::Metadata {
                name: "rosbag2".into(),
                metadata: meta,
            })
            .map_err(mcap_err("writing metadata"))?;
        let summary = self
            .mcap
            .finish()
            .map_err(mcap_err("writing the summary"))?;
        let Recorder {
            mcap,
            topics,
            start_ns,
            end_ns,
            ..
        } = self;
        let mut w = mcap.into_inner();
        w.flush()
            .map_err(|e| format!("writing the MCAP file: {e}"))?;
        let bytes = w
            .stream_position()
            .map_err(|e| format!("writing the MCAP file: {e}"))?;
        let stats = summary.stats.unwrap_or_default();
        Ok((
            RecordSummary {
                messages: topics.iter().map(|t| t.count).sum(),
                topics: topics.into_iter().map(|t| (t.name, t.count)).collect(),
                bytes,
                chunks: stats.chunk_count,
                start_ns: start_ns.unwrap_or(0),
                end_ns,
            },
            w,
        ))
    }
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

/// Bytes of a string in an MCAP record (u32 length, then the bytes).
fn str_len(s: &str) -> u64 {
    4 + s.len() as u64
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

/// The machine file of a machine, as TOML (what recordings attach).
pub fn machine_toml(machine: &Machine) -> Result<String, String> {
    toml::to_string(machine).map_err(|e| format!("machine {}: {e}", machine.name))
}

/// The most points of the `/cnc/toolpath` cloud.
pub const TOOLPATH_MAX_POINTS: u64 = 100_000;

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

/// Runs `program_text` offline against the simulated machine (as `cnc
/// simulate` does) and records the run to `out`:
///
/// | topic | type | when |
/// |---|---|---|
/// | `/cnc/joint_setpoints` | sensor_msgs/JointState | every sample, m |
/// | `/sim/joint_states` | sensor_msgs/JointState | every sample, m and m/s (finite differences) |
/// | `/cnc/spindle_command` | std_msgs/Float64 | first sample and on change, rad/s |
/// | `/cnc/status` | cnc_msgs/ControllerStatus | 10 Hz, on a line change, last sample (idle) |
/// | `/tf` | tf2_msgs/TFMessage | `world` → `tool` every 10th and the last sample |
/// | `/cnc/tool_pose` | geometry_msgs/PoseStamped | every 10th and the last sample |
/// | `/cnc/toolpath` | sensor_msgs/PointCloud2 | once at the end: x, y, z float32, m |
/// | `/cnc/program`, `/cnc/machine_file` | std_msgs/String | once, at the first sample |
///
/// Sample k is stamped [`EPOCH_NS`] + k·dt, so equal inputs give
/// byte-identical files. The tool position is the commanded X, Y, Z in
/// metres (lathe: X is the radius, Y 0). The program must pass the check;
/// otherwise nothing is written and the errors are returned.
pub fn record_simulation(
    machine: &Machine,
    program_name: &str,
    program_text: &str,
    dialect: Dialect,
    out: &Path,
) -> Result<RecordSummary, String> {
    let report = check(StrSource::new(program_text), dialect, machine);
    if !report.ok() {
        return Err(format!(
            "{program_name}: {} error(s), nothing recorded:\n{}",
            report.error_count,
            report.message()
        ));
    }
    let info = RecordingInfo {
        program_name: program_name.to_string(),
        program_text: program_text.to_string(),
        dialect: dialect.id().to_string(),
        machine_toml: machine_toml(machine)?,
        machine_name: machine.name.clone(),
        rate_hz: machine.interpolation.rate_hz,
    };
    let rec = Recorder::create(out, info)?;
    record_run(rec, machine, program_text, dialect, report.ticks)
        .map_err(|e| format!("{}: {e}", out.display()))
}

/// The recording of one offline run; `ticks` is the check's sample count
/// (for the progress and the decimation of the tool path).
pub fn record_run<W: Write + Seek>(
    rec: Recorder<W>,
    machine: &Machine,
    program_text: &str,
    dialect: Dialect,
    ticks: u64,
) -> Result<RecordSummary, String> {
    record_run_with(rec, machine, program_text, dialect, ticks, |_| {})
}

/// [`record_run`] with `alter` applied to every interpolator sample (see
/// [`crate::offline::simulate_with`]).
pub fn record_run_with<W: Write + Seek>(
    rec: Recorder<W>,
    machine: &Machine,
    program_text: &str,
    dialect: Dialect,
    ticks: u64,
    alter: impl FnMut(&mut cnc_core::exec::Sample),
) -> Result<RecordSummary, String> {
    let mut r = SimRecorder::new(rec, machine, ticks)?;
    simulate_with(
        StrSource::new(program_text),
        dialect,
        machine,
        alter,
        |st| {
            if r.error.is_none() {
                if let Err(e) = r.step(st) {
                    r.error = Some(e);
                }
            }
        },
    );
    r.finish()
}

struct SimRecorder<W: Write + Seek> {
    rec: Recorder<W>,
    error: Option<String>,
    names: Vec<String>,
    setpoints: ChannelId<JointState>,
    joint_states: ChannelId<JointState>,
    spindle: ChannelId<Float64>,
    status: ChannelId<ControllerStatus>,
    tf: ChannelId<TFMessage>,
    tool_pose: ChannelId<PoseStamped>,
    toolpath: ChannelId<PointCloud2>,
    dt: f64,
    ticks: u64,
    status_every: u64,
    path_every: u64,
    prev_actual: Vec<f64>,
    last_spindle: Option<f64>,
    last_line: Option<u32>,
    path: Vec<u8>,
    last_ns: u64,
}

fn header(ns: u64, frame: &str) -> Header {
    Header {
        stamp: time_from_ns(ns),
        frame_id: frame.to_string(),
    }
}

impl<W: Write + Seek> SimRecorder<W> {
    fn new(mut rec: Recorder<W>, machine: &Machine, ticks: u64) -> Result<Self, String> {
        let rate = machine.interpolation.rate_hz;
        let points = ticks.saturating_add(1);
        // every path_every-th sample and the last one: at most TOOLPATH_MAX_POINTS
        let path_every = if points <= TOOLPATH_MAX_POINTS {
            1
        } else {
            points.div_ceil(TOOLPATH_MAX_POINTS - 1)
        };
        Ok(SimRecorder {
            setpoints: rec.channel(topics::JOINT_SETPOINTS)?,
            joint_states: rec.channel(topics::JOINT_STATES)?,
            spindle: rec.channel(topics::SPINDLE_COMMAND)?,
            status: rec.channel(topics::STATUS)?,
            tf: rec.channel(topics::TF)?,
            tool_pose: rec.channel(topics::TOOL_POSE)?,
            toolpath: rec.channel(topics::TOOLPATH)?,
            rec,
            error: None,
            names: machine.axes.iter().map(|a| a.name.clone()).collect(),
            dt: 1.0 / rate,
            ticks,
            status_every: ((rate / 10.0).round() as u64).max(1),
            path_every,
            prev_actual: Vec::new(),
            last_spindle: None,
            last_line: None,
            path: Vec::with_capacity(
                (points.div_ceil(path_every).min(TOOLPATH_MAX_POINTS) as usize + 1) * 12,
            ),
            last_ns: EPOCH_NS,
        })
    }

    fn step(&mut self, st: &Step) -> Result<(), String> {
        let s = st.sample;
        let ns = EPOCH_NS + (s.t * 1e9).round() as u64;
        self.last_ns = ns;
        let m = |v: &[f64]| v.iter().map(|p| p / 1000.0).collect::<Vec<f64>>();
        self.rec.write(
            self.setpoints,
            ns,
            &JointState {
                header: header(ns, ""),
                name: self.names.clone(),
                position: m(st.setpoints),
                velocity: Vec::new(),
                effort: Vec::new(),
            },
        )?;
        let velocity = if self.prev_actual.len() == st.actual.len() {
            st.actual
                .iter()
                .zip(&self.prev_actual)
                .map(|(a, p)| (a - p) / 1000.0 / self.dt)
                .collect()
        } else {
            vec![0.0; st.actual.len()]
        };
        self.prev_actual.clear();
        self.prev_actual.extend_from_slice(st.actual);
        self.rec.write(
            self.joint_states,
            ns,
            &JointState {
                header: header(ns, ""),
                name: self.names.clone(),
                position: m(st.actual),
                velocity,
                effort: Vec::new(),
            },
        )?;
        if self.last_spindle != Some(s.spindle_rpm) {
            self.last_spindle = Some(s.spindle_rpm);
            self.rec.write(
                self.spindle,
                ns,
                &Float64 {
                    data: s.spindle_rpm * std::f64::consts::TAU / 60.0,
                },
            )?;
        }
        if s.k.is_multiple_of(self.status_every) || self.last_line != Some(s.src.line) || s.last {
            self.last_line = Some(s.src.line);
            let progress = if s.last || self.ticks == 0 {
                1.0
            } else {
                (s.k as f64 / self.ticks as f64).min(1.0)
            };
            self.rec.write(
                self.status,
                ns,
                &ControllerStatus {
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
                },
            )?;
        }
        let (x, y, z) = (s.pos[0] / 1000.0, s.pos[1] / 1000.0, s.pos[2] / 1000.0);
        if s.k.is_multiple_of(POSE_EVERY) || s.last {
            write_tool(&mut self.rec, self.tf, self.tool_pose, ns, [x, y, z])?;
        }
        if s.k.is_multiple_of(self.path_every) || s.last {
            push_point(&mut self.path, [x, y, z]);
        }
        Ok(())
    }

    fn finish(mut self) -> Result<RecordSummary, String> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        let cloud = toolpath_cloud(std::mem::take(&mut self.path), self.last_ns);
        self.rec.write(self.toolpath, self.last_ns, &cloud)?;
        self.rec.finish()
    }
}

/// `/tf` (`world` → `tool`) and `/cnc/tool_pose` at `pos` (m).
fn write_tool<W: Write + Seek>(
    rec: &mut Recorder<W>,
    tf: ChannelId<TFMessage>,
    pose: ChannelId<PoseStamped>,
    ns: u64,
    [x, y, z]: [f64; 3],
) -> Result<(), String> {
    rec.write(
        tf,
        ns,
        &TFMessage {
            transforms: vec![TransformStamped {
                header: header(ns, WORLD_FRAME),
                child_frame_id: TOOL_FRAME.to_string(),
                transform: Transform {
                    translation: Vector3 { x, y, z },
                    rotation: Quaternion::IDENTITY,
                },
            }],
        },
    )?;
    rec.write(
        pose,
        ns,
        &PoseStamped {
            header: header(ns, WORLD_FRAME),
            pose: Pose {
                position: Point { x, y, z },
                orientation: Quaternion::IDENTITY,
            },
        },
    )
}

/// Appends one x, y, z float32 point (m) to a tool path cloud's data.
fn push_point(path: &mut Vec<u8>, p: [f64; 3]) {
    for v in p {
        path.extend_from_slice(&(v as f32).to_le_bytes());
    }
}

/// The `/cnc/toolpath` cloud of the points pushed by [`push_point`].
fn toolpath_cloud(data: Vec<u8>, ns: u64) -> PointCloud2 {
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

/// ns since the Unix epoch of a stamp.
pub fn stamp_ns(t: &Time) -> u64 {
    (t.sec.max(0) as u64) * 1_000_000_000 + t.nanosec as u64
}

/// A job recorded live by the node: the setpoints, spindle command and
/// status as the node publishes them, and the simulator's joint states
/// and encoder as the node receives them, stamped with their header times.
/// The tool path (`/tf`, `/cnc/tool_pose` every 10th setpoint,
/// `/cnc/toolpath` at the end) is derived from the setpoints, so Rerun
/// shows the job in 3D as it shows offline recordings.
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
    path: Vec<u8>,
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
            path: Vec::new(),
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
            p[i] = *v;
        }
        if self.k.is_multiple_of(POSE_EVERY) {
            write_tool(&mut self.rec, self.tf, self.tool_pose, ns, p)?;
        }
        if (self.path.len() as u64) < TOOLPATH_MAX_POINTS * 12 {
            push_point(&mut self.path, p);
        }
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
        let cloud = toolpath_cloud(std::mem::take(&mut self.path), self.last_ns);
        self.rec.write(self.toolpath, self.last_ns, &cloud)?;
        self.rec.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    #[test]
    fn joint_state_cdr_is_byte_exact() {
        let js = JointState {
            header: Header {
                stamp: Time {
                    sec: 1_700_000_000,
                    nanosec: 5,
                },
                frame_id: String::new(),
            },
            name: vec!["joint1".into(), "j2".into()],
            position: vec![0.25, -1.0],
            velocity: vec![],
            effort: vec![],
        };
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,                   // encapsulation: CDR_LE
            0x00, 0xf1, 0x53, 0x65,                   //  0 stamp.sec 1_700_000_000
            0x05, 0x00, 0x00, 0x00,                   //  4 stamp.nanosec
            0x01, 0x00, 0x00, 0x00, 0x00,             //  8 frame_id "" (length 1: the NUL)
            0x00, 0x00, 0x00,                         // 13 padding to 16
            0x02, 0x00, 0x00, 0x00,                   // 16 name: 2 strings
            0x07, 0x00, 0x00, 0x00,                   // 20 "joint1" length 7
            b'j', b'o', b'i', b'n', b't', b'1', 0x00, // 24
            0x00,                                     // 31 padding to 32
            0x03, 0x00, 0x00, 0x00,                   // 32 "j2" length 3
            b'j', b'2', 0x00,                         // 36
            0x00,                                     // 39 padding to 40
            0x02, 0x00, 0x00, 0x00,                   // 40 position: 2 doubles
            0x00, 0x00, 0x00, 0x00,                   // 44 padding to 48 (8-byte alignment
                                                      //    counts from the body, not the file)
            0, 0, 0, 0, 0, 0, 0xd0, 0x3f,             // 48 0.25
            0, 0, 0, 0, 0, 0, 0xf0, 0xbf,             // 56 -1.0
            0x00, 0x00, 0x00, 0x00,                   // 64 velocity: empty
            0x00, 0x00, 0x00, 0x00,                   // 68 effort: empty
        ];
        assert_eq!(to_cdr(&js).unwrap(), want);
        assert_eq!(from_cdr::<JointState>(&want).unwrap(), js);
    }

    #[test]
    fn bool_then_u32_is_aligned() {
        #[derive(Serialize)]
        struct S {
            a: bool,
            b: u32,
            c: u8,
            d: f64,
        }
        let got = to_cdr(&S {
            a: true,
            b: 7,
            c: 3,
            d: 2.0,
        })
        .unwrap();
        #[rustfmt::skip]
        let want = [
            0x00, 0x01, 0x00, 0x00,
            0x01, 0x00, 0x00, 0x00,  // 0 bool, padding to 4
            0x07, 0x00, 0x00, 0x00,  // 4 u32
            0x03, 0, 0, 0, 0, 0, 0, 0, // 8 u8, padding to 16
            0, 0, 0, 0, 0, 0, 0x00, 0x40, // 16 2.0
        ];
        assert_eq!(got, want);
        // the real case: PointCloud2's `bool is_bigendian` then `uint32 point_step`
        let pc = PointCloud2 {
            is_bigendian: false,
            point_step: 12,
            ..Default::default()
        };
        let b = to_cdr(&pc).unwrap();
        // header (8 + 4 + 1 → 16 with padding), height, width, fields count → 28,
        // bool at 28, point_step at 32
        assert_eq!(&b[4 + 28..4 + 36], &[0, 0, 0, 0, 12, 0, 0, 0]);
    }

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

    #[test]
    fn stamps() {
        assert_eq!(
            time_from_ns(EPOCH_NS + 1_500_000_123),
            Time {
                sec: 1_700_000_001,
                nanosec: 500_000_123
            }
        );
    }

    #[test]
    fn machine_toml_round_trips() {
        for m in [Machine::builtin_mill(), Machine::builtin_lathe()] {
            let t = machine_toml(&m).unwrap();
            assert_eq!(Machine::from_toml(&t).unwrap(), m);
        }
    }

    #[test]
    fn in_memory_recording_and_errors() {
        let mut rec = Recorder::new(
            Cursor::new(Vec::new()),
            "mem.mcap",
            RecordingInfo {
                program_name: "p.nc".into(),
                program_text: "G0 X1\n".into(),
                ..Default::default()
            },
        )
        .unwrap();
        let ch = rec.channel::<Float64>("/a").unwrap();
        assert_eq!(rec.channel::<Float64>("/a").unwrap().id(), ch.id());
        assert!(rec.channel::<StringMsg>("/a").is_err());
        rec.write(ch, 5, &Float64 { data: 1.0 }).unwrap();
        rec.write(ch, 7, &Float64 { data: 2.0 }).unwrap();
        let (s, w) = rec.finish_into_inner().unwrap();
        assert_eq!(s.count("/a"), 2);
        assert_eq!(s.count("/cnc/program"), 1);
        assert_eq!(s.messages, 4);
        assert_eq!((s.start_ns, s.end_ns), (5, 7));
        let bytes = w.into_inner();
        assert_eq!(s.bytes, bytes.len() as u64);
        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let meta = &summary.metadata_indexes;
        assert_eq!(
            meta.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(),
            ["cnc", "rosbag2"]
        );
        assert_eq!(summary.attachment_indexes.len(), 2);
    }

    #[test]
    fn io_errors_are_returned() {
        /// accepts the first `left` bytes, then fails
        struct Failing {
            inner: Cursor<Vec<u8>>,
            left: usize,
        }
        impl Write for Failing {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                if b.len() > self.left {
                    return Err(std::io::Error::other("disk full"));
                }
                self.left -= b.len();
                self.inner.write(b)
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        impl Seek for Failing {
            fn seek(&mut self, p: std::io::SeekFrom) -> std::io::Result<u64> {
                self.inner.seek(p)
            }
        }
        for left in [0, 30, 200, 2000] {
            let w = Failing {
                inner: Cursor::new(Vec::new()),
                left,
            };
            let r = Recorder::new(w, "x.mcap", RecordingInfo::default()).and_then(|mut rec| {
                let ch = rec.channel::<Float64>("/a")?;
                for k in 0..100 {
                    rec.write(ch, k, &Float64 { data: k as f64 })?;
                }
                rec.finish()
            });
            assert!(r.is_err(), "left {left}");
        }
    }
}
