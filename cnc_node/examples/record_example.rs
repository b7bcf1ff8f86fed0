//! Records an offline run to an MCAP file (what `cnc simulate --mcap` is to
//! do), for tests and CI:
//!
//!     cargo run -p cnc_node --example record_example -- OUT.mcap [PROGRAM [MACHINE]]
//!
//! PROGRAM defaults to examples/mill_pocket.nc, MACHINE (a machine file or
//! a bundled name) to `mill`; the dialect is the machine's.

use cnc_node::files::load_machine;
use cnc_node::record::record_simulation;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first() else {
        eprintln!("usage: record_example OUT.mcap [PROGRAM [MACHINE]]");
        return ExitCode::from(2);
    };
    let program = args.get(1).map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/mill_pocket.nc")
    });
    let machine = args.get(2).map(String::as_str).unwrap_or("mill");
    let run = || -> Result<(), String> {
        let m = load_machine(machine)?;
        let text =
            std::fs::read_to_string(&program).map_err(|e| format!("{}: {e}", program.display()))?;
        let name = program
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let t0 = std::time::Instant::now();
        let s = record_simulation(&m, &name, &text, m.dialect, out.as_ref())?;
        let secs = (s.end_ns - s.start_ns) as f64 * 1e-9;
        println!(
            "{out}: {} messages, {} bytes, {} chunks, {:.3} s of motion ({:.0} bytes per minute), written in {:.2} s",
            s.messages,
            s.bytes,
            s.chunks,
            secs,
            if secs > 0.0 { s.bytes as f64 / secs * 60.0 } else { 0.0 },
            t0.elapsed().as_secs_f64()
        );
        for (topic, n) in &s.topics {
            println!("  {topic}: {n}");
        }
        Ok(())
    };
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
