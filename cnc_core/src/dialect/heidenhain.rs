//! HEIDENHAIN TNC ISO (`docs/dialects.md` §3): `;` comments, an optional
//! `*` block end; polar coordinates about a pole (G10-G13, G15, G29, the
//! pole by I/J alone, R and H), the dwell time by F.

use super::{Meaning, Rules};

/// How a second motion word in one block is named.
const MOTION: &str = "a motion G code (G00-G03, G10-G13, G15)";

pub(super) static RULES: Rules = Rules {
    id: "heidenhain",
    comment: b';',
    block_end: Some(b'*'),
    g_codes: &[
        (10, Meaning::Polar(0), MOTION),
        (11, Meaning::Polar(1), MOTION),
        (12, Meaning::Polar(2), MOTION),
        (13, Meaning::Polar(3), MOTION),
        (15, Meaning::PolarLastDirection, MOTION),
        (29, Meaning::PoleHere, "G29"),
    ],
    addresses: &[(b'R', Meaning::PolarRadius), (b'H', Meaning::PolarAngle)],
    dwell_time_in_f: true,
    centres_set_pole: true,
};
