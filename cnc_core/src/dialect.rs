//! The G-code dialects. A program is parsed and interpreted in exactly one
//! dialect, chosen by the caller (never guessed per block).

use std::fmt;
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Dialect {
    /// MEFI CNC836 / CNC8x6: `"` comments.
    Cnc836,
    /// HEIDENHAIN TNC 410 ISO: `;` comments, optional `*` block end.
    Heidenhain,
}

impl Dialect {
    pub const ALL: [Dialect; 2] = [Dialect::Cnc836, Dialect::Heidenhain];

    pub fn id(self) -> &'static str {
        match self {
            Dialect::Cnc836 => "cnc836",
            Dialect::Heidenhain => "heidenhain",
        }
    }

    /// The character that starts a comment running to the end of the line.
    pub fn comment_char(self) -> u8 {
        match self {
            Dialect::Cnc836 => b'"',
            Dialect::Heidenhain => b';',
        }
    }

    /// The explicit block-end character, if the dialect has one.
    pub fn block_end_char(self) -> Option<u8> {
        match self {
            Dialect::Cnc836 => None,
            Dialect::Heidenhain => Some(b'*'),
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

impl FromStr for Dialect {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "cnc836" => Ok(Dialect::Cnc836),
            "heidenhain" => Ok(Dialect::Heidenhain),
            _ => Err(format!(
                "unknown dialect '{s}' (expected \"cnc836\" or \"heidenhain\")"
            )),
        }
    }
}
