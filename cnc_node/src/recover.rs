//! `cnc bag recover`: a complete MCAP file from one that was cut short (a
//! killed recorder, a full disk, a copy that broke off).
//!
//! The input is read record by record from its start, without its summary
//! (which a killed recorder never wrote): every record whose bytes are all
//! there is kept, every chunk that is whole and decompresses with a good
//! CRC gives its schemas, channels and messages, and reading stops at the
//! first record that runs past the end of the file (the chunk that was
//! open when the process died: its header still holds the placeholder
//! lengths the MCAP writer patches when it closes the chunk). A record
//! that is whole but damaged (bad CRC, bad compression, sizes that do
//! not add up) is skipped and reported. When a damaged chunk held the
//! definitions of channels (schemas and channels are written where they
//! are first used), those of a complete file's summary are taken instead,
//! so the messages of the chunks after it are kept.
//!
//! Every chunk is decompressed by [`chunk_records`], which takes no size
//! from the file on trust (the `mcap` crate's chunk reader allocates what
//! a chunk's header and its records claim, so one flipped bit could make
//! it ask for exabytes); [`crate::bag::Bag`] checks every chunk with it
//! before it hands a file to the `mcap` reader.
//!
//! The output is written the way [`crate::record`] writes recordings
//! (profile of the input, zstd chunks of [`record::CHUNK_SIZE`], schema
//! and channel ids kept, messages in file order), followed by the summary.
//! Metadata and attachments are copied; rosbag2's metadata record is kept
//! when the input has it (it is written last, so then every message was
//! written) and otherwise written anew from the recovered channels, so
//! `ros2 bag info`, `cnc bag rerun` and any MCAP reader accept the file.

use crate::chunks::{chunk_records, record_name, Records};
use crate::record::{self, BagTopic};
use mcap::records::{op, Record};
use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// The records of [`chunk_records`]' output, parsed: the whole chunk or
/// nothing of it.
fn parse_chunk_records(records: &[u8]) -> Result<Vec<Record<'_>>, mcap::McapError> {
    // (chunk_records checked that every record is whole)
    Records::new(records)
        .map(|(_, op, body)| mcap::read::parse_record(op, body))
        .collect()
}

/// What [`recover`] found and wrote.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recovery {
    pub input: PathBuf,
    pub output: PathBuf,
    /// messages written to the output
    pub messages: u64,
    /// channels defined in the output, and those with at least one message
    pub channels: usize,
    pub channels_with_messages: usize,
    /// complete chunks read
    pub chunks: u32,
    /// log time of the first and the last message, ns
    pub start_ns: Option<u64>,
    pub end_ns: Option<u64>,
    /// metadata records copied (names, in file order)
    pub metadata: Vec<String>,
    /// attachments copied (names, in file order)
    pub attachments: Vec<String>,
    /// the input's rosbag2 metadata was kept (else written anew, or none
    /// for a profile other than `ros2`)
    pub rosbag2_kept: bool,
    /// the input ended properly (its data section was complete)
    pub complete: bool,
    /// bytes at the end of the input that were not whole records, and
    /// what they were (e.g. "an unfinished chunk")
    pub dropped_bytes: u64,
    pub dropped: Option<String>,
    /// whole records that could not be read (bad CRC, bad compression), skipped
    pub damaged: Vec<String>,
    /// how many of them were chunks
    pub damaged_chunks: usize,
    /// messages of channels whose definition was lost, skipped
    pub orphans: u64,
    /// channels whose definition was lost with a damaged chunk, taken
    /// from the input's summary
    pub from_summary: usize,
    /// the messages the input's summary counts (a complete input)
    pub summary_messages: Option<u64>,
    /// the log time of the first message the input's summary counts, ns
    /// (a complete input): where its job's time starts
    pub summary_start_ns: Option<u64>,
    /// a chunk was damaged before the first message recovered (what came
    /// before that message is lost, and the summary may not say when it
    /// began)
    pub lost_at_start: bool,
    /// size of the output, bytes
    pub bytes: u64,
}

impl fmt::Display for Recovery {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: recovered {} message{} on {} channel{}",
            self.input.display(),
            self.messages,
            if self.messages == 1 { "" } else { "s" },
            self.channels_with_messages,
            if self.channels_with_messages == 1 {
                ""
            } else {
                "s"
            },
        )?;
        if self.channels != self.channels_with_messages {
            write!(f, " ({} defined)", self.channels)?;
        }
        write!(
            f,
            " from {} complete chunk{}",
            self.chunks,
            if self.chunks == 1 { "" } else { "s" }
        )?;
        if let (Some(s), Some(e)) = (self.start_ns, self.end_ns) {
            // (t counts from the input's first message where its summary
            // says when that was, else from the first one recovered)
            let t0 = self.summary_start_ns.map_or(s, |z| z.min(s));
            let t = |ns: u64| ns.saturating_sub(t0) as f64 * 1e-9;
            if s > t0 {
                write!(f, ", from t = {:.3} s", t(s))?;
            }
            write!(
                f,
                ", up to t = {:.3} s (last log time {}.{:09} s)",
                t(e),
                e / 1_000_000_000,
                e % 1_000_000_000
            )?;
            if self.lost_at_start && self.summary_start_ns.is_none() {
                write!(
                    f,
                    " counted from the first message recovered: a damaged chunk came before it"
                )?;
            }
        }
        let clean = self.damaged.is_empty() && !self.lost();
        match (&self.dropped, self.complete, clean) {
            (Some(what), _, _) => write!(f, "; dropped {} bytes of {what}", self.dropped_bytes)?,
            (None, true, true) => write!(f, "; the file was complete, nothing was lost")?,
            (None, true, false) => write!(f, "; the file ended properly")?,
            (None, false, _) => {
                write!(f, "; the file ended after a whole record, nothing was cut")?
            }
        }
        for d in &self.damaged {
            write!(f, "; skipped {d}")?;
        }
        if self.from_summary > 0 {
            write!(
                f,
                "; took the definitions of {} channel(s) from the file's summary",
                self.from_summary
            )?;
        }
        if self.orphans > 0 {
            write!(
                f,
                "; skipped {} message(s) of channels whose definition was lost",
                self.orphans
            )?;
        }
        match self.summary_messages {
            Some(n) if n > self.messages => write!(
                f,
                "; LOST {} of the {n} messages the file's summary counts",
                n - self.messages
            )?,
            Some(n) if !self.damaged.is_empty() => write!(
                f,
                "; all {n} messages the file's summary counts were recovered"
            )?,
            _ => {}
        }
        writeln!(f)?;
        let list = |v: &[String]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        write!(
            f,
            "{}: {} bytes with summary; metadata: {}{}; attachments: {}",
            self.output.display(),
            self.bytes,
            list(&self.metadata),
            if self.rosbag2_kept {
                " (rosbag2 kept)"
            } else if self.metadata.iter().any(|m| m == "rosbag2") {
                " (rosbag2 written anew)"
            } else {
                ""
            },
            list(&self.attachments)
        )
    }
}

impl Recovery {
    /// Something of the input's whole records is not in the output: a
    /// damaged record was skipped (of a complete input with statistics,
    /// a damaged chunk counts only when messages are missing, since its
    /// schemas and channels are taken from the summary), or messages were
    /// skipped without their channel. A cut end is not counted.
    pub fn lost(&self) -> bool {
        let damaged = match self.summary_messages {
            Some(n) => n > self.messages || self.damaged.len() > self.damaged_chunks,
            None => !self.damaged.is_empty(),
        };
        damaged || self.orphans > 0
    }
}

/// Whether an Attachment record's body holds its header (log time,
/// create time, name, media type, data length) and its CRC, which the
/// `mcap` crate's parser assumes.
fn attachment_fits(body: &[u8]) -> bool {
    let u32_at = |off: usize| -> Option<usize> {
        let b = body.get(off..off + 4)?;
        Some(u32::from_le_bytes(b.try_into().ok()?) as usize)
    };
    let mut off = 16usize;
    for _ in 0..2 {
        match u32_at(off).and_then(|n| off.checked_add(4)?.checked_add(n)) {
            Some(o) => off = o,
            None => return false,
        }
    }
    off.checked_add(8 + 4).is_some_and(|end| end <= body.len())
}

/// Reads `input` (see the module documentation) and writes the complete
/// recording `out`. Errors, with nothing left at `out`, for a file that is
/// not MCAP, for `out` equal to `input`, and for I/O errors.
pub fn recover(input: &Path, out: &Path) -> Result<Recovery, String> {
    if crate::files::same_file(input, out) {
        return Err(format!(
            "{}: the output must be another file than the input",
            out.display()
        ));
    }
    let f = File::open(input).map_err(|e| format!("{}: {e}", input.display()))?;
    let len = f
        .metadata()
        .map_err(|e| format!("{}: {e}", input.display()))?
        .len();
    let mut reader = BufReader::with_capacity(1 << 16, f);
    // the input is checked before the output is created
    check_magic(&mut reader, len).map_err(|e| format!("{}: {e}", input.display()))?;
    let w = File::create(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let file_name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let r = recover_records(
        &mut reader,
        len,
        BufWriter::with_capacity(1 << 16, w),
        &file_name,
    )
    .map(|(r, _)| r);
    match r {
        Ok(mut r) => {
            r.input = input.to_path_buf();
            r.output = out.to_path_buf();
            Ok(r)
        }
        Err(e) => {
            let _ = std::fs::remove_file(out);
            Err(format!("{}: {e}", input.display()))
        }
    }
}

/// [`recover`] of a recording in memory into any writer; `file_name` is
/// what a new rosbag2 metadata record names as the file.
pub fn recover_bytes<W: Write + Seek>(
    bytes: &[u8],
    w: W,
    file_name: &str,
) -> Result<(Recovery, W), String> {
    let mut r = std::io::Cursor::new(bytes);
    check_magic(&mut r, bytes.len() as u64)?;
    recover_records(&mut r, bytes.len() as u64, w, file_name)
}

fn check_magic(r: &mut impl Read, len: u64) -> Result<(), String> {
    let mut magic = [0u8; 8];
    let n = (len.min(8)) as usize;
    r.read_exact(&mut magic[..n])
        .map_err(|e| format!("reading the file: {e}"))?;
    crate::chunks::check_magic(&magic[..n])
}

/// A schema and a channel as read, for the output and the report.
struct ChannelInfo {
    topic: String,
    schema_name: String,
    qos_yaml: String,
    count: u64,
}

/// The schemas and channels of a complete input's summary, and the
/// messages its statistics count.
#[derive(Default)]
struct SummaryDefs {
    schemas: BTreeMap<u16, (String, String, Vec<u8>)>,
    channels: BTreeMap<u16, mcap::records::Channel>,
    messages: Option<u64>,
    /// the first message's log time, ns (of a summary that counts any)
    start_ns: Option<u64>,
}

/// [`SummaryDefs`] of an input of `len` bytes that ends with a footer
/// (else none); what cannot be read of it is left out. Leaves `r` where
/// it was.
fn summary_defs<R: Read + Seek>(r: &mut R, len: u64) -> Result<SummaryDefs, String> {
    let io = |e: std::io::Error| format!("reading the file: {e}");
    let mut defs = SummaryDefs::default();
    // footer: opcode, length 20, summary start, summary offset start, CRC; then the magic
    const FOOTER: u64 = 9 + 20 + 8;
    if len < 8 + FOOTER {
        return Ok(defs);
    }
    let back = r.stream_position().map_err(io)?;
    let footer_at = len - FOOTER;
    r.seek(SeekFrom::Start(footer_at)).map_err(io)?;
    let mut tail = [0u8; FOOTER as usize];
    r.read_exact(&mut tail).map_err(io)?;
    let u64_at =
        |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap_or_default());
    let start = u64_at(&tail, 9);
    if tail[0] == op::FOOTER
        && u64_at(&tail, 1) == 20
        && tail[29..] == mcap::MAGIC[..]
        && start >= 8
        && start < footer_at
    {
        let mut summary = vec![0u8; (footer_at - start) as usize];
        r.seek(SeekFrom::Start(start)).map_err(io)?;
        r.read_exact(&mut summary).map_err(io)?;
        for (_, op, body) in Records::new(&summary) {
            match mcap::read::parse_record(op, body) {
                Ok(Record::Schema { header, data }) => {
                    defs.schemas
                        .insert(header.id, (header.name, header.encoding, data.into_owned()));
                }
                Ok(Record::Channel(c)) => {
                    defs.channels.insert(c.id, c);
                }
                Ok(Record::Statistics(s)) => {
                    defs.messages = Some(s.message_count);
                    defs.start_ns = (s.message_count > 0).then_some(s.message_start_time);
                }
                _ => {}
            }
        }
    }
    r.seek(SeekFrom::Start(back)).map_err(io)?;
    Ok(defs)
}

struct State<W: Write + Seek> {
    w: mcap::Writer<W>,
    rec: Recovery,
    channels: BTreeMap<u16, ChannelInfo>,
    schema_names: BTreeMap<u16, String>,
    rosbag2: Option<mcap::records::Metadata>,
    profile: String,
    summary: SummaryDefs,
}

impl<W: Write + Seek> State<W> {
    fn schema(&mut self, id: u16, name: &str, encoding: &str, data: &[u8]) -> Result<(), String> {
        if id == 0 {
            return Ok(());
        }
        self.w
            .add_schema_with_id(id, name, encoding, data)
            .map_err(|e| format!("schema {id} ({name}): {e}"))?;
        self.schema_names.insert(id, name.to_string());
        Ok(())
    }

    fn channel(&mut self, c: &mcap::records::Channel) -> Result<(), String> {
        if c.schema_id != 0 && !self.schema_names.contains_key(&c.schema_id) {
            // its schema was lost: the channel and its messages go
            return Ok(());
        }
        self.w
            .add_channel_with_id(
                c.id,
                c.schema_id,
                &c.topic,
                &c.message_encoding,
                &c.metadata,
            )
            .map_err(|e| format!("channel {} ({}): {e}", c.id, c.topic))?;
        self.channels.entry(c.id).or_insert_with(|| ChannelInfo {
            topic: c.topic.clone(),
            schema_name: self
                .schema_names
                .get(&c.schema_id)
                .cloned()
                .unwrap_or_default(),
            qos_yaml: c
                .metadata
                .get("offered_qos_profiles")
                .cloned()
                .unwrap_or_else(|| record::qos_yaml(&record::Qos::DEFAULT)),
            count: 0,
        });
        Ok(())
    }

    fn message(&mut self, h: &mcap::records::MessageHeader, data: &[u8]) -> Result<(), String> {
        if !self.channels.contains_key(&h.channel_id) {
            // its definition was in a damaged chunk: the summary's
            if let Some(c) = self.summary.channels.get(&h.channel_id).cloned() {
                self.define_from_summary(&c)?;
            }
        }
        let Some(c) = self.channels.get_mut(&h.channel_id) else {
            self.rec.orphans += 1;
            return Ok(());
        };
        c.count += 1;
        self.w
            .write_to_known_channel(h, data)
            .map_err(|e| format!("writing a message of {}: {e}", c.topic))?;
        self.rec.messages += 1;
        let t = h.log_time;
        self.rec.start_ns = Some(self.rec.start_ns.map_or(t, |s| s.min(t)));
        self.rec.end_ns = Some(self.rec.end_ns.map_or(t, |e| e.max(t)));
        Ok(())
    }

    /// A channel (and its schema) as the input's summary defines it.
    fn define_from_summary(&mut self, c: &mcap::records::Channel) -> Result<(), String> {
        if c.schema_id != 0 && !self.schema_names.contains_key(&c.schema_id) {
            if let Some((name, encoding, data)) = self.summary.schemas.get(&c.schema_id).cloned() {
                self.schema(c.schema_id, &name, &encoding, &data)?;
            }
        }
        self.channel(c)?;
        if self.channels.contains_key(&c.id) {
            self.rec.from_summary += 1;
        }
        Ok(())
    }

    /// One whole top-level record. Ok(false): the data section ended.
    fn record(&mut self, opcode: u8, body: &[u8], at: u64) -> Result<bool, String> {
        let damaged =
            |e: mcap::McapError| format!("a damaged {} at byte {at} ({e})", record_name(opcode));
        if opcode == op::ATTACHMENT && !attachment_fits(body) {
            self.rec.damaged.push(format!(
                "a damaged attachment at byte {at} (shorter than its header and CRC)"
            ));
            return Ok(true);
        }
        let rec = match mcap::read::parse_record(opcode, body) {
            Ok(r) => r,
            Err(e) => {
                self.rec.damaged.push(damaged(e));
                if opcode == op::CHUNK {
                    self.rec.damaged_chunks += 1;
                    self.rec.lost_at_start |= self.rec.start_ns.is_none();
                }
                return Ok(true);
            }
        };
        match rec {
            Record::Header(_) => {}
            Record::Schema { header, data } => {
                self.schema(header.id, &header.name, &header.encoding, &data)?
            }
            Record::Channel(c) => self.channel(&c)?,
            Record::Message { header, data } => self.message(&header, &data)?,
            Record::Chunk { header, data } => {
                // the whole chunk or nothing of it
                let plain = match chunk_records(&header, &data) {
                    Ok(p) => p,
                    Err(e) => {
                        self.rec
                            .damaged
                            .push(format!("a damaged chunk at byte {at} ({e})"));
                        self.rec.damaged_chunks += 1;
                        self.rec.lost_at_start |= self.rec.start_ns.is_none();
                        return Ok(true);
                    }
                };
                let records = match parse_chunk_records(&plain) {
                    Ok(r) => r,
                    Err(e) => {
                        self.rec.damaged.push(damaged(e));
                        self.rec.damaged_chunks += 1;
                        self.rec.lost_at_start |= self.rec.start_ns.is_none();
                        return Ok(true);
                    }
                };
                self.rec.chunks += 1;
                for r in records {
                    match r {
                        Record::Schema { header, data } => {
                            self.schema(header.id, &header.name, &header.encoding, &data)?
                        }
                        Record::Channel(c) => self.channel(&c)?,
                        Record::Message { header, data } => self.message(&header, &data)?,
                        _ => {}
                    }
                }
            }
            Record::Attachment { header, data, .. } => {
                self.w
                    .attach(&mcap::Attachment {
                        log_time: header.log_time,
                        create_time: header.create_time,
                        name: header.name.clone(),
                        media_type: header.media_type,
                        data,
                    })
                    .map_err(|e| format!("attachment {}: {e}", header.name))?;
                self.rec.attachments.push(header.name);
            }
            Record::Metadata(m) => {
                if m.name == "rosbag2" {
                    // written last, as the recorder does
                    self.rosbag2 = Some(m);
                } else {
                    self.w
                        .write_metadata(&m)
                        .map_err(|e| format!("metadata {}: {e}", m.name))?;
                    self.rec.metadata.push(m.name);
                }
            }
            Record::DataEnd(_) | Record::Footer(_) => {
                self.rec.complete = true;
                return Ok(false);
            }
            // indexes and the summary are written anew
            _ => {}
        }
        Ok(true)
    }
}

fn recover_records<R: Read + Seek, W: Write + Seek>(
    r: &mut R,
    len: u64,
    w: W,
    file_name: &str,
) -> Result<(Recovery, W), String> {
    let io = |e: std::io::Error| format!("reading the file: {e}");
    let summary = summary_defs(r, len)?;
    // (opcode, length) of the next record, or what cut it off
    let next = |r: &mut R, pos: u64| -> Result<Result<(u8, u64), Recovery>, String> {
        let left = len - pos;
        let cut = |what: String| {
            Ok(Err(Recovery {
                dropped_bytes: left,
                dropped: Some(what),
                ..Default::default()
            }))
        };
        if left < 9 {
            return cut("a record cut off in its opcode and length".into());
        }
        let mut head = [0u8; 9];
        r.read_exact(&mut head).map_err(io)?;
        let opcode = head[0];
        let rec_len = u64::from_le_bytes(head[1..].try_into().unwrap_or_default());
        if rec_len > left - 9 {
            return cut(format!(
                "an unfinished {}{}",
                record_name(opcode),
                if rec_len == u64::MAX {
                    " (its length was never written: the recorder was stopped while it was open)"
                } else {
                    ""
                }
            ));
        }
        Ok(Ok((opcode, rec_len)))
    };
    let mut body = Vec::new();
    let mut pos = 8u64;
    // the header first: its profile is the output's
    let mut profile = String::new();
    let mut cut = None;
    if pos < len {
        match next(r, pos)? {
            Ok((opcode, rec_len)) => {
                if opcode != op::HEADER {
                    return Err(format!(
                        "not an MCAP file: the magic is not followed by a header record (opcode 0x{opcode:02x})"
                    ));
                }
                body.resize(rec_len as usize, 0);
                r.read_exact(&mut body).map_err(io)?;
                match mcap::read::parse_record(opcode, &body) {
                    Ok(Record::Header(h)) => profile = h.profile,
                    _ => return Err("not an MCAP file: its header record is damaged".into()),
                }
                pos += 9 + rec_len;
            }
            Err(c) => cut = Some(c),
        }
    }
    let w = record::write_options(Some(record::CHUNK_SIZE))
        .profile(profile.clone())
        .create(w)
        .map_err(|e| format!("writing the MCAP header: {e}"))?;
    let mut st = State {
        w,
        rec: Recovery::default(),
        channels: BTreeMap::new(),
        schema_names: BTreeMap::new(),
        rosbag2: None,
        profile,
        summary,
    };
    while cut.is_none() && pos < len {
        match next(r, pos)? {
            Ok((opcode, rec_len)) => {
                body.clear();
                body.resize(rec_len as usize, 0);
                r.read_exact(&mut body).map_err(io)?;
                if !st.record(opcode, &body, pos)? {
                    break;
                }
                pos += 9 + rec_len;
            }
            Err(c) => cut = Some(c),
        }
    }
    if let Some(c) = cut {
        st.rec.dropped_bytes = c.dropped_bytes;
        st.rec.dropped = c.dropped;
    }
    // channels defined in a damaged chunk, of which no message was read
    let undefined: Vec<mcap::records::Channel> = st
        .summary
        .channels
        .values()
        .filter(|c| !st.channels.contains_key(&c.id))
        .cloned()
        .collect();
    for c in &undefined {
        st.define_from_summary(c)?;
    }
    let State {
        mut w,
        mut rec,
        channels,
        rosbag2,
        profile,
        summary,
        ..
    } = st;
    if rec.complete {
        rec.summary_messages = summary.messages;
        rec.summary_start_ns = summary.start_ns;
    }
    let rosbag2 = match rosbag2 {
        Some(m) => {
            rec.rosbag2_kept = true;
            Some(m)
        }
        None if profile == record::PROFILE => {
            let topics: Vec<BagTopic> = channels
                .values()
                .map(|c| BagTopic {
                    name: c.topic.clone(),
                    type_name: c.schema_name.clone(),
                    qos_yaml: c.qos_yaml.clone(),
                    count: c.count,
                })
                .collect();
            let mut meta = BTreeMap::new();
            meta.insert(
                "serialized_metadata".to_string(),
                record::bag_metadata_yaml(
                    &topics,
                    rec.start_ns.unwrap_or(0),
                    rec.end_ns.unwrap_or(0),
                    file_name,
                ),
            );
            meta.insert("ROS_DISTRO".to_string(), record::ROS_DISTRO.to_string());
            Some(mcap::records::Metadata {
                name: "rosbag2".into(),
                metadata: meta,
            })
        }
        None => None,
    };
    if let Some(m) = rosbag2 {
        w.write_metadata(&m)
            .map_err(|e| format!("writing metadata: {e}"))?;
        rec.metadata.push(m.name);
    }
    w.finish()
        .map_err(|e| format!("writing the summary: {e}"))?;
    let mut out = w.into_inner();
    out.flush()
        .map_err(|e| format!("writing the MCAP file: {e}"))?;
    rec.bytes = out
        .stream_position()
        .map_err(|e| format!("writing the MCAP file: {e}"))?;
    rec.channels = channels.len();
    rec.channels_with_messages = channels.values().filter(|c| c.count > 0).count();
    Ok((rec, out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Recorder, RecordingInfo};
    use std::io::Cursor;

    fn recording(n: u64) -> Vec<u8> {
        let mut rec =
            Recorder::new(Cursor::new(Vec::new()), "r.mcap", RecordingInfo::default()).unwrap();
        let ch = rec.channel::<cnc_msgs::Float64>("/a").unwrap();
        for k in 0..n {
            rec.write(ch, 1_000 + k, &cnc_msgs::Float64 { data: k as f64 })
                .unwrap();
        }
        rec.finish_into_inner().unwrap().1.into_inner()
    }

    #[test]
    fn a_complete_file_is_copied_whole() {
        let bytes = recording(10);
        let (r, out) = recover_bytes(&bytes, Cursor::new(Vec::new()), "o.mcap").unwrap();
        assert!(r.complete);
        assert_eq!(r.messages, 12); // /a, /cnc/program, /cnc/machine_file
        assert_eq!((r.start_ns, r.end_ns), (Some(1_000), Some(1_009)));
        assert!(r.rosbag2_kept);
        assert_eq!(r.metadata, ["cnc", "rosbag2"]);
        assert_eq!(r.attachments, ["program.nc", "machine.toml"]);
        let out = out.into_inner();
        let s = mcap::Summary::read(&out).unwrap().unwrap();
        assert_eq!(s.stats.unwrap().message_count, 12);
    }

    #[test]
    fn not_mcap_is_an_error() {
        for (bytes, want) in [
            (&b""[..], "the file is empty"),
            (b"\x89MCA", "it starts with 89 4D 43 41 and ends there"),
            (b"G01 X10 Y20\n", "it starts with 47 30 31 20 58 31 30 20"),
        ] {
            let e = recover_bytes(bytes, Cursor::new(Vec::new()), "o.mcap").unwrap_err();
            assert!(e.starts_with("not an MCAP file: "), "{e}");
            assert!(e.contains(want), "{e}");
        }
        let mut b = mcap::MAGIC.to_vec();
        b.extend_from_slice(&[0x05, 1, 0, 0, 0, 0, 0, 0, 0, 0]);
        let e = recover_bytes(&b, Cursor::new(Vec::new()), "o.mcap").unwrap_err();
        assert!(
            e.contains("not followed by a header record (opcode 0x05)"),
            "{e}"
        );
    }
}
