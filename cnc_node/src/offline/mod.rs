//! The offline run: a program checked once, then simulated once (executor
//! samples driving the in-process axis and spindle model, the same model
//! the simulator node uses), every [`Step`] handed to each of a list of
//! [`Sink`]s: a CSV file ([`CsvSink`]), a recording
//! ([`crate::record::SimRecorder`]), a plot's paths and thread errors
//! ([`crate::plot`]), a progress bar. `cnc simulate` with any set of
//! outputs, `cnc plot` and `cnc bag rerun` each run the program once.
//!
//! ```no_run
//! use cnc_core::source::StrSource;
//! use cnc_node::offline::{check_text, run, CsvSink, Sink};
//! let m = cnc_core::Machine::builtin_mill();
//! let text = "G1 X10 F600\nM30\n";
//! let report = check_text(&m, m.dialect, "p.nc", text, "nothing written")?;
//! let mut csv = CsvSink::create("p.csv".as_ref(), &m)?;
//! let summary = run(StrSource::new(text), m.dialect, &m, &mut [&mut csv as &mut dyn Sink])?;
//! # Ok::<(), String>(())
//! ```

mod csv;
mod sim;
mod sink;

pub use csv::CsvSink;
pub use sim::{
    encoder_reading, model_for, model_for_seed, simulate, simulate_with, SimSummary, Step,
    DRIVE_HEADROOM,
};
pub use sink::{check_text, run, run_with, Sink};
