//! The lexer/parser: one line of text becomes one [`Block`] of words, each
//! with its column. The dialect decides the comment and block-end syntax;
//! which words mean what is the interpreter's business.

use crate::diag::Diagnostic;
use crate::dialect::Dialect;
use arrayvec::ArrayVec;

/// Most words one block may hold.
pub const MAX_WORDS: usize = 32;
/// Largest magnitude of a number in a program.
pub const MAX_NUMBER: f64 = 1.0e9;

/// One address word such as `X-0.5`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Word {
    /// upper-case address letter
    pub letter: u8,
    pub value: f64,
    /// 1-based column of the letter
    pub col: u32,
    /// length of the word's text in bytes
    pub len: u32,
    /// the number was written without a decimal point
    pub integer: bool,
}

impl Word {
    /// The value as a whole number, if it is one (e.g. `G01`, `N120`).
    #[inline]
    pub fn as_int(&self) -> Option<i64> {
        // Within ±MAX_NUMBER the cast truncates exactly, so the round trip
        // is equal just when the fraction is zero (no `fract` call needed);
        // NaN and infinities fail the range test.
        if self.value.abs() <= MAX_NUMBER {
            let n = self.value as i64;
            if n as f64 == self.value {
                return Some(n);
            }
        }
        None
    }
}

/// One line of the program.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Block {
    pub line: u32,
    pub words: ArrayVec<Word, MAX_WORDS>,
    /// the line held a comment
    pub has_comment: bool,
}

impl Block {
    /// No words (blank, comment only). An `N` number alone also makes an
    /// empty block in `cnc836`; see [`Block::is_empty_block`].
    pub fn is_blank(&self) -> bool {
        self.words.is_empty()
    }
    /// Nothing but an optional N number and comment.
    pub fn is_empty_block(&self) -> bool {
        self.words.iter().all(|w| w.letter == b'N')
    }
    /// The `N` number, if any.
    pub fn block_no(&self) -> Option<u64> {
        block_no(&self.words)
    }
}

/// The `N` number among `words`, if any.
#[inline]
pub(crate) fn block_no(words: &[Word]) -> Option<u64> {
    words
        .iter()
        .find(|w| w.letter == b'N')
        .and_then(|w| w.as_int())
        .and_then(|n| u64::try_from(n).ok())
}

/// Parses one line into `block` (reused to avoid allocation). On a syntax
/// error returns the diagnostic for the first bad character; `block` then
/// holds the words before it.
pub fn parse_line(
    dialect: Dialect,
    line_no: u32,
    text: &[u8],
    block: &mut Block,
) -> Result<(), Diagnostic> {
    block.line = line_no;
    block.words.clear();
    block.has_comment = false;
    parse_words(
        dialect,
        line_no,
        text,
        &mut block.words,
        &mut block.has_comment,
    )
}

/// Where [`parse_words`] puts the words of a line.
pub(crate) trait WordList {
    /// Adds a word; false (and nothing added) if the line has
    /// [`MAX_WORDS`] already.
    fn add(&mut self, word: Word) -> bool;
}

impl WordList for ArrayVec<Word, MAX_WORDS> {
    #[inline]
    fn add(&mut self, word: Word) -> bool {
        self.try_push(word).is_ok()
    }
}

/// The words of a line appended to those of the lines before it (the
/// check's batches of lines), from index `start` on.
pub(crate) struct Appended<'a> {
    pub words: &'a mut Vec<Word>,
    pub start: usize,
}

impl WordList for Appended<'_> {
    #[inline]
    fn add(&mut self, word: Word) -> bool {
        if self.words.len() - self.start >= MAX_WORDS {
            return false;
        }
        self.words.push(word);
        true
    }
}

/// [`parse_line`], putting the words into `words` and setting
/// `has_comment` if the line has a comment.
pub(crate) fn parse_words(
    dialect: Dialect,
    line_no: u32,
    text: &[u8],
    words: &mut impl WordList,
    has_comment: &mut bool,
) -> Result<(), Diagnostic> {
    let comment = dialect.comment_char();
    let block_end = dialect.block_end_char();
    let n = text.len();
    let mut i = 0usize;
    let err = |i: usize, len: usize, msg: String| {
        let mut d = Diagnostic::new(line_no, i as u32 + 1, len as u32, msg);
        d.source = String::from_utf8_lossy(text).into_owned();
        d
    };
    // A `%` line (ISO program start/end marker such as `%PART G71`) is
    // skipped. (A line that starts with a letter, nearly all, is not one.)
    if !text.first().is_some_and(u8::is_ascii_alphabetic) {
        let first = text.iter().position(|b| !b.is_ascii_whitespace());
        if let Some(f) = first {
            if text[f] == b'%' {
                return Ok(());
            }
        }
    }
    let mut ended = false;
    while i < n {
        let c = text[i];
        // A word, the common case, first: a letter is never blank, a
        // comment or the block end, so testing it first changes nothing.
        if c.is_ascii_alphabetic() && !ended {
            let (word, end) = match lex_word(text, i) {
                Some(w) => w,
                None => lex_word_slowly(text, i).map_err(|(at, len, msg)| err(at, len, msg))?,
            };
            if !words.add(word) {
                return Err(err(
                    i,
                    end - i,
                    format!("too many words in one block (at most {MAX_WORDS})"),
                ));
            }
            i = end;
            continue;
        }
        if c == b' ' || c == b'\t' {
            i += 1;
            continue;
        }
        if c == b'\r' {
            // (a line's own CRLF end is gone: a CR left inside it is a
            // line end of an old Mac file, whose blocks would run together)
            return Err(err(
                i,
                1,
                "carriage return inside a line: lines end with LF or CRLF (a file with CR-only line ends must be converted)".into(),
            ));
        }
        if c == comment {
            *has_comment = true;
            break;
        }
        if ended {
            return Err(err(
                i,
                char_len(text, i),
                format!(
                    "text after the block end '*': expected only a comment ('{}') or nothing",
                    comment as char
                ),
            ));
        }
        if Some(c) == block_end {
            ended = true;
            i += 1;
            continue;
        }
        let hint = if c == b'"' || c == b';' || c == b'(' {
            format!("; comments in {dialect} start with '{}'", comment as char)
        } else if c == b'*' {
            format!("; '*' ends a block only in heidenhain, not in {dialect}")
        } else {
            String::new()
        };
        return Err(err(
            i,
            char_len(text, i),
            format!(
                "unexpected character '{}': expected an address letter and a number{hint}",
                char_at(text, i)
            ),
        ));
    }
    Ok(())
}

/// The word at `start` (a letter) and where it ends, when it is one of
/// the usual kind: a sign, at most 9 digits before the point and 19 in all,
/// a mantissa an `f64` holds exactly. Anything else is left to
/// [`lex_word_slowly`], which gives the same word for these.
#[inline(always)]
fn lex_word(text: &[u8], start: usize) -> Option<(Word, usize)> {
    // (an ASCII letter: clearing bit 5 makes it upper case)
    let letter = text[start] & !0x20;
    let mut i = start + 1;
    let mut neg = false;
    match text.get(i) {
        Some(b'-') => {
            neg = true;
            i += 1;
        }
        Some(b'+') => i += 1,
        _ => {}
    }
    let (end, mantissa, digits, frac_digits, dot) = lex_number(text, i);
    let int_digits = digits - frac_digits;
    // 1..=19 digits, at most 9 before the point (so at most 10^9 in
    // magnitude: within MAX_NUMBER), the mantissa exact in an f64
    if digits.wrapping_sub(1) >= 19 || int_digits > 9 || mantissa > 1 << 53 {
        return None;
    }
    let v = mantissa as f64 / EXACT_POW10[frac_digits as usize];
    let word = Word {
        letter,
        value: if neg { -v } else { v },
        col: start as u32 + 1,
        len: (end - start) as u32,
        integer: !dot,
    };
    Some((word, end))
}

/// The word at `start` (a letter) and where it ends, or an error: (column
/// index, length, message).
#[cold]
#[inline(never)]
fn lex_word_slowly(text: &[u8], start: usize) -> Result<(Word, usize), (usize, usize, String)> {
    let n = text.len();
    let letter = text[start].to_ascii_uppercase();
    let mut i = start + 1;
    let num_start = i;
    if i < n && (text[i] == b'+' || text[i] == b'-') {
        i += 1;
    }
    let digits_start = i;
    // digits [. digits]: where it ends, all digits as one integer
    // (meaningful only for up to 19 digits), how many digits, how
    // many after the point, and whether there is a point
    let (end, mantissa, digits, frac_digits, dot) = lex_number(text, i);
    i = end;
    if digits == 0 {
        let what = if i > digits_start {
            // (a point alone: the caret is on it)
            "'.' without a digit".to_string()
        } else if i < n {
            format!("'{}'", char_at(text, i))
        } else {
            "the end of the line".to_string()
        };
        let at = if i > digits_start { digits_start } else { i };
        return Err((
            at.min(n.saturating_sub(1)).max(start),
            1,
            format!(
                "expected a number after address '{}', found {what}",
                letter as char
            ),
        ));
    }
    let value = match exact_decimal(mantissa, digits, frac_digits) {
        Some(v) if text[num_start] == b'-' => -v,
        Some(v) => v,
        // Safe: the slice holds only ASCII sign, digits and one dot.
        None => std::str::from_utf8(&text[num_start..i])
            .unwrap_or("0")
            .parse()
            .unwrap_or(f64::INFINITY),
    };
    if !value.is_finite() || value.abs() > MAX_NUMBER {
        return Err((
            start,
            i - start,
            format!(
                "number out of range after '{}': at most {} in magnitude",
                letter as char, MAX_NUMBER as u64
            ),
        ));
    }
    let word = Word {
        letter,
        value,
        col: start as u32 + 1,
        len: (i - start) as u32,
        integer: !dot,
    };
    Ok((word, i))
}

/// A lexed number: (end, mantissa, digits, fraction digits, has a point).
type Lexed = (usize, u64, u32, u32, bool);

/// Lexes `digits [. [digits]]` from `i`.
#[inline]
fn lex_number(text: &[u8], mut i: usize) -> Lexed {
    let start = i;
    let mut mantissa = 0u64;
    while let Some(d) = text.get(i).filter(|d| d.is_ascii_digit()) {
        mantissa = mantissa.wrapping_mul(10).wrapping_add((d - b'0') as u64);
        i += 1;
    }
    let mut digits = (i - start) as u32;
    let dot = text.get(i) == Some(&b'.');
    let mut frac_digits = 0;
    if dot {
        i += 1;
        let frac_start = i;
        while let Some(d) = text.get(i).filter(|d| d.is_ascii_digit()) {
            mantissa = mantissa.wrapping_mul(10).wrapping_add((d - b'0') as u64);
            i += 1;
        }
        frac_digits = (i - frac_start) as u32;
        digits += frac_digits;
    }
    (i, mantissa, digits, frac_digits, dot)
}

/// Powers of ten that an `f64` holds exactly (5^22 < 2^53).
const EXACT_POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The value of an unsigned decimal `mantissa / 10^frac_digits` (written
/// with `digits` digits), when it can be had with one division: Clinger's
/// fast path. The mantissa (below 2^53) and the power of ten (at most 10^22)
/// are both exact `f64`s, and IEEE division rounds correctly, so the result
/// is the correctly rounded value of the decimal: bit for bit what
/// `str::parse::<f64>` returns. `None` (more than 19 digits, a mantissa
/// over 2^53, more than 22 decimals) leaves the number to `str::parse`.
#[inline]
fn exact_decimal(mantissa: u64, digits: u32, frac_digits: u32) -> Option<f64> {
    if digits <= 19 && mantissa <= 1 << 53 && frac_digits <= 22 {
        Some(mantissa as f64 / EXACT_POW10[frac_digits as usize])
    } else {
        None
    }
}

fn char_len(text: &[u8], i: usize) -> usize {
    // (a whole UTF-8 character, else the one byte: 0xFF is no character's
    // start, and a cut-off sequence is not a character)
    let rest = &text[i..];
    let l = match rest[0] {
        0x00..=0x7F => 1,
        0xC2..=0xDF => 2,
        0xE0..=0xEF => 3,
        0xF0..=0xF4 => 4,
        _ => return 1,
    };
    match rest.get(..l).map(std::str::from_utf8) {
        Some(Ok(_)) => l,
        _ => 1,
    }
}

fn char_at(text: &[u8], i: usize) -> String {
    let l = char_len(text, i);
    let Ok(s) = std::str::from_utf8(&text[i..i + l]) else {
        // a byte that is no character: its value
        return format!("\\x{:02X}", text[i]);
    };
    if s.chars().all(|c| !c.is_control()) {
        s.to_string()
    } else {
        s.escape_debug().to_string()
    }
}

#[cfg(test)]
#[allow(clippy::bool_comparison)]
mod tests {
    use super::*;

    fn p(d: Dialect, s: &str) -> Result<Block, Diagnostic> {
        let mut b = Block::default();
        parse_line(d, 7, s.as_bytes(), &mut b).map(|_| b)
    }

    #[test]
    fn words_values_columns() {
        let b = p(
            Dialect::Cnc836,
            "N50 G09 g02 X10. y.5 I+100 Z-0.25 \" comment X9",
        )
        .unwrap();
        let got: Vec<(char, f64, u32)> = b
            .words
            .iter()
            .map(|w| (w.letter as char, w.value, w.col))
            .collect();
        assert_eq!(
            got,
            vec![
                ('N', 50.0, 1),
                ('G', 9.0, 5),
                ('G', 2.0, 9),
                ('X', 10.0, 13),
                ('Y', 0.5, 18),
                ('I', 100.0, 22),
                ('Z', -0.25, 28)
            ]
        );
        assert!(b.has_comment);
        assert_eq!(b.block_no(), Some(50));
        assert!(b.words[3].integer == false && b.words[1].integer);
    }

    #[test]
    fn heidenhain_star_and_semicolon() {
        let b = p(
            Dialect::Heidenhain,
            "N130 G11 G42 R+30 H+0 F300 M3 * ; to (75, 45)",
        )
        .unwrap();
        assert_eq!(b.words.len(), 7);
        assert_eq!(b.words[4].value, 0.0);
        let e = p(Dialect::Heidenhain, "N10 G01 * X5").unwrap_err();
        assert_eq!((e.line, e.col), (7, 11));
        assert!(
            e.message.starts_with("text after the block end '*'"),
            "{}",
            e.message
        );
        // the other dialect's comment is an error, with a hint
        let e = p(Dialect::Heidenhain, "N10 G01 \" hi").unwrap_err();
        assert_eq!(e.col, 9);
        assert!(
            e.message.contains("comments in heidenhain start with ';'"),
            "{}",
            e.message
        );
        let e = p(Dialect::Cnc836, "N10 G01 X1 *").unwrap_err();
        assert_eq!(e.col, 12);
    }

    #[test]
    fn errors_have_columns() {
        let e = p(Dialect::Cnc836, "N10 X").unwrap_err();
        assert_eq!(
            (e.col, e.message.as_str()),
            (
                5,
                "expected a number after address 'X', found the end of the line"
            )
        );
        let e = p(Dialect::Cnc836, "N10 X- 5").unwrap_err();
        assert_eq!(
            (e.col, e.message.as_str()),
            (7, "expected a number after address 'X', found ' '")
        );
        for line in ["N10 X. F100", "N10 X.", "N10 X-. 5"] {
            let e = p(Dialect::Cnc836, line).unwrap_err();
            assert_eq!(
                (e.col, e.message.as_str()),
                (
                    if line.contains('-') { 7 } else { 6 },
                    "expected a number after address 'X', found '.' without a digit"
                ),
                "{line}"
            );
        }
        let e = p(Dialect::Cnc836, "G01 X1 #5").unwrap_err();
        assert_eq!((e.col, e.len), (8, 1));
        assert!(e.message.starts_with("unexpected character '#'"));
        let e = p(Dialect::Cnc836, "G01 X99999999999").unwrap_err();
        assert!(
            e.message.starts_with("number out of range"),
            "{}",
            e.message
        );
        let e = p(Dialect::Cnc836, "G01 Ä").unwrap_err();
        assert_eq!((e.col, e.len), (5, 2));
        let long = "X1 ".repeat(40);
        let e = p(Dialect::Cnc836, &long).unwrap_err();
        assert!(e.message.starts_with("too many words"));
    }

    /// A byte that is no UTF-8 character is named by its value, one byte
    /// long (0xFF once took the next two characters with it: '�Y2').
    #[test]
    fn a_byte_that_is_no_character_is_named_by_its_value() {
        let mut b = Block::default();
        let e = parse_line(Dialect::Cnc836, 1, b"G00 X1\xffY2", &mut b).unwrap_err();
        assert_eq!((e.col, e.len), (7, 1));
        assert!(
            e.message
                .starts_with("unexpected character '\\xFF': expected an address letter"),
            "{}",
            e.message
        );
        // a whole UTF-8 character is one, however many bytes
        let e = p(Dialect::Cnc836, "G00 X1 é").unwrap_err();
        assert_eq!((e.col, e.len), (8, 2));
        assert!(
            e.message.starts_with("unexpected character 'é'"),
            "{}",
            e.message
        );
    }

    /// A CR inside a line (CR-only line ends, an old Mac file) is an error:
    /// as a blank it ran the file's blocks together into one, and an M30
    /// among them ended nothing. A CRLF line's own end is trimmed before.
    #[test]
    fn a_carriage_return_inside_a_line_is_an_error() {
        let e = p(Dialect::Cnc836, "G00 X10\rM30\rY10").unwrap_err();
        assert_eq!(e.col, 8);
        assert_eq!(
            e.message,
            "carriage return inside a line: lines end with LF or CRLF (a file with CR-only line ends must be converted)"
        );
        assert!(p(Dialect::Heidenhain, "N10 G00 X+10 *\r; note").is_err());
        // a comment may hold anything
        assert!(p(Dialect::Cnc836, "G00 X10 \"a\rb").is_ok());
    }

    #[test]
    fn numbers_match_str_parse() {
        // every number goes through the fast path or str::parse; both must
        // give the same bits
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "+0",
            "0.",
            "-0.",
            ".0",
            "-.0",
            "1",
            "1.",
            ".5",
            "+.5",
            "-.5",
            "0.1",
            "0.2",
            "0.3",
            "-1.2345",
            "123456789",
            "999999999.9999999",
            "9007199254740992",
            "9007199254740993",
            "0.9007199254740993",
            "9999999999999999999",
            "0.0000000000000000000001",
            "0.00000000000000000000001",
            "00000000000000000000000001.5",
            "1.00000000000000000000000000000000000001",
            "2.675",
            "100.0001",
            "0.30000000000000004",
            "4.35",
            "8.325",
            "1000000000",
            "1000000000.0000001",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // pseudo-random decimals of every shape
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..20_000 {
            crate::xorshift64(&mut x);
            let int_len = (x % 12) as usize;
            let frac_len = ((x >> 8) % 24) as usize;
            let digs = format!("{:020}{:020}", x >> 1, x.rotate_left(29) >> 1);
            let mut s = String::new();
            if x & (1 << 40) != 0 {
                s.push('-');
            }
            s.push_str(&digs[..int_len]);
            if frac_len > 0 || int_len == 0 {
                s.push('.');
                s.push_str(&digs[12..12 + frac_len.max(1)]);
            }
            cases.push(s);
        }
        for c in &cases {
            let want: f64 = c.parse().unwrap();
            let b = p(Dialect::Cnc836, &format!("X{c}"));
            match b {
                Ok(b) => assert_eq!(b.words[0].value.to_bits(), want.to_bits(), "X{c}"),
                Err(e) => assert!(
                    want.abs() > MAX_NUMBER && e.message.starts_with("number out of range"),
                    "X{c}: {}",
                    e.message
                ),
            }
        }
    }

    #[test]
    fn usual_words_lex_as_every_word_does() {
        // where the quick lexer takes a word, the general one makes the
        // same word of it (bit for bit) and ends at the same place
        let alphabet = b"0123456789012345678901234567890123456789..-+-+xX ;\xc3";
        let mut x = 0x0123_4567_89AB_CDEFu64;
        let mut next = move |n: usize| (crate::xorshift64(&mut x) % n as u64) as usize;
        let mut taken = 0;
        for _ in 0..300_000 {
            let len = 1 + next(30);
            let mut text: Vec<u8> = (0..len).map(|_| alphabet[next(alphabet.len())]).collect();
            text[0] = if next(2) == 0 { b'X' } else { b'g' };
            if let Some((w, end)) = lex_word(&text, 0) {
                taken += 1;
                let (want, want_end) = lex_word_slowly(&text, 0).unwrap();
                assert_eq!(
                    (w.letter, w.value.to_bits(), w.col, w.len, w.integer, end),
                    (
                        want.letter,
                        want.value.to_bits(),
                        want.col,
                        want.len,
                        want.integer,
                        want_end
                    ),
                    "{:?}",
                    String::from_utf8_lossy(&text)
                );
            }
        }
        assert!(taken > 100_000, "{taken}");
    }

    #[test]
    fn empty_and_marker_lines() {
        assert!(p(Dialect::Cnc836, "").unwrap().is_blank());
        assert!(p(Dialect::Cnc836, "N30  \" only a number")
            .unwrap()
            .is_empty_block());
        assert!(p(Dialect::Heidenhain, "%PART G71 *").unwrap().is_blank());
    }
}
