//! `cnc plot`'s library side: programs and recordings to SVG and PNG.

use cnc_core::Machine;
use cnc_node::plot::{labels, plot_program, plot_recording};
use cnc_node::record::record_simulation;
use std::path::{Path, PathBuf};

fn example(name: &str) -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name);
    std::fs::read_to_string(p).unwrap()
}

/// Points of every `<polyline points="...">` of an SVG.
fn polylines(svg: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for part in svg.split("<polyline").skip(1) {
        let el = &part[..part.find("/>").unwrap()];
        let stroke = el
            .split("stroke=\"")
            .nth(1)
            .map(|s| s[..s.find('"').unwrap()].to_string())
            .unwrap_or_default();
        let pts = el
            .split("points=\"")
            .nth(1)
            .map(|s| s[..s.find('"').unwrap()].split_whitespace().count())
            .unwrap_or(0);
        out.push((stroke, pts));
    }
    out
}

/// The largest polyline of a colour (as plotters writes it: `#RRGGBB`).
fn largest(svg: &str, stroke: &str) -> usize {
    polylines(svg)
        .into_iter()
        .filter(|(s, _)| s.eq_ignore_ascii_case(stroke))
        .map(|(_, n)| n)
        .max()
        .unwrap_or(0)
}

const GREY: &str = "#A0A0A0";
const DARK_GREY: &str = "#3C3C3C";
const BLUE: &str = "#1F77B4";
const RED: &str = "#D62728";

/// Whether the SVG has a `<text>` element with exactly `s`.
fn has_text(svg: &str, s: &str) -> bool {
    svg.contains(&format!(">\n{s}\n</text>"))
}

fn check_svg(path: &Path, title_part: &str) -> String {
    let svg = std::fs::read_to_string(path).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(200)]);
    assert!(svg.trim_end().ends_with("</svg>"));
    for label in [
        labels::PROGRAMMED,
        labels::RAPID,
        labels::SETPOINTS,
        labels::ACTUAL,
    ] {
        assert!(has_text(&svg, label), "legend label {label}");
    }
    assert!(svg.contains(title_part), "title {title_part}");
    svg
}

#[test]
fn mill_program_to_svg() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pocket.svg");
    let m = Machine::builtin_mill();
    plot_program(
        &m,
        m.dialect,
        "mill_pocket.nc",
        &example("mill_pocket.nc"),
        &out,
    )
    .unwrap();
    if let Ok(keep) = std::env::var("CNC_PLOT_KEEP") {
        std::fs::copy(&out, Path::new(&keep).join("mill_pocket.svg")).unwrap();
    }
    let svg = check_svg(&out, "mill_pocket.nc on");
    assert!(has_text(&svg, "X mm") && has_text(&svg, "Y mm") && has_text(&svg, "Z mm"));
    assert!(has_text(&svg, "top view (XY)") && has_text(&svg, "side view (XZ)"));
    // the pocket: 4 lines and 4 arcs of 90° (2° chords) in one polyline
    let programmed = largest(&svg, GREY);
    assert!((40..2000).contains(&programmed), "programmed {programmed}");
    // setpoints and actual: the whole run, deduplicated to pixels
    for (c, what) in [(BLUE, "setpoints"), (RED, "actual")] {
        let n = largest(&svg, c);
        assert!((200..=20_001).contains(&n), "{what}: {n} points");
    }
    // dashed rapids: many short polylines (and the legend's three dashes)
    let grey_lines = polylines(&svg)
        .iter()
        .filter(|(s, _)| s == DARK_GREY)
        .count();
    assert!(grey_lines > 5, "{grey_lines}");
}

#[test]
fn lathe_program_to_svg() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("profile.svg");
    let m = Machine::builtin_lathe();
    let text = example("lathe_profile.nc");
    plot_program(&m, m.dialect, "lathe_profile.nc", &text, &out).unwrap();
    let svg = check_svg(&out, "lathe_profile.nc on");
    assert!(has_text(&svg, "Z mm") && has_text(&svg, "X (radius) mm"));
    assert!(!svg.contains("side view"));
    assert!(largest(&svg, GREY) >= 10);
    for c in [BLUE, RED] {
        let n = largest(&svg, c);
        assert!((100..=20_001).contains(&n), "{c}: {n} points");
    }
}

#[test]
fn png_output() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_lathe();
    let out = dir.path().join("profile.png");
    plot_program(
        &m,
        m.dialect,
        "lathe_profile.nc",
        &example("lathe_profile.nc"),
        &out,
    )
    .unwrap();
    let png = std::fs::read(&out).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(
        (10_000..5_000_000).contains(&png.len()),
        "{} bytes",
        png.len()
    );
    // IHDR: width and height
    let w = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert_eq!((w, h), (1200, 760));
    if let Ok(keep) = std::env::var("CNC_PLOT_KEEP") {
        std::fs::copy(&out, Path::new(&keep).join("lathe_profile.png")).unwrap();
        let m = Machine::builtin_mill();
        let mill = Path::new(&keep).join("mill_pocket.png");
        plot_program(
            &m,
            m.dialect,
            "mill_pocket.nc",
            &example("mill_pocket.nc"),
            &mill,
        )
        .unwrap();
    }
}

#[test]
fn recording_to_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let rec = dir.path().join("pocket.mcap");
    record_simulation(
        &m,
        "mill_pocket.nc",
        &example("mill_pocket.nc"),
        m.dialect,
        &rec,
    )
    .unwrap();
    let out = dir.path().join("pocket.svg");
    plot_recording(&rec, &out).unwrap();
    let svg = check_svg(&out, "mill_pocket.nc on");
    assert!(svg.contains("recording pocket.mcap"));
    for c in [GREY, BLUE, RED] {
        let n = largest(&svg, c);
        assert!(n >= 40, "{c}: {n} points");
    }
    // the same picture as from the program (same run, same decimation)
    let direct = dir.path().join("direct.svg");
    plot_program(
        &m,
        m.dialect,
        "mill_pocket.nc",
        &example("mill_pocket.nc"),
        &direct,
    )
    .unwrap();
    let direct = std::fs::read_to_string(&direct).unwrap();
    assert_eq!(polylines(&svg), polylines(&direct));
    let png = dir.path().join("pocket.png");
    plot_recording(&rec, &png).unwrap();
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
    if let Ok(keep) = std::env::var("CNC_PLOT_KEEP") {
        std::fs::copy(&png, Path::new(&keep).join("mill_pocket_recording.png")).unwrap();
    }
}

#[test]
fn refusals() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let text = example("mill_pocket.nc");
    for name in ["p.pdf", "p", "p.svg.txt"] {
        let out = dir.path().join(name);
        let e = plot_program(&m, m.dialect, "mill_pocket.nc", &text, &out).unwrap_err();
        assert!(e.contains(".svg") && e.contains(".png"), "{e}");
        assert!(!out.exists());
    }
    // a bad program: the check's errors, nothing written
    let out = dir.path().join("bad.svg");
    let e = plot_program(
        &m,
        m.dialect,
        "bad.nc",
        "G01 X10 F100\nG01 X99999\nG77\n",
        &out,
    )
    .unwrap_err();
    assert!(e.starts_with("bad.nc: "), "{e}");
    assert!(e.contains("error"), "{e}");
    assert!(e.contains("line 2") || e.contains("line 3"), "{e}");
    assert!(!out.exists());
    // not a recording
    let junk = dir.path().join("junk.mcap");
    std::fs::write(&junk, b"not an mcap file").unwrap();
    let e = plot_recording(&junk, &dir.path().join("j.svg")).unwrap_err();
    assert!(e.contains("junk.mcap") && e.contains("MCAP"), "{e}");
    let e = plot_recording(&dir.path().join("missing.mcap"), &out).unwrap_err();
    assert!(e.contains("missing.mcap"), "{e}");
    let e = plot_recording(&junk, &dir.path().join("j.jpg")).unwrap_err();
    assert!(e.contains(".svg or .png"), "{e}");
}
