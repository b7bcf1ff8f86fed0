//! `cnc plot`'s library side: programs and recordings to SVG and PNG.

use cnc_core::{Dialect, Machine};
use cnc_node::plot::{
    labels, plot_program, plot_recording, plot_thread_error, thread_error_series, thread_labels,
};
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

/// A single-pass thread: M20 x 1.5 over 25 mm at 800 rpm.
const THREAD: &str = "N5 G18 G90 M03 S800\nN10 G00 X20 Z5\nN20 G33 Z-20 F1.5\nN30 G00 X30\nN40 Z5\nN50 M05\nN60 M30\n";

#[test]
fn thread_error_series_numbers() {
    let m = Machine::builtin_lathe();
    let s = thread_error_series(&m, Dialect::Cnc836, THREAD).unwrap();
    assert_eq!(s.fault, None);
    assert_eq!(s.counts_per_rev, 4096);
    assert_eq!(s.passes.len(), 1);
    let p = &s.passes[0];
    assert_eq!((p.line, p.block_no, p.lead, p.pitch), (3, Some(20), 2, 1.5));
    let count = 1.5 / 4096.0 * 1000.0;
    assert!((p.count_um - count).abs() < 1e-12, "{}", p.count_um);
    // the synchronized part: 25 mm of 1.5 mm/rev less run-in and deceleration
    assert_eq!(p.sync_deg.len(), 1);
    let (a, b) = p.sync_deg[0];
    assert!(a > 0.0 && a < 90.0, "synchronized from {a}°");
    assert!(b > 5500.0 && b < 25.0 / 1.5 * 360.0, "synchronized to {b}°");
    assert!(p.on_line_samples > 1000, "{}", p.on_line_samples);
    // the setpoint is on the thread line within one encoder count
    assert!(p.max_set_counts <= 1.0, "{} counts", p.max_set_counts);
    assert!(p.max_set_um <= count, "{} µm", p.max_set_um);
    let on: Vec<_> = p.points.iter().filter(|q| q.on_line).collect();
    assert!(on.len() > 100, "{}", on.len());
    for q in &on {
        assert!(q.set_um.abs() <= count, "{q:?}");
        assert!(q.deg >= a && q.deg <= b, "{q:?}");
    }
    // the simulated axis lags after the run-in and settles within a count
    // in the first two revolutions
    assert!(p.max_act_counts > 1.0, "{}", p.max_act_counts);
    let settled = p.act_within_count_from_deg.unwrap();
    assert!(settled > a && settled < 720.0, "{settled}°");
    for q in on.iter().filter(|q| q.deg >= settled) {
        assert!(q.act_um.abs() <= count, "{q:?}");
    }
    // the whole pass, in order: the run-in starts at rest before θ₀ ...
    assert!(p.points.windows(2).all(|w| w[0].deg <= w[1].deg));
    let first = p.points[0];
    assert!(first.deg < 0.0 && first.deg > -a - 1.0, "{first:?}");
    assert!(!first.on_line);
    // ... where the setpoint is at the start (u = 0): error −pitch × angle
    let want = -1.5 * first.deg / 360.0 * 1000.0;
    assert!(
        (first.set_um - want).abs() <= count,
        "{first:?} want {want}"
    );
    assert!(first.set_um > 10.0, "{first:?}");
    // the run-in is symmetric about θ₀ (a parabola from -Δ/2 to Δ/2)
    assert!((first.deg + a).abs() < 1.0, "{} vs {a}", first.deg);
    // ... and the deceleration ends at the end point, behind the line
    let last = *p.points.last().unwrap();
    assert!(!last.on_line && last.deg > b, "{last:?}");
    let want = (25.0 - 1.5 * last.deg / 360.0) * 1000.0;
    assert!((last.set_um - want).abs() <= count, "{last:?} want {want}");
    assert!(last.set_um < -10.0, "{last:?}");
    eprintln!(
        "thread: synchronized {a:.1}..{b:.1}°, setpoint ≤ {:.3} counts, actual ≤ {:.2} counts, within 1 count from {settled:.0}°, run-in error {:.1} µm",
        p.max_set_counts, p.max_act_counts, first.set_um
    );
}

#[test]
fn thread_error_plot() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_lathe();
    let out = dir.path().join("thread.svg");
    let s = plot_thread_error(&m, m.dialect, "thread.nc", THREAD, 1, &out).unwrap();
    assert_eq!(s.passes.len(), 1);
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for label in [
        thread_labels::SETPOINT,
        thread_labels::ACTUAL,
        thread_labels::COUNT,
        thread_labels::SYNC,
    ] {
        assert!(has_text(&svg, label), "legend label {label}");
    }
    assert!(svg.contains("thread.nc on lathe: G33 Z lead error, pass 1 of 1"));
    assert!(has_text(&svg, "Z lead error, µm"));
    assert!(svg.contains("spindle angle from θ₀"));
    // two panels: the whole pass and the zoom with the count in its caption
    assert!(svg.contains("whole pass (N20, line 3)"));
    assert!(svg.contains("1 count = 0.366 µm (F1.5 / 4096 counts/rev)"));
    for c in [BLUE, RED] {
        let n = largest(&svg, c);
        assert!(n >= 50, "{c}: {n} points");
    }
    // the ±1 count lines: dashed, in both panels (and the legend's dashes)
    let dashes = polylines(&svg)
        .iter()
        .filter(|(s, _)| s == DARK_GREY)
        .count();
    assert!(dashes > 20, "{dashes}");
    // PNG as well
    let png = dir.path().join("thread.png");
    plot_thread_error(&m, m.dialect, "thread.nc", THREAD, 1, &png).unwrap();
    assert_eq!(&std::fs::read(&png).unwrap()[..4], b"\x89PNG");
}

#[test]
fn thread_error_of_the_example_two_passes_one_groove() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_lathe();
    let text = example("lathe_thread.nc");
    let out = dir.path().join("lathe_thread_error.png");
    let s = plot_thread_error(&m, m.dialect, "lathe_thread.nc", &text, 2, &out).unwrap();
    assert_eq!(s.fault, None);
    assert_eq!(s.passes.len(), 2);
    assert_eq!(s.passes[0].block_no, Some(30));
    assert_eq!(s.passes[1].block_no, Some(70));
    for p in &s.passes {
        assert!(
            p.max_set_counts <= 1.0,
            "N{:?}: {}",
            p.block_no,
            p.max_set_counts
        );
        assert!(p.act_within_count_from_deg.is_some());
    }
    // both start at the same spindle angle (I0 after the index): one groove
    let d = (s.passes[1].theta0 - s.passes[0].theta0).rem_euclid(1.0);
    assert!(
        d.min(1.0 - d) < 1e-9,
        "θ₀ {} and {}",
        s.passes[0].theta0,
        s.passes[1].theta0
    );
    assert!(std::fs::metadata(&out).unwrap().len() > 10_000);
    if let Ok(keep) = std::env::var("CNC_PLOT_KEEP") {
        let keep = Path::new(&keep).join("lathe_thread_error.png");
        plot_thread_error(&m, m.dialect, "lathe_thread.nc", &text, 1, &keep).unwrap();
    }
}

#[test]
fn thread_error_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_lathe();
    let out = dir.path().join("t.svg");
    // no G33
    let e = plot_thread_error(
        &m,
        m.dialect,
        "profile.nc",
        &example("lathe_profile.nc"),
        1,
        &out,
    )
    .unwrap_err();
    assert!(e.contains("profile.nc") && e.contains("no G33"), "{e}");
    // a pass the program does not cut
    let e = plot_thread_error(&m, m.dialect, "t.nc", THREAD, 2, &out).unwrap_err();
    assert!(e.contains("pass 2") && e.contains("cuts 1"), "{e}");
    let e = plot_thread_error(&m, m.dialect, "t.nc", THREAD, 0, &out).unwrap_err();
    assert!(e.contains("pass 0"), "{e}");
    // a bad program, a bad extension
    let e = plot_thread_error(&m, m.dialect, "bad.nc", "G33 Z-10\n", 1, &out).unwrap_err();
    assert!(e.starts_with("bad.nc: ") && e.contains("error"), "{e}");
    let e =
        plot_thread_error(&m, m.dialect, "t.nc", THREAD, 1, &dir.path().join("t.jpg")).unwrap_err();
    assert!(e.contains(".svg or .png"), "{e}");
    assert!(!out.exists());
}

fn cnc(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cnc"))
        .args(args)
        .current_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .expect("run cnc");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_thread_flag() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("t.svg");
    let o = dir.path().join("o.svg");
    let (t_s, o_s) = (t.to_str().unwrap(), o.to_str().unwrap());
    let prog = "examples/lathe_thread.nc";
    // --thread alone: no path plot needed
    let (code, out, err) = cnc(&[
        "plot",
        prog,
        "--machine",
        "lathe",
        "--thread",
        t_s,
        "--pass",
        "2",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("thread pass 2 of 2 plotted to"), "{out}");
    assert!(
        out.contains("pass 1 (N30, line 7): F1.5 synchronized"),
        "{out}"
    );
    assert!(t.exists() && !o.exists());
    // both
    std::fs::remove_file(&t).unwrap();
    let (code, out, err) = cnc(&[
        "plot",
        prog,
        "--machine",
        "lathe",
        "-o",
        o_s,
        "--thread",
        t_s,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("plotted to") && t.exists() && o.exists(),
        "{out}"
    );
    // one of the two outputs or nothing; --pass needs --thread
    let (code, _, err) = cnc(&["plot", prog, "--machine", "lathe"]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = cnc(&["plot", prog, "--machine", "lathe", "-o", o_s, "--pass", "2"]);
    assert_eq!(code, 2, "{err}");
    // a bad thread output refuses before the path plot is written
    let o2 = dir.path().join("o2.svg");
    let (code, _, err) = cnc(&[
        "plot",
        prog,
        "--machine",
        "lathe",
        "-o",
        o2.to_str().unwrap(),
        "--thread",
        "t.pdf",
    ]);
    assert_ne!(code, 0);
    assert!(err.contains(".svg or .png") && !o2.exists(), "{err}");
}
