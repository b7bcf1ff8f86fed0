//! Machine files and program files from disk.

use cnc_core::source::ReaderSource;
use cnc_core::Machine;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

pub use sim_axes::machine::load_machine;

/// Opens a program for streaming, refusing files over the machine's size
/// limit before reading them.
pub fn open_program(
    path: &Path,
    machine: &Machine,
) -> Result<ReaderSource<BufReader<File>>, String> {
    let f = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let meta = f
        .metadata()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    if !meta.is_file() {
        return Err(format!("{}: not a regular file", path.display()));
    }
    let max = machine.limits.max_program_bytes;
    if meta.len() > max {
        return Err(format!(
            "{}: {} bytes is over the machine's limit of {max} bytes (limits.max_program_bytes)",
            path.display(),
            meta.len()
        ));
    }
    Ok(ReaderSource::new(
        BufReader::with_capacity(1 << 16, f),
        machine.limits.max_line_bytes,
    ))
}
