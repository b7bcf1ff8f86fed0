//! Where program lines come from. The core never opens files: the caller
//! hands it a [`ProgramSource`] (a string here, a buffered file in the CLI).

/// A place in the program that can be returned to (for jumps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SourcePos {
    /// byte offset of the start of the line
    pub offset: u64,
    /// 1-based number of that line
    pub line: u32,
}

/// A failure to read the program (I/O in a file-backed source).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceError(pub String);

/// Line-by-line access to a program, with the ability to jump back.
pub trait ProgramSource {
    /// Reads the next line (without its line end) into `buf` (cleared first).
    /// Returns the position of that line, or `None` at the end.
    fn read_line(&mut self, buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError> {
        buf.clear();
        self.append_line(buf)
    }
    /// [`read_line`](Self::read_line), appending the line to what `buf`
    /// holds (the check gathers lines one after the other). After an
    /// error, what was appended is unspecified.
    fn append_line(&mut self, buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError>;
    /// Continues reading at `pos` (a value returned by `read_line`).
    fn seek(&mut self, pos: SourcePos) -> Result<(), SourceError>;
    /// Whether `seek` works (jumps need it).
    fn can_seek(&self) -> bool {
        true
    }
}

/// A program held in memory: borrowed ([`StrSource`]) or owned
/// ([`OwnedSource`]).
#[derive(Clone, Debug)]
pub struct TextSource<T> {
    text: T,
    offset: usize,
    line: u32,
    /// longest accepted line, bytes (as [`ReaderSource`]'s)
    max_line: usize,
}

/// A program borrowed from a string.
pub type StrSource<'a> = TextSource<&'a [u8]>;
/// A program owned by its source (it outlives the request that brought it).
pub type OwnedSource = TextSource<Vec<u8>>;

impl<'a> TextSource<&'a [u8]> {
    pub fn new(text: &'a str) -> Self {
        Self::from_bytes(text.as_bytes())
    }
    pub fn from_bytes(text: &'a [u8]) -> Self {
        TextSource {
            text,
            offset: 0,
            line: 0,
            max_line: usize::MAX - 2,
        }
    }
}

impl TextSource<Vec<u8>> {
    pub fn owned(text: Vec<u8>) -> Self {
        TextSource {
            text,
            offset: 0,
            line: 0,
            max_line: usize::MAX - 2,
        }
    }
}

impl<T> TextSource<T> {
    /// Refuses lines longer than `max_line` bytes (the machine's
    /// `limits.max_line_bytes`) with the error [`ReaderSource`] gives, at
    /// the same lengths. Unbounded by default.
    pub fn with_max_line(mut self, max_line: usize) -> Self {
        self.max_line = max_line.min(usize::MAX - 2);
        self
    }
}

/// Removes a trailing `\r` (CRLF files).
pub fn trim_line_end(buf: &mut Vec<u8>) {
    trim_line_end_from(buf, 0);
}

/// [`trim_line_end`] on the bytes of `buf` from `start` on.
fn trim_line_end_from(buf: &mut Vec<u8>, start: usize) {
    while buf.len() > start && matches!(buf.last(), Some(b'\n') | Some(b'\r')) {
        buf.pop();
    }
}

/// The first `\n` in `hay`, eight bytes at a time: lines are short, and
/// for a few dozen bytes this beats a call into a vectorised search.
#[inline]
fn find_newline(hay: &[u8]) -> Option<usize> {
    const ONES: u64 = 0x0101_0101_0101_0101;
    let mut chunks = hay.chunks_exact(8);
    let mut at = 0;
    for c in &mut chunks {
        let mut b = [0u8; 8];
        b.copy_from_slice(c);
        // a zero byte where `\n` was; the lowest flagged byte is the first
        // zero (a borrow only flags bytes above a zero)
        let x = u64::from_le_bytes(b) ^ (u64::from(b'\n') * ONES);
        let zero = x.wrapping_sub(ONES) & !x & (0x80 * ONES);
        if zero != 0 {
            return Some(at + (zero.trailing_zeros() / 8) as usize);
        }
        at += 8;
    }
    chunks
        .remainder()
        .iter()
        .position(|&b| b == b'\n')
        .map(|p| at + p)
}

impl<T: AsRef<[u8]>> ProgramSource for TextSource<T> {
    fn append_line(&mut self, buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError> {
        let start = buf.len();
        let text = self.text.as_ref();
        if self.offset >= text.len() {
            return Ok(None);
        }
        let rest = &text[self.offset..];
        let end = find_newline(rest);
        let (line, next) = match end {
            Some(e) => (&rest[..e], self.offset + e + 1),
            None => (rest, text.len()),
        };
        self.line += 1;
        // ReaderSource reads at most max_line + 2 bytes looking for the
        // line end: a line (without it) of max_line + 1 bytes passes
        if line.len() > self.max_line + 1 {
            self.offset = next;
            return Err(SourceError(format!(
                "line {} is longer than {} bytes",
                self.line, self.max_line
            )));
        }
        buf.extend_from_slice(line);
        trim_line_end_from(buf, start);
        let pos = SourcePos {
            offset: self.offset as u64,
            line: self.line,
        };
        self.offset = next;
        Ok(Some(pos))
    }

    fn seek(&mut self, pos: SourcePos) -> Result<(), SourceError> {
        if pos.offset as usize > self.text.as_ref().len() || pos.line == 0 {
            return Err(SourceError(format!("cannot seek to offset {}", pos.offset)));
        }
        self.offset = pos.offset as usize;
        self.line = pos.line - 1;
        Ok(())
    }
}

/// A program read from any `BufRead + Seek` (a file), one line at a time, so
/// a large program never sits in memory as a whole.
pub struct ReaderSource<R> {
    reader: R,
    offset: u64,
    line: u32,
    max_line: usize,
}

impl<R: std::io::BufRead + std::io::Seek> ReaderSource<R> {
    /// `max_line`: longest accepted line in bytes; a longer one is an error.
    pub fn new(reader: R, max_line: usize) -> Self {
        ReaderSource {
            reader,
            offset: 0,
            line: 0,
            max_line,
        }
    }
}

impl<R: std::io::BufRead + std::io::Seek> ProgramSource for ReaderSource<R> {
    fn append_line(&mut self, buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError> {
        // the usual case: the whole line, with its end, is in the reader's
        // buffer (what the general loop below does with it, in one go)
        let limit = self.max_line.saturating_add(2);
        match self.reader.fill_buf() {
            Ok(avail) => {
                let room = &avail[..avail.len().min(limit)];
                if let Some(i) = find_newline(room) {
                    let mut end = i;
                    while end > 0 && room[end - 1] == b'\r' {
                        end -= 1;
                    }
                    buf.extend_from_slice(&room[..end]);
                    self.reader.consume(i + 1);
                    self.line += 1;
                    let pos = SourcePos {
                        offset: self.offset,
                        line: self.line,
                    };
                    self.offset += i as u64 + 1;
                    return Ok(Some(pos));
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(SourceError(e.to_string())),
        }
        self.append_line_slowly(buf)
    }

    fn seek(&mut self, pos: SourcePos) -> Result<(), SourceError> {
        self.reader
            .seek(std::io::SeekFrom::Start(pos.offset))
            .map_err(|e| SourceError(e.to_string()))?;
        self.offset = pos.offset;
        self.line = pos.line.saturating_sub(1);
        Ok(())
    }
}

impl<R: std::io::BufRead + std::io::Seek> ReaderSource<R> {
    /// [`ProgramSource::append_line`] in general: a line across the
    /// reader's buffers, too long, or the last without a line end.
    fn append_line_slowly(&mut self, buf: &mut Vec<u8>) -> Result<Option<SourcePos>, SourceError> {
        let start = buf.len();
        // `read_until(b'\n')` on `take(limit)`, searching the reader's
        // buffer directly
        let limit = self.max_line as u64 + 2;
        let mut n = 0u64;
        while n < limit {
            let avail = match self.reader.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(SourceError(e.to_string())),
            };
            if avail.is_empty() {
                break;
            }
            let room = &avail[..avail.len().min((limit - n) as usize)];
            let (used, found) = match find_newline(room) {
                Some(i) => (i + 1, true),
                None => (room.len(), false),
            };
            buf.extend_from_slice(&room[..used]);
            self.reader.consume(used);
            n += used as u64;
            if found {
                break;
            }
        }
        if n == 0 {
            return Ok(None);
        }
        self.line += 1;
        if buf.last() != Some(&b'\n') && n == limit {
            return Err(SourceError(format!(
                "line {} is longer than {} bytes",
                self.line, self.max_line
            )));
        }
        let pos = SourcePos {
            offset: self.offset,
            line: self.line,
        };
        self.offset += n;
        trim_line_end_from(buf, start);
        Ok(Some(pos))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn str_source_lines_and_seek() {
        let mut s = StrSource::new("N10 G00\r\n\nN30 X1");
        let mut b = Vec::new();
        let p1 = s.read_line(&mut b).unwrap().unwrap();
        assert_eq!((p1.line, b.as_slice()), (1, &b"N10 G00"[..]));
        let p2 = s.read_line(&mut b).unwrap().unwrap();
        assert_eq!((p2.line, b.len()), (2, 0));
        let p3 = s.read_line(&mut b).unwrap().unwrap();
        assert_eq!((p3.line, p3.offset, b.as_slice()), (3, 10, &b"N30 X1"[..]));
        assert!(s.read_line(&mut b).unwrap().is_none());
        s.seek(p1).unwrap();
        assert_eq!(s.read_line(&mut b).unwrap().unwrap(), p1);
    }

    #[test]
    fn newlines_found_eight_bytes_at_a_time_are_the_first() {
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..100_000 {
            crate::xorshift64(&mut x);
            let len = (x % 40) as usize;
            // newlines rare or frequent, next to every byte value
            let hay: Vec<u8> = (0..len)
                .map(|k| {
                    let b = (x.rotate_left(k as u32 * 7) & 0xFF) as u8;
                    if b.is_multiple_of((2 + (x >> 60)) as u8) {
                        b'\n'
                    } else {
                        b
                    }
                })
                .collect();
            assert_eq!(
                find_newline(&hay),
                hay.iter().position(|&b| b == b'\n'),
                "{hay:?}"
            );
        }
    }

    #[test]
    fn lines_are_appended_and_trimmed_alone() {
        let text = "N1\r\n\r\nN3\n";
        let mut r = ReaderSource::new(std::io::Cursor::new(text.as_bytes()), 100);
        let mut s = StrSource::new(text);
        for src in [&mut r as &mut dyn ProgramSource, &mut s] {
            // what the buffer held before stays, line ends and all
            let mut buf = b"X\r".to_vec();
            assert_eq!(src.append_line(&mut buf).unwrap().unwrap().line, 1);
            assert_eq!(buf, b"X\rN1");
            assert_eq!(src.append_line(&mut buf).unwrap().unwrap().line, 2);
            assert_eq!(buf, b"X\rN1");
            buf.push(b'\r');
            assert_eq!(src.append_line(&mut buf).unwrap().unwrap().offset, 6);
            assert_eq!(buf, b"X\rN1\rN3");
            assert!(src.append_line(&mut buf).unwrap().is_none());
        }
    }

    #[test]
    fn reader_source_matches_str_source() {
        let text = "N1 X1\nN2 X2\r\nN3 X3";
        let mut r = ReaderSource::new(std::io::Cursor::new(text.as_bytes()), 100);
        let mut s = StrSource::new(text);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        loop {
            let pa = r.read_line(&mut a).unwrap();
            let pb = s.read_line(&mut b).unwrap();
            assert_eq!(pa, pb);
            assert_eq!(a, b);
            if pa.is_none() {
                break;
            }
        }
        let mut r = ReaderSource::new(std::io::Cursor::new(b"X123456789\n".as_slice()), 4);
        let err = r.read_line(&mut a).unwrap_err();
        assert_eq!(err.0, "line 1 is longer than 4 bytes");
    }

    #[test]
    fn text_source_bounds_lines_as_reader_source() {
        // the same lines accepted and refused, with or without line ends
        for n in 0..12 {
            for end in ["", "\n", "\r\n"] {
                let text = format!("N1\n{}{end}N3\n", "X".repeat(n));
                let mut r = ReaderSource::new(std::io::Cursor::new(text.as_bytes()), 6);
                let mut s = StrSource::new(&text).with_max_line(6);
                let (mut a, mut b) = (Vec::new(), Vec::new());
                for _ in 0..2 {
                    let (pa, pb) = (r.read_line(&mut a), s.read_line(&mut b));
                    assert_eq!(pa, pb, "{text:?}");
                    if pa.is_err() {
                        break;
                    }
                    assert_eq!(a, b);
                }
            }
        }
        let mut s = OwnedSource::owned(b"X12345\n".to_vec()).with_max_line(4);
        let err = s.read_line(&mut Vec::new()).unwrap_err();
        assert_eq!(err.0, "line 1 is longer than 4 bytes");
        assert!(s.read_line(&mut Vec::new()).unwrap().is_none());
    }
}
