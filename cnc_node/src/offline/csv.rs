//! `cnc simulate --csv`: one row per sample.

use super::sim::{SimSummary, Step};
use super::sink::Sink;
use cnc_core::Machine;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Writes one row per step: `t`, the setpoint of every joint, then its
/// simulated actual position (s, mm), under a header row
/// `t,<axis>_set...,<axis>_act...`.
pub struct CsvSink<W: Write> {
    w: W,
    num: ryu::Buffer,
    line: String,
}

impl CsvSink<BufWriter<File>> {
    /// Creates (truncates) the file `path` and writes the header row.
    pub fn create(path: &Path, machine: &Machine) -> Result<Self, String> {
        let f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        CsvSink::new(BufWriter::with_capacity(1 << 16, f), machine)
    }
}

impl<W: Write> CsvSink<W> {
    /// Rows into any writer; writes the header row.
    pub fn new(mut w: W, machine: &Machine) -> Result<Self, String> {
        let names: Vec<&str> = machine.axes.iter().map(|a| a.name.as_str()).collect();
        let mut head = String::from("t");
        for n in &names {
            head.push_str(&format!(",{n}_set"));
        }
        for n in &names {
            head.push_str(&format!(",{n}_act"));
        }
        writeln!(w, "{head}").map_err(|e| e.to_string())?;
        Ok(CsvSink {
            w,
            num: ryu::Buffer::new(),
            line: String::with_capacity(96),
        })
    }

    /// The writer (after the run: flushed by [`Sink::finish`]).
    pub fn into_inner(self) -> W {
        self.w
    }
}

impl<W: Write> Sink for CsvSink<W> {
    fn step(&mut self, st: &Step) -> Result<(), String> {
        let line = &mut self.line;
        line.clear();
        line.push_str(self.num.format(st.sample.t));
        for v in st.setpoints.iter().chain(st.actual.iter()) {
            line.push(',');
            line.push_str(self.num.format(*v));
        }
        line.push('\n');
        self.w
            .write_all(line.as_bytes())
            .map_err(|e| format!("writing the CSV: {e}"))
    }

    fn finish(&mut self, _: &SimSummary) -> Result<(), String> {
        self.w.flush().map_err(|e| format!("writing the CSV: {e}"))
    }
}
