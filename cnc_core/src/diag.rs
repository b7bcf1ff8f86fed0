//! Errors found in a program: line, column, block number, what was expected,
//! and the source line for a snippet.

use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// 1-based line
    pub line: u32,
    /// 1-based column (byte offset + 1; everything before an error is ASCII)
    pub col: u32,
    /// length of the offending text in bytes (at least 1)
    pub len: u32,
    /// the block's N number, if it has one
    pub block_no: Option<u64>,
    pub message: String,
    /// the text of the line, for snippets (lossy UTF-8)
    pub source: String,
}

impl Diagnostic {
    pub fn new(line: u32, col: u32, len: u32, message: impl Into<String>) -> Self {
        Diagnostic {
            line,
            col: col.max(1),
            len: len.max(1),
            block_no: None,
            message: message.into(),
            source: String::new(),
        }
    }

    /// Renders the error with a source snippet (for terminals and logs).
    pub fn render(&self, origin: Option<&str>) -> String {
        use annotate_snippets::{Level, Renderer, Snippet};
        let title = self.to_string();
        if self.source.is_empty() {
            // no text to show (a line too long to read): where it is, as
            // the snippet's header gives it (an empty snippet said line 1)
            return match origin {
                Some(o) => format!("error: {title}\n --> {o}:{}:{}", self.line, self.col),
                None => format!("error: {title}"),
            };
        }
        // control characters (CR, VT, NUL, ...) shown as '?', byte for
        // byte so the columns stay: annotate-snippets splits lines at a CR
        // and then slices the text inside a character (a panic)
        let shown: String = self
            .source
            .chars()
            .flat_map(|c| {
                let bad = c.is_control() && c != '\t';
                std::iter::repeat_n(
                    if bad { '?' } else { c },
                    if bad { c.len_utf8() } else { 1 },
                )
            })
            .collect();
        let mut start = (self.col as usize - 1).min(shown.len());
        while !shown.is_char_boundary(start) {
            start -= 1;
        }
        let mut end = (start + self.len as usize).min(shown.len()).max(start);
        while !shown.is_char_boundary(end) {
            end += 1;
        }
        let mut snippet = Snippet::source(&shown)
            .line_start(self.line as usize)
            .fold(false);
        if let Some(o) = origin {
            snippet = snippet.origin(o);
        }
        let snippet = snippet.annotation(Level::Error.span(start..end).label("here"));
        let msg = Level::Error.title(&title).snippet(snippet);
        let out = Renderer::plain().render(msg).to_string();
        out
    }
}

impl fmt::Display for Diagnostic {
    /// `line L, column C: [block N10: ]message`, the contract's error format.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}, column {}: ", self.line, self.col)?;
        if let Some(n) = self.block_no {
            write!(f, "block N{n}: ")?;
        }
        f.write_str(&self.message)
    }
}

/// Formats a number of millimetres or degrees for messages: up to 4
/// decimals, trailing zeros removed.
pub fn num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_and_render() {
        let mut d = Diagnostic::new(3, 5, 3, "unknown address 'Q'");
        d.block_no = Some(30);
        d.source = "N30 Q12 X1".into();
        assert_eq!(
            d.to_string(),
            "line 3, column 5: block N30: unknown address 'Q'"
        );
        let r = d.render(Some("a.nc"));
        assert!(r.contains("a.nc:3:5"), "{r}");
        assert!(r.contains("N30 Q12 X1"), "{r}");
        assert!(r.contains("^^^"), "{r}");
        assert_eq!(num(1.25), "1.25");
        // control characters are shown as '?', the column stays
        let mut d = Diagnostic::new(1, 3, 1, "unexpected character");
        d.source = "X\r1\u{85}Y".into();
        let r = d.render(None);
        assert!(r.contains("X?1??Y"), "{r}");
        // a byte that is no UTF-8 (read as U+FFFD, 3 bytes) under the caret
        let mut d = Diagnostic::new(1, 1, 1, "unexpected character");
        d.source = String::from_utf8_lossy(b"\xef").into_owned();
        assert!(d.render(None).contains("^ here"));
        assert_eq!(num(100.0), "100");
        assert_eq!(num(-0.00001), "0");
        // no text (a line too long to read): its place, not line 1's
        let d = Diagnostic::new(
            4,
            1,
            1,
            "cannot read the program: line 4 is longer than 4096 bytes",
        );
        assert_eq!(
            d.render(Some("p.nc")),
            "error: line 4, column 1: cannot read the program: line 4 is longer than 4096 bytes\n --> p.nc:4:1"
        );
    }

    proptest::proptest! {
        /// Any line (bytes as a program may hold them, read lossily as
        /// UTF-8) and any column and length render without a panic.
        #[test]
        fn any_source_renders(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
                              col in 1u32..400, len in 1u32..50) {
            let mut d = Diagnostic::new(7, col, len, "bad");
            d.source = String::from_utf8_lossy(&bytes).into_owned();
            let r = d.render(Some("p.nc"));
            proptest::prop_assert!(r.contains("line 7"));
        }
    }
}
