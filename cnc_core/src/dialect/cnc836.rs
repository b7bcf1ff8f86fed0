//! MEFI CNC836 / CNC8x6 (`docs/dialects.md` §2): `"` comments; the helix
//! G09/G10/G98, jumps G73 L Q and thread cutting G33.

use super::{Meaning, Rules};

pub(super) static RULES: Rules = Rules {
    id: "cnc836",
    comment: b'"',
    block_end: None,
    g_codes: &[
        (9, Meaning::HelixOn, "G09"),
        (10, Meaning::HelixPitch, "G10"),
        (73, Meaning::Jump, "G73"),
        (33, Meaning::Thread, "G33"),
        (98, Meaning::HelixOff, "G98"),
    ],
    addresses: &[(b'L', Meaning::JumpTarget), (b'Q', Meaning::JumpCount)],
    dwell_time_in_f: false,
    centres_set_pole: false,
};
