//! The MCAP writer: [`Recorder`] writes one recording in the ROS 2
//! profile (see [`crate::record`] for what a file holds): the `cnc`
//! metadata, a schema and a channel per topic, CDR messages in zstd chunks
//! closed by size or by time span, the job as attachments and latched
//! messages, the `rosbag2` metadata and the summary.

use super::cdr::to_cdr_into;
use super::rosbag2::{bag_metadata_yaml, qos_yaml, BagTopic, Qos, MESSAGE_ENCODING, ROS_DISTRO};
use cnc_core::{Dialect, Machine};
use cnc_msgs::schema::{RosSchema, ENCODING};
use cnc_msgs::StringMsg;
use serde::Serialize;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::marker::PhantomData;
use std::path::Path;

/// MCAP header profile.
pub const PROFILE: &str = "ros2";
/// MCAP header library string.
pub const LIBRARY: &str = concat!("cnc_node/", env!("CARGO_PKG_VERSION"), " mcap-rust/0.26");
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
    /// the drives' setpoint delay the controller led G33 by, ms (the
    /// node's jobs: `interpolation.setpoint_delay_ms`); None: none, as in
    /// an offline run, where each setpoint drives the model in its own
    /// step (the key is then not written, so offline recordings stay as
    /// they were)
    pub setpoint_delay_ms: Option<f64>,
}

impl RecordingInfo {
    /// The job of an offline run: `program_text` named `program_name`, in
    /// `dialect`, on `machine` (its machine file as TOML, its rate).
    pub fn offline(
        machine: &Machine,
        program_name: &str,
        program_text: &str,
        dialect: Dialect,
    ) -> Result<RecordingInfo, String> {
        Ok(RecordingInfo {
            program_name: program_name.to_string(),
            program_text: program_text.to_string(),
            dialect: dialect.id().to_string(),
            machine_toml: machine_toml(machine)?,
            machine_name: machine.name.clone(),
            rate_hz: machine.interpolation.rate_hz,
            setpoint_delay_ms: None,
        })
    }
}

/// The machine file of a machine, as TOML (what recordings attach).
pub fn machine_toml(machine: &Machine) -> Result<String, String> {
    toml::to_string(machine).map_err(|e| format!("machine {}: {e}", machine.name))
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
        if let Some(d) = info.setpoint_delay_ms {
            cnc.insert("setpoint_delay_ms".into(), format!("{d}"));
        }
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

/// Bytes of a string in an MCAP record (u32 length, then the bytes).
fn str_len(s: &str) -> u64 {
    4 + s.len() as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc_msgs::Float64;
    use std::io::Cursor;

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
