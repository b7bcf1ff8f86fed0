//! The interpreter: blocks in, canonical commands out (LinuxCNC's seam
//! between interpreter and motion, see [`crate::canon`]). It keeps the modal
//! state, validates every word, records every error (and keeps going, so
//! one check reports them all), and holds only the current block: memory
//! does not grow with the program. It plans no motion: its commands go to
//! a [`Canon`](crate::canon::Canon) (the pipeline's compensation and blend
//! stages), and a G33 block's run-in and deceleration are fitted by
//! [`crate::thread`].
//!
//! One file per concern, each adding the methods of its concern to the one
//! [`Interpreter`] type (`state.rs` holds its fields):
//!
//! | file | concern |
//! |---|---|
//! | `state.rs` | the state, errors, the commands handed on |
//! | `run.rs` | lines and blocks, in their order |
//! | `words.rs` | a block's words sorted by meaning (core and dialect) |
//! | `modal.rs` | the modal state |
//! | `motion.rs` | lines, arcs, dwells, feed, targets, travel limits |
//! | `tools.rs` | T and G40-G42 |
//! | `helix.rs` | the helix (G09/G10/G98 in cnc836) |
//! | `loops.rs` | jumps and repeats (G73 in cnc836) |
//! | `threads.rs` | thread blocks (G33 in cnc836) |
//! | `polar.rs` | polar coordinates about a pole (HEIDENHAIN) |
//!
//! The concerns act on the meanings a dialect's rules give its words
//! ([`crate::dialect::Meaning`]), never on the dialect's name.

mod helix;
mod loops;
mod modal;
mod motion;
mod polar;
mod run;
mod state;
mod threads;
mod tools;
mod words;

pub use modal::{Modal, Motion, SpindleDir};
pub use motion::ARC_TOLERANCE_MM;
pub use state::Interpreter;
