//! Programs as the node receives them: text in the request, or a path that
//! must stay inside the machine's program directory.

use std::path::{Component, Path, PathBuf};

pub use cnc_core::source::OwnedSource;

/// Resolves `rel` inside `dir`: no absolute paths, no `..`, no symlinks
/// that lead out. Nothing is read.
pub fn resolve_in(dir: &Path, rel: &str) -> Result<PathBuf, String> {
    let p = Path::new(rel);
    if rel.is_empty() {
        return Err("program_path is empty".into());
    }
    if p.is_absolute() {
        return Err(format!(
            "program_path '{rel}' is absolute; give a path inside the program directory"
        ));
    }
    if p.components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(format!("program_path '{rel}' may not contain '..'"));
    }
    let root = dir
        .canonicalize()
        .map_err(|e| format!("program directory {}: {e}", dir.display()))?;
    let full = root
        .join(p)
        .canonicalize()
        .map_err(|_| format!("program_path '{rel}': no such file in the program directory"))?;
    if !full.starts_with(&root) {
        return Err(format!(
            "program_path '{rel}' leads out of the program directory"
        ));
    }
    if !full.is_file() {
        return Err(format!("program_path '{rel}' is not a file"));
    }
    Ok(full)
}

/// Reads a program file, refusing it unread when over `max` bytes.
pub fn read_limited(path: &Path, max: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let f = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let len = f.metadata().map_err(|e| e.to_string())?.len();
    if len > max {
        return Err(format!(
            "the program is {len} bytes, over the machine's limit of {max} bytes (limits.max_program_bytes)"
        ));
    }
    let mut v = Vec::with_capacity(len as usize);
    f.take(max + 1)
        .read_to_end(&mut v)
        .map_err(|e| e.to_string())?;
    if v.len() as u64 > max {
        return Err(format!(
            "the program grew over the limit of {max} bytes while being read"
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_stay_inside() {
        let d = std::env::temp_dir().join(format!("cnc-prog-{}", std::process::id()));
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::write(d.join("sub/a.nc"), "G00 X1\n").unwrap();
        std::fs::write(d.join("../outside.nc"), "G00 X1\n").unwrap();
        assert!(resolve_in(&d, "sub/a.nc").is_ok());
        assert!(resolve_in(&d, "./sub/a.nc").is_ok());
        assert_eq!(
            resolve_in(&d, "../outside.nc").unwrap_err(),
            "program_path '../outside.nc' may not contain '..'"
        );
        assert!(resolve_in(&d, "/etc/passwd")
            .unwrap_err()
            .contains("is absolute"));
        #[cfg(unix)]
        {
            let _ = std::fs::remove_file(d.join("link.nc"));
            std::os::unix::fs::symlink(d.join("../outside.nc"), d.join("link.nc")).unwrap();
            assert_eq!(
                resolve_in(&d, "link.nc").unwrap_err(),
                "program_path 'link.nc' leads out of the program directory"
            );
        }
        assert!(resolve_in(&d, "sub").unwrap_err().contains("is not a file"));
        assert!(resolve_in(&d, "nope.nc")
            .unwrap_err()
            .contains("no such file"));
        let e = read_limited(&d.join("sub/a.nc"), 3).unwrap_err();
        assert!(
            e.contains("7 bytes, over the machine's limit of 3 bytes"),
            "{e}"
        );
        assert_eq!(read_limited(&d.join("sub/a.nc"), 100).unwrap(), b"G00 X1\n");
    }

    #[test]
    fn owned_source_reads_lines() {
        use cnc_core::source::ProgramSource;
        let mut s = OwnedSource::owned(b"A\r\nB".to_vec());
        let mut b = Vec::new();
        assert_eq!(s.read_line(&mut b).unwrap().unwrap().line, 1);
        assert_eq!(b, b"A");
        assert_eq!(s.read_line(&mut b).unwrap().unwrap().offset, 3);
        assert_eq!(b, b"B");
        assert!(s.read_line(&mut b).unwrap().is_none());
    }
}
