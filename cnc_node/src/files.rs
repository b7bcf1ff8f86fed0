//! Machine files and program files from disk: the program streamed
//! within the size limit, its dialect from its name, and a hint when the
//! machine does not fit it.

use cnc_core::machine::MachineKind;
use cnc_core::source::ReaderSource;
use cnc_core::{CheckReport, Dialect, Machine};
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

/// The dialect of a program: the one given, else the file name's (`.h`,
/// `.i`: HEIDENHAIN, as the TNC names its programs), else the machine
/// file's.
pub fn dialect_for(path: Option<&Path>, given: Option<Dialect>, machine: &Machine) -> Dialect {
    given
        .or_else(|| path.and_then(dialect_of_name))
        .unwrap_or(machine.dialect)
}

/// The dialect a file's name says: `.h`, `.i` (any case) HEIDENHAIN.
pub fn dialect_of_name(path: &Path) -> Option<Dialect> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    matches!(ext.as_str(), "h" | "i").then_some(Dialect::Heidenhain)
}

/// [`machine_hint`] for a program file (its first 64 KiB).
pub fn machine_hint_for(path: &Path, machine: &Machine, report: &CheckReport) -> Option<String> {
    use std::io::Read;
    let mut head = Vec::new();
    File::open(path)
        .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
        .ok()?;
    machine_hint(&head, machine, report)
}

/// A hint for a program refused on a machine it does not seem written
/// for: a lathe program (`T0101`-style tool words, G18, no Y) on a mill,
/// or a program that moves Y on a lathe. `text`: the program's start.
pub fn machine_hint(text: &[u8], machine: &Machine, report: &CheckReport) -> Option<String> {
    if report.ok() {
        return None;
    }
    let lathe = machine.kind == MachineKind::Lathe;
    let y_refused = report
        .errors
        .iter()
        .any(|e| e.message.starts_with("axis Y is not on this machine"));
    if lathe && y_refused {
        return Some(format!(
            "hint: the program moves Y, which the lathe '{}' does not have: is it a mill program (--machine mill)?",
            machine.name
        ));
    }
    if lathe {
        return None;
    }
    let upper: Vec<u8> = text.iter().map(u8::to_ascii_uppercase).collect();
    let four_digit_tool = digits_after(&upper, b'T').any(|n| n == 4);
    let g18 = upper.windows(3).any(|w| w == b"G18");
    let moves_y = digits_after(&upper, b'Y').any(|n| n > 0);
    if (four_digit_tool || g18) && !moves_y {
        return Some(format!(
            "hint: this looks like a lathe program ({}), checked on the mill '{}': try --machine lathe",
            if four_digit_tool {
                "T0101-style tool words"
            } else {
                "G18, no Y"
            },
            machine.name
        ));
    }
    None
}

/// The number of digits after each `letter` that starts a word (no letter
/// before it).
fn digits_after(text: &[u8], letter: u8) -> impl Iterator<Item = usize> + '_ {
    (0..text.len())
        .filter(move |&i| text[i] == letter && (i == 0 || !text[i - 1].is_ascii_alphabetic()))
        .map(move |i| {
            text[i + 1..]
                .iter()
                .take_while(|c| c.is_ascii_digit())
                .count()
        })
}

/// Whether two paths name the same file: compared canonicalized (the
/// parent directory's when the file does not exist yet), and on Unix by
/// device and inode when both exist (hard links).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    let key = |p: &Path| -> Option<std::path::PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let name = p.file_name()?;
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(parent.canonicalize().ok()?.join(name))
    };
    match (key(a), key(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc_core::source::StrSource;

    #[test]
    fn the_dialect_comes_from_the_extension_when_not_given() {
        let mill = Machine::builtin_mill();
        let d = |name: &str, given| dialect_for(Some(Path::new(name)), given, &mill);
        assert_eq!(d("part.h", None), Dialect::Heidenhain);
        assert_eq!(d("PART.H", None), Dialect::Heidenhain);
        assert_eq!(d("part.i", None), Dialect::Heidenhain);
        assert_eq!(d("part.nc", None), mill.dialect);
        assert_eq!(d("part", None), mill.dialect);
        assert_eq!(d("part.h", Some(Dialect::Cnc836)), Dialect::Cnc836);
        assert_eq!(dialect_for(None, None, &mill), mill.dialect);
    }

    #[test]
    fn a_program_on_the_wrong_machine_gets_a_hint() {
        let mill = Machine::builtin_mill();
        let lathe = Machine::builtin_lathe();
        let lathe_prog = "N10 G18 G90 M03 S1000 T0101\nN20 G00 X30 Z5\nN30 G01 X20 Z-10 F300\n";
        let r = cnc_core::check(StrSource::new(lathe_prog), mill.dialect, &mill);
        // (on the mill the program is refused: tool 101 is not in its table)
        assert!(!r.ok());
        assert_eq!(
            machine_hint(lathe_prog.as_bytes(), &mill, &r).as_deref(),
            Some("hint: this looks like a lathe program (T0101-style tool words), checked on the mill 'mill': try --machine lathe")
        );
        let mill_prog = "N10 G00 X10 Y10 Z5\n";
        let r = cnc_core::check(StrSource::new(mill_prog), lathe.dialect, &lathe);
        assert_eq!(
            machine_hint(mill_prog.as_bytes(), &lathe, &r).as_deref(),
            Some("hint: the program moves Y, which the lathe 'lathe' does not have: is it a mill program (--machine mill)?")
        );
        // a good program, or a bad one that fits its machine: no hint
        let ok = cnc_core::check(StrSource::new(mill_prog), mill.dialect, &mill);
        assert_eq!(machine_hint(mill_prog.as_bytes(), &mill, &ok), None);
        let bad = "N10 G01 X10 Y10\n";
        let r = cnc_core::check(StrSource::new(bad), mill.dialect, &mill);
        assert!(!r.ok());
        assert_eq!(machine_hint(bad.as_bytes(), &mill, &r), None);
    }
}
