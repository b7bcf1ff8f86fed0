//! An MCAP file's chunks read without trusting its sizes: a damaged
//! chunk is an error naming the damage (`cnc bag recover` skips it, the
//! readers refuse the file), never an allocation of what a flipped bit
//! claims.

use mcap::records::op;
use std::io::Read;

/// The largest uncompressed chunk read, bytes (1 GiB; the recorder writes
/// chunks of about 1 MiB, a single larger message gets a chunk of its own).
pub const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// How far zstd data can expand at most: a block holds at most 128 KiB and
/// takes at least 4 bytes (a 3-byte block header and one byte repeated).
const ZSTD_MAX_EXPANSION: u64 = 128 * 1024 / 4;

/// Whether `head`, a file's first bytes (up to 8; fewer: the whole
/// file), is MCAP's magic; else what a reader tells the user, with what
/// the file starts with instead.
pub fn check_magic(head: &[u8]) -> Result<(), String> {
    let not_mcap = |why: &str| {
        format!(
            "not an MCAP file: {why} (an MCAP file starts with the 8 bytes 89 4D 43 41 50 30 0D 0A, \"\\x89MCAP0\\r\\n\")"
        )
    };
    let head = &head[..head.len().min(8)];
    if head.is_empty() {
        return Err(not_mcap("the file is empty"));
    }
    if head != mcap::MAGIC {
        let shown: Vec<String> = head.iter().map(|b| format!("{b:02X}")).collect();
        return Err(not_mcap(&format!(
            "it starts with {}{}",
            shown.join(" "),
            if head.len() < 8 {
                " and ends there"
            } else {
                ""
            }
        )));
    }
    Ok(())
}

/// The records of a chunk (its `records` field), decompressed and checked,
/// taking no size from the file on trust: the uncompressed size its header
/// gives must be at most [`MAX_CHUNK_BYTES`] and no more than its compressed
/// data can expand to; the data must decompress to exactly that size (never
/// more is decoded, and memory grows with what is decoded), match the
/// header's CRC (unless that is 0, "not computed") and be whole records
/// (opcode, length, body) to its end. Err: what is wrong with it.
pub fn chunk_records(header: &mcap::records::ChunkHeader, data: &[u8]) -> Result<Vec<u8>, String> {
    let size = header.uncompressed_size;
    if size > MAX_CHUNK_BYTES {
        return Err(format!(
            "its header gives an uncompressed size of {size} bytes, more than the {MAX_CHUNK_BYTES} bytes a chunk is read up to"
        ));
    }
    let records = match header.compression.as_str() {
        "" => {
            if data.len() as u64 != size {
                return Err(format!(
                    "it is not compressed, yet its header gives {size} bytes for its {} bytes of records",
                    data.len()
                ));
            }
            data.to_vec()
        }
        "zstd" => {
            let most = (data.len() as u64).saturating_mul(ZSTD_MAX_EXPANSION);
            if size > most {
                return Err(format!(
                    "its header gives an uncompressed size of {size} bytes, more than its {} bytes of zstd data can expand to ({most})",
                    data.len()
                ));
            }
            let mut out = Vec::new();
            let decoder = zstd::stream::read::Decoder::with_buffer(data)
                .map_err(|e| format!("bad compression: zstd: {e}"))?;
            // one byte more than the header gives: more is damage too
            decoder
                .take(size + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("bad compression: zstd: {e}"))?;
            if out.len() as u64 != size {
                return Err(format!(
                    "it decompresses to {}{} bytes, its header gives {size}",
                    if out.len() as u64 > size {
                        "more than "
                    } else {
                        ""
                    },
                    out.len().min(size as usize)
                ));
            }
            out
        }
        other => {
            return Err(format!(
                "unsupported compression {other:?} (zstd or none are read)"
            ))
        }
    };
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(&records);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "bad CRC: its records hash to {crc:08x}, its header gives {:08x}",
                header.uncompressed_crc
            ));
        }
    }
    let mut walk = Records::new(&records);
    for _ in walk.by_ref() {}
    let (at, left) = (walk.at(), records.len() - walk.at());
    if left > 0 {
        let Some(head) = records.get(at..at + 9) else {
            return Err(format!(
                "its records end in {left} bytes at byte {at} of {}, too few for a record's opcode and length",
                records.len()
            ));
        };
        let len = u64::from_le_bytes(head[1..].try_into().unwrap_or_default());
        return Err(format!(
            "a {} at byte {at} of its {} bytes of records claims {len} bytes, more than the {} left",
            record_name(head[0]),
            records.len(),
            left - 9
        ));
    }
    Ok(records)
}

/// The whole records (opcode, u64 length, body) of MCAP bytes, in order,
/// each with its offset: the walk stops before the first that is not whole
/// (its length past the end), where [`Records::at`] then stands.
pub struct Records<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Records<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Records { bytes, at: 0 }
    }

    /// Where the walk stands: after the last whole record given.
    pub fn at(&self) -> usize {
        self.at
    }
}

impl<'a> Iterator for Records<'a> {
    /// (offset, opcode, body)
    type Item = (usize, u8, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        let at = self.at;
        let head = self.bytes.get(at..at.checked_add(9)?)?;
        let len = u64::from_le_bytes(head[1..].try_into().unwrap_or_default());
        let body = usize::try_from(len)
            .ok()
            .and_then(|n| self.bytes.get(at + 9..(at + 9).checked_add(n)?))?;
        self.at = at + 9 + body.len();
        Some((at, head[0], body))
    }
}

/// What a record with opcode `op` is, for the reports.
pub fn record_name(opcode: u8) -> &'static str {
    match opcode {
        op::HEADER => "header",
        op::FOOTER => "footer",
        op::SCHEMA => "schema",
        op::CHANNEL => "channel",
        op::MESSAGE => "message",
        op::CHUNK => "chunk",
        op::MESSAGE_INDEX => "message index",
        op::CHUNK_INDEX => "chunk index",
        op::ATTACHMENT => "attachment",
        op::ATTACHMENT_INDEX => "attachment index",
        op::STATISTICS => "statistics record",
        op::METADATA => "metadata record",
        op::METADATA_INDEX => "metadata index",
        op::SUMMARY_OFFSET => "summary offset",
        op::DATA_END => "data end record",
        _ => "record",
    }
}
