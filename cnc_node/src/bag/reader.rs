//! The reader of recordings: [`Bag`].

use crate::record::{from_cdr, topics};
use cnc_core::{Dialect, Machine};
use cnc_msgs::StringMsg;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The messages of one topic.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TopicData {
    /// schema name, e.g. `sensor_msgs/msg/JointState` (empty if none)
    pub type_name: String,
    /// (log time in ns, payload) in file order
    pub messages: Vec<(u64, Vec<u8>)>,
}

/// An MCAP recording read into memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bag {
    pub path: PathBuf,
    /// topics in the order of their channel ids
    pub topics: Vec<(String, TopicData)>,
    /// metadata records by name (`cnc`, `rosbag2`)
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// attachments by name (`program.nc`, `machine.toml`)
    pub attachments: BTreeMap<String, Vec<u8>>,
    /// the earliest log time, ns (0 if there is no message)
    pub start_ns: u64,
}

/// How much of a file a read accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extent {
    /// a complete recording; one cut short is refused with a pointer to
    /// `cnc bag recover`
    Complete,
    /// also a recording cut short (a killed recorder: no summary, no end
    /// magic), read as far as its whole chunks go (`cnc plot`)
    AsFarAsItGoes,
}

/// One message as [`Bag::scan`] hands it over.
#[derive(Clone, Copy, Debug)]
pub struct MessageView<'a> {
    pub topic: &'a str,
    /// schema name (empty if none)
    pub type_name: &'a str,
    /// log time, ns since the Unix epoch
    pub log_time: u64,
    /// the payload (CDR)
    pub data: &'a [u8],
}

impl Bag {
    /// Reads a whole recording. A file cut short (a killed recorder: no
    /// summary, an unfinished chunk) is refused with a pointer to `cnc
    /// bag recover` ([`crate::recover`]), which makes a complete file of
    /// what it holds.
    pub fn read(path: &Path) -> Result<Bag, String> {
        Bag::scan(path, Extent::Complete, |_| Ok(true))
    }

    /// Reads a recording, handing every message to `keep` first: the bag
    /// keeps the messages for which it returns true (a reader that
    /// condenses a long recording as it goes keeps none, so the messages
    /// never sit in memory all at once); its error ends the read. The
    /// metadata, attachments and topics are read either way.
    pub fn scan(
        path: &Path,
        extent: Extent,
        mut keep: impl FnMut(&MessageView) -> Result<bool, String>,
    ) -> Result<Bag, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Bag::scan_bytes(path, &bytes, extent, &mut keep).map_err(|e| {
            let cut = mcap::Summary::read(&bytes).map_or(true, |s| s.is_none());
            let hint = if cut && bytes.starts_with(mcap::MAGIC) {
                format!(
                    " (the file has no summary: a recording that was cut short? `cnc bag recover {} -o OUT.mcap` makes a complete file of what it holds)",
                    path.display()
                )
            } else {
                String::new()
            };
            format!("{}: {e}{hint}", path.display())
        })
    }

    /// A recording from its bytes; `path` is only kept for the reports.
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Bag, String> {
        Bag::scan_bytes(path, bytes, Extent::Complete, &mut |_| Ok(true))
    }

    /// [`scan`](Self::scan) of a recording's bytes; errors without the path.
    pub fn scan_bytes(
        path: &Path,
        bytes: &[u8],
        extent: Extent,
        keep: &mut dyn FnMut(&MessageView) -> Result<bool, String>,
    ) -> Result<Bag, String> {
        crate::chunks::check_magic(bytes)?;
        // every chunk is checked before the mcap reader, which allocates
        // what a chunk claims, sees it
        check_chunks(bytes).map_err(|e| {
            format!(
                "{e}; `cnc bag recover {} -o OUT.mcap` skips it and keeps the rest",
                path.display()
            )
        })?;
        let cut_ok = extent == Extent::AsFarAsItGoes;
        let ignore_end = mcap::read::Options::IgnoreEndMagic;
        let mut bag = Bag {
            path: path.to_path_buf(),
            ..Default::default()
        };
        let mut channels: BTreeMap<u16, (String, TopicData)> = BTreeMap::new();
        // top-level records: metadata and attachments (chunks stay compressed)
        let reader = if cut_ok {
            mcap::read::LinearReader::new_with_options(bytes, ignore_end.into())
        } else {
            mcap::read::LinearReader::new(bytes)
        }
        .map_err(|e| format!("MCAP: {e}"))?;
        for r in reader {
            let r = match r {
                Ok(r) => r,
                // a cut file: what came before its broken end
                Err(_) if cut_ok => break,
                Err(e) => return Err(format!("MCAP: {e}")),
            };
            match r {
                mcap::records::Record::Metadata(m) => {
                    bag.metadata.insert(m.name, m.metadata);
                }
                mcap::records::Record::Attachment { header, data, .. } => {
                    bag.attachments.insert(header.name, data.into_owned());
                }
                _ => {}
            }
        }
        // channels without messages are only in the summary
        if let Ok(Some(summary)) = mcap::Summary::read(bytes) {
            for c in summary.channels.values() {
                channels.insert(c.id, (c.topic.clone(), topic_data(c)));
            }
        }
        let stream = if cut_ok {
            mcap::MessageStream::new_with_options(bytes, ignore_end.into())
        } else {
            mcap::MessageStream::new(bytes)
        }
        .map_err(|e| format!("MCAP: {e}"))?;
        let mut start: Option<u64> = None;
        for m in stream {
            let m = m.map_err(|e| format!("MCAP: {e}"))?;
            start = Some(start.map_or(m.log_time, |s| s.min(m.log_time)));
            let (topic, data) = channels
                .entry(m.channel.id)
                .or_insert_with(|| (m.channel.topic.clone(), topic_data(&m.channel)));
            let view = MessageView {
                topic,
                type_name: &data.type_name,
                log_time: m.log_time,
                data: &m.data,
            };
            if keep(&view)? {
                data.messages.push((m.log_time, m.data.into_owned()));
            }
        }
        bag.start_ns = start.unwrap_or(0);
        bag.topics = channels.into_values().collect();
        Ok(bag)
    }

    /// The messages of a topic.
    pub fn topic(&self, name: &str) -> Option<&TopicData> {
        self.topics.iter().find(|(t, _)| t == name).map(|(_, d)| d)
    }

    /// A text of the job: the attachment, or else the first
    /// `std_msgs/String` message of a latched topic (`/cnc/program`,
    /// `/cnc/machine_file`); None when the recording has neither.
    pub fn job_text(&self, attachment: &str, topic: &str) -> Result<Option<String>, String> {
        if let Some(a) = self.attachments.get(attachment) {
            return String::from_utf8(a.clone())
                .map(Some)
                .map_err(|_| format!("{attachment}: not UTF-8"));
        }
        let Some(t) = self.topic(topic).and_then(|d| d.messages.first()) else {
            return Ok(None);
        };
        from_cdr::<StringMsg>(&t.1)
            .map(|s| Some(s.data))
            .map_err(|e| format!("{topic}: {e}"))
    }

    /// [`job_text`](Self::job_text), which must be there.
    fn text(&self, attachment: &str, topic: &str) -> Result<String, String> {
        self.job_text(attachment, topic)?
            .ok_or_else(|| format!("neither an attachment {attachment} nor a message on {topic}"))
    }

    /// The job the recording is of: program, dialect, machine file.
    pub fn job(&self) -> Result<Job, String> {
        let program_text = self.text("program.nc", topics::PROGRAM)?;
        let machine_toml = self.text("machine.toml", topics::MACHINE_FILE)?;
        let machine =
            Machine::from_toml(&machine_toml).map_err(|e| format!("machine.toml: {e}"))?;
        let cnc = self.metadata.get("cnc");
        let get = |k: &str| cnc.and_then(|m| m.get(k)).filter(|v| !v.is_empty());
        let dialect = match get("dialect") {
            Some(d) => d.parse::<Dialect>()?,
            None => machine.dialect,
        };
        if let Some(rate) = get("rate_hz") {
            let r: f64 = rate
                .parse()
                .map_err(|_| format!("metadata cnc.rate_hz: not a number: {rate}"))?;
            if r != machine.interpolation.rate_hz {
                return Err(format!(
                    "metadata cnc.rate_hz {r} differs from the machine file's interpolation.rate_hz {}",
                    machine.interpolation.rate_hz
                ));
            }
        }
        Ok(Job {
            program_name: get("program_name")
                .cloned()
                .unwrap_or_else(|| "program.nc".into()),
            program_text,
            dialect,
            machine,
            machine_text: machine_toml,
        })
    }
}

/// Every whole chunk of the data section, decompressed and checked with
/// [`crate::chunks::chunk_records`] (sizes, CRC, whole records); Err
/// names the first damaged one. What is not a whole record (a file cut
/// short) and a chunk compressed otherwise are left to the mcap reader,
/// which reports them.
fn check_chunks(bytes: &[u8]) -> Result<(), String> {
    use mcap::records::{op, Record};
    let magic = mcap::MAGIC.len();
    for (at, opcode, body) in crate::chunks::Records::new(bytes.get(magic..).unwrap_or_default()) {
        let at = magic + at;
        match opcode {
            op::CHUNK => {
                if let Ok(Record::Chunk { header, data }) =
                    mcap::read::parse_record(op::CHUNK, body)
                {
                    if header.compression.is_empty() || header.compression == "zstd" {
                        crate::chunks::chunk_records(&header, &data)
                            .map_err(|e| format!("a damaged chunk at byte {at} ({e})"))?;
                    }
                }
            }
            op::DATA_END | op::FOOTER => break,
            _ => {}
        }
    }
    Ok(())
}

fn topic_data(c: &mcap::Channel) -> TopicData {
    TopicData {
        type_name: c
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default(),
        messages: Vec::new(),
    }
}

/// What a recording ran: enough to run it again.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    pub program_name: String,
    pub program_text: String,
    pub dialect: Dialect,
    pub machine: Machine,
    /// The machine file as the recording holds it (as written, comments
    /// and all, for a file the node was given).
    pub machine_text: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Recorder, RecordingInfo};
    use cnc_msgs::Float64;
    use std::io::Cursor;

    /// A recording of 20 messages on `/a` and 10 on `/b`, and the offset
    /// of its DataEnd record (where the summary begins).
    fn recording() -> (Vec<u8>, usize) {
        let mut rec = Recorder::new(
            Cursor::new(Vec::new()),
            "m.mcap",
            RecordingInfo {
                program_text: "G0 X1\n".into(),
                ..Default::default()
            },
        )
        .unwrap();
        let a = rec.channel::<Float64>("/a").unwrap();
        let b = rec.channel::<Float64>("/b").unwrap();
        for k in 0..20u64 {
            rec.write(a, 1000 + k, &Float64 { data: k as f64 }).unwrap();
            if k % 2 == 0 {
                rec.write(b, 1000 + k, &Float64 { data: -(k as f64) })
                    .unwrap();
            }
        }
        let bytes = rec.finish_into_inner().unwrap().1.into_inner();
        // records after the magic: opcode, u64 length, body
        let mut at = 8;
        while bytes[at] != 0x0f {
            let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
            at += 9 + len as usize;
        }
        (bytes, at)
    }

    #[test]
    fn scan_keeps_what_it_is_told_and_reads_cut_files_when_asked() {
        let (bytes, data_end) = recording();
        let path = Path::new("m.mcap");
        let mut seen = 0;
        let bag = Bag::scan_bytes(path, &bytes, Extent::Complete, &mut |m| {
            if m.topic.len() == 2 {
                seen += 1;
                assert_eq!(m.type_name, "std_msgs/msg/Float64");
            }
            Ok(m.topic == "/b")
        })
        .unwrap();
        assert_eq!(seen, 30);
        // the job's latched messages were seen, not kept
        assert_eq!(bag.topic("/cnc/program").map(|d| d.messages.len()), Some(0));
        assert_eq!(bag.topic("/a").map(|d| d.messages.len()), Some(0));
        assert_eq!(bag.topic("/b").map(|d| d.messages.len()), Some(10));
        assert_eq!(bag.start_ns, 1000);
        assert_eq!(
            bag.job_text("program.nc", "/cnc/program"),
            Ok(Some("G0 X1\n".into()))
        );
        assert_eq!(bag.job_text("nothing", "/none"), Ok(None));
        // an error of the caller ends the read
        let e = Bag::scan_bytes(path, &bytes, Extent::Complete, &mut |_| Err("no".into()));
        assert_eq!(e, Err("no".into()));
        // cut where the summary begins: refused whole, read as far as it goes
        let cut = &bytes[..data_end];
        assert!(Bag::from_bytes(path, cut).is_err());
        let bag = Bag::scan_bytes(path, cut, Extent::AsFarAsItGoes, &mut |_| Ok(true)).unwrap();
        // (everything but the summary: the same bag)
        assert_eq!(bag, Bag::from_bytes(path, &bytes).unwrap_or_default());
        assert_eq!(
            Bag::from_bytes(path, b"junk").unwrap_err(),
            "not an MCAP file: it starts with 6A 75 6E 6B and ends there (an MCAP file starts with the 8 bytes 89 4D 43 41 50 30 0D 0A, \"\\x89MCAP0\\r\\n\")"
        );
    }
}
