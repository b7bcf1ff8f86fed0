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
    pub fn as_int(&self) -> Option<i64> {
        if self.value.fract() == 0.0 && self.value.abs() <= MAX_NUMBER {
            Some(self.value as i64)
        } else {
            None
        }
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
        self.words
            .iter()
            .find(|w| w.letter == b'N')
            .and_then(|w| w.as_int())
            .and_then(|n| u64::try_from(n).ok())
    }
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
    let comment = dialect.comment_char();
    let block_end = dialect.block_end_char();
    let n = text.len();
    let mut i = 0usize;
    let err = |i: usize, len: usize, msg: String| {
        let mut d = Diagnostic::new(line_no, i as u32 + 1, len as u32, msg);
        d.source = String::from_utf8_lossy(text).into_owned();
        d
    };
    // A `%` line (ISO program start/end marker such as `%PART G71`) is skipped.
    let first = text.iter().position(|b| !b.is_ascii_whitespace());
    if let Some(f) = first {
        if text[f] == b'%' {
            return Ok(());
        }
    }
    let mut ended = false;
    while i < n {
        let c = text[i];
        if c == b' ' || c == b'\t' || c == b'\r' {
            i += 1;
            continue;
        }
        if c == comment {
            block.has_comment = true;
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
        if c.is_ascii_alphabetic() {
            let start = i;
            let letter = c.to_ascii_uppercase();
            i += 1;
            let num_start = i;
            if i < n && (text[i] == b'+' || text[i] == b'-') {
                i += 1;
            }
            let digits_start = i;
            let mut digits = 0;
            let mut dot = false;
            while i < n {
                let d = text[i];
                if d.is_ascii_digit() {
                    digits += 1;
                } else if d == b'.' && !dot {
                    dot = true;
                } else {
                    break;
                }
                i += 1;
            }
            if digits == 0 {
                let what = if i < n {
                    format!("'{}'", char_at(text, i))
                } else {
                    "the end of the line".to_string()
                };
                let at = if i > digits_start { digits_start } else { i };
                return Err(err(
                    at.min(n.saturating_sub(1)).max(start),
                    1,
                    format!(
                        "expected a number after address '{}', found {what}",
                        letter as char
                    ),
                ));
            }
            // Safe: the slice holds only ASCII sign, digits and one dot.
            let s = std::str::from_utf8(&text[num_start..i]).unwrap_or("0");
            let value: f64 = s.parse().unwrap_or(f64::INFINITY);
            if !value.is_finite() || value.abs() > MAX_NUMBER {
                return Err(err(
                    start,
                    i - start,
                    format!(
                        "number out of range after '{}': at most {} in magnitude",
                        letter as char, MAX_NUMBER as u64
                    ),
                ));
            }
            if block.words.is_full() {
                return Err(err(
                    start,
                    i - start,
                    format!("too many words in one block (at most {MAX_WORDS})"),
                ));
            }
            block.words.push(Word {
                letter,
                value,
                col: start as u32 + 1,
                len: (i - start) as u32,
                integer: !dot,
            });
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

fn char_len(text: &[u8], i: usize) -> usize {
    let c = text[i];
    let l = if c < 0x80 {
        1
    } else if c >= 0xF0 {
        4
    } else if c >= 0xE0 {
        3
    } else {
        2
    };
    l.min(text.len() - i)
}

fn char_at(text: &[u8], i: usize) -> String {
    let l = char_len(text, i);
    let s = String::from_utf8_lossy(&text[i..i + l]);
    if s.chars().all(|c| !c.is_control()) {
        s.into_owned()
    } else {
        s.escape_debug().to_string()
    }
}

#[cfg(test)]
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

    #[test]
    fn empty_and_marker_lines() {
        assert!(p(Dialect::Cnc836, "").unwrap().is_blank());
        assert!(p(Dialect::Cnc836, "N30  \" only a number")
            .unwrap()
            .is_empty_block());
        assert!(p(Dialect::Heidenhain, "%PART G71 *").unwrap().is_blank());
    }
}
