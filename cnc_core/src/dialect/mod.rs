//! The G-code dialects. A program is parsed and interpreted in exactly one
//! dialect, chosen by the caller (never guessed per block).
//!
//! A dialect is one file here holding one [`Rules`] value: its comment
//! syntax, and which G codes and addresses beyond the shared DIN 66025 core
//! it has and what each means. The interpreter acts on those meanings
//! ([`Meaning`]), never on the dialect's name, so a third dialect is a new
//! file, a variant of [`Dialect`] and one arm in [`Dialect::rules`]; the
//! meanings it maps its words to (helix, loops, threads, polar moves) are
//! the interpreter's concerns and work in any dialect that names them.
//! `docs/dialects.md` describes both dialects.

mod cnc836;
mod heidenhain;

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

/// What a word beyond the shared core means. The interpreter's concerns
/// act on these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Meaning {
    /// helix on (cnc836 G09): arcs drag the third axis by the pitch
    HelixOn,
    /// helix pitch (cnc836 G10): the dragged axis and its pitch
    HelixPitch,
    /// helix off (cnc836 G98), alone in its block
    HelixOff,
    /// jump back and repeat (cnc836 G73 L Q)
    Jump,
    /// thread cutting synchronized with the spindle, this block only
    /// (cnc836 G33)
    Thread,
    /// a polar motion about the pole (HEIDENHAIN G10, G11, G12, G13):
    /// 0 rapid line, 1 line at feed, 2 arc clockwise, 3 arc
    /// counter-clockwise
    Polar(u8),
    /// a polar arc in the direction of the last one (HEIDENHAIN G15)
    PolarLastDirection,
    /// the pole where the tool stands (HEIDENHAIN G29)
    PoleHere,
    /// the jump's target block (cnc836 L)
    JumpTarget,
    /// the jump's repeat count (cnc836 Q)
    JumpCount,
    /// polar radius (HEIDENHAIN R)
    PolarRadius,
    /// polar angle, degrees (HEIDENHAIN H)
    PolarAngle,
}

/// One dialect's syntax and vocabulary beyond the shared core (N G M X Y Z
/// I J K F S T P; G00-G04, G17-G19, G40-G42, G61, G64, G90, G91, G94, G95;
/// M02-M06, M08, M09, M30).
#[derive(Debug)]
pub struct Rules {
    /// the name programs and messages use
    pub id: &'static str,
    /// the character that starts a comment running to the end of the line
    pub comment: u8,
    /// the explicit block-end character, if the dialect has one
    pub block_end: Option<u8>,
    /// G codes beyond the core: code, meaning, and how a second word of
    /// that meaning in one block is named ("G09 programmed twice")
    pub g_codes: &'static [(i64, Meaning, &'static str)],
    /// addresses beyond the core, in the order messages list them
    pub addresses: &'static [(u8, Meaning)],
    /// a G04 block's time may be given by F (when there is no P)
    pub dwell_time_in_f: bool,
    /// a block of centre words (I, J) with no motion sets the pole
    pub centres_set_pole: bool,
}

impl Rules {
    /// The meaning of G`code` beyond the core, and its name in messages.
    #[inline]
    pub fn g_code(&self, code: i64) -> Option<(Meaning, &'static str)> {
        self.g_codes
            .iter()
            .find(|g| g.0 == code)
            .map(|&(_, m, what)| (m, what))
    }

    /// The meaning of an address letter beyond the core.
    #[inline]
    pub fn address(&self, letter: u8) -> Option<Meaning> {
        self.addresses.iter().find(|a| a.0 == letter).map(|a| a.1)
    }

    /// The G code that means `m`, if the dialect has one.
    pub fn code_of(&self, m: Meaning) -> Option<i64> {
        self.g_codes.iter().find(|g| g.1 == m).map(|g| g.0)
    }
}

impl Dialect {
    pub const ALL: [Dialect; 2] = [Dialect::Cnc836, Dialect::Heidenhain];

    /// The dialect's rules: the one place that names every dialect.
    #[inline]
    pub fn rules(self) -> &'static Rules {
        match self {
            Dialect::Cnc836 => &cnc836::RULES,
            Dialect::Heidenhain => &heidenhain::RULES,
        }
    }

    pub fn id(self) -> &'static str {
        self.rules().id
    }

    /// The character that starts a comment running to the end of the line.
    pub fn comment_char(self) -> u8 {
        self.rules().comment
    }

    /// The explicit block-end character, if the dialect has one.
    pub fn block_end_char(self) -> Option<u8> {
        self.rules().block_end
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
        let want = s.to_ascii_lowercase();
        Dialect::ALL
            .into_iter()
            .find(|d| d.id() == want)
            .ok_or_else(|| {
                let names: Vec<String> = Dialect::ALL
                    .iter()
                    .map(|d| format!("\"{}\"", d.id()))
                    .collect();
                format!("unknown dialect '{s}' (expected {})", names.join(" or "))
            })
    }
}
