//! `cnc plot`'s library side: programs and recordings to SVG and PNG.

use cnc_core::{Dialect, Machine};
use cnc_node::plot::{
    labels, plot_program, plot_recording, plot_thread_error, program_figure, render_svg,
    run_figure, thread_error_series, thread_labels, Figure, Panel, Point, ProgramRun,
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

/// A line and a convex arc under G42 on the lathe (X diameters; radius
/// below): the line Z2..-10 at X10, the arc R5 about (Z-15, X10) from
/// (Z-10, X10) to (Z-15, X15). Tool 1: nose radius 0.8, tool type 3 (tip
/// at (-1, -1) x R from the nose centre).
const COMP: &str = "N10 G18 G90 G94 M03 S1000 T0101
N20 G00 X30 Z5
N30 G42 G01 X20 Z2 F300
N40 Z-10
N50 G03 X30 Z-15 I0 K-5
N60 G40 G00 X40 Z-10
N70 M30
";

fn series<'a>(p: &'a Panel, label: &str) -> Vec<&'a [Point]> {
    let s = p.series.iter().find(|s| s.label == label);
    let s = s.unwrap_or_else(|| panic!("no series {label}"));
    s.polylines.iter().map(Vec::as_slice).collect()
}

/// Distance in the (Z, X radius) plane from `p` to the contour of
/// [`COMP`], from its geometry (not the compensation code).
fn to_comp_contour(p: Point) -> f64 {
    // the line Z2..-10 at X10
    let line = {
        let z = p.0.clamp(-10.0, 2.0);
        ((p.0 - z).powi(2) + (p.1 - 10.0).powi(2)).sqrt()
    };
    // the arc about (-15, 10), R5, angles 0..90° in (Z, X)
    let (dz, dx) = (p.0 + 15.0, p.1 - 10.0);
    let a = dx.atan2(dz);
    let arc = if (0.0..=std::f64::consts::FRAC_PI_2).contains(&a) {
        ((dz * dz + dx * dx).sqrt() - 5.0).abs()
    } else {
        let e = |z: f64, x: f64| ((p.0 - z).powi(2) + (p.1 - x).powi(2)).sqrt();
        e(-10.0, 10.0).min(e(-15.0, 15.0))
    };
    line.min(arc)
}

fn first_panel(f: &Figure) -> &Panel {
    &f.panels[0]
}

#[test]
fn compensation_series_contour_nose_centre_and_tip() {
    let m = Machine::builtin_lathe();
    let fig = program_figure(&m, Dialect::Cnc836, "comp.nc", COMP).unwrap();
    let p = first_panel(&fig);
    assert_eq!(
        (p.x_label.as_str(), p.y_label.as_str()),
        ("Z mm", "X (radius) mm")
    );
    let contour = series(p, labels::CONTOUR);
    let nose = series(p, labels::NOSE_CENTRE);
    let tip = series(p, labels::TIP);
    assert!(series(p, labels::SETPOINTS)[0].len() > 100);
    assert!(!series(p, labels::NOSE).is_empty());
    // the programmed contour: drawing dimensions, with the corner points
    let pts: Vec<Point> = contour.iter().flat_map(|l| l.iter().copied()).collect();
    for c in [(2.0, 10.0), (-10.0, 10.0), (-15.0, 15.0)] {
        assert!(
            pts.iter().any(|q| (q.0 - c.0).hypot(q.1 - c.1) < 1e-9),
            "contour lacks {c:?}"
        );
    }
    // the nose centre: at R from the contour along the whole compensated
    // part (the points in the box of the contour grown by R, between the
    // entry's end and the G40 block's start), on the right of the travel
    // (outside: X above the line, outside the arc); every point of every
    // segment there, not just the vertices
    let r = 0.8;
    assert_eq!(nose.len(), 1);
    let nose = nose[0];
    let inside = |q: &Point| q.0 >= -15.0 - 1e-9 && q.0 <= 2.0 + r + 1e-9 && q.1 <= 15.0 + r + 1e-9;
    let mut checked = 0;
    for w in nose.windows(2) {
        if !(inside(&w[0]) && inside(&w[1])) {
            continue;
        }
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let q = (
                w[0].0 + t * (w[1].0 - w[0].0),
                w[0].1 + t * (w[1].1 - w[0].1),
            );
            let d = to_comp_contour(q);
            // arcs are drawn as chords of at most 2°: 5.8 (1 - cos 1°) < 1 µm
            assert!(
                (d - r).abs() < 2e-3,
                "nose centre {q:?} is {d} from the contour"
            );
            assert!(q.1 > 10.0, "{q:?} on the wrong side");
            checked += 1;
        }
    }
    assert!(checked > 200, "{checked}");
    // the corner of the line and the arc (an inside corner): the offset
    // line X10.8 meets the offset arc R5.8 at Z = -15 + sqrt(5.8² - 0.8²)
    let corner = (-15.0 + (5.8f64 * 5.8 - 0.64).sqrt(), 10.8);
    assert!(
        nose.iter()
            .any(|q| (q.0 - corner.0).hypot(q.1 - corner.1) < 1e-9),
        "no corner point {corner:?}"
    );
    // the imaginary tip: the nose centre + R x (-1, -1) (type 3), point
    // by point over the whole program (tool 1 is selected before any move)
    assert_eq!(tip.len(), 1);
    assert_eq!(tip[0].len(), nose.len());
    for (t, n) in tip[0].iter().zip(nose) {
        assert!((t.0 - (n.0 - r)).abs() < 1e-9 && (t.1 - (n.1 - r)).abs() < 1e-9);
    }
    // on the Z line the tip is on the contour (X10): from the entry's end
    // (the nose centre R above the line's start, Z2) to the corner; on the
    // arc it is not (the nose circle is tangent there, its imaginary tip
    // off it)
    for z in [2.0 - r, corner.0 - r] {
        assert!(
            tip[0]
                .iter()
                .any(|q| (q.0 - z).abs() < 1e-9 && (q.1 - 10.0).abs() < 1e-9),
            "no tip point (Z{z}, X10)"
        );
    }
    let off = tip[0]
        .iter()
        .filter(|q| q.0 < corner.0 - r - 0.1 && q.1 < 15.0)
        .map(|q| to_comp_contour(*q))
        .fold(0.0, f64::max);
    assert!(off > 0.2, "{off}");
    // the SVG names the series
    let svg = render_svg(&fig).unwrap();
    for label in [
        labels::CONTOUR,
        labels::NOSE_CENTRE,
        labels::TIP,
        labels::NOSE,
        labels::SETPOINTS,
    ] {
        assert!(has_text(&svg, label), "legend label {label}");
    }
}

#[test]
fn compensation_plots_of_the_examples() {
    // the lathe example: the compensated part zoomed beside the whole
    // program
    let m = Machine::builtin_lathe();
    let text = example("lathe_compensation.nc");
    let fig = program_figure(&m, Dialect::Cnc836, "lathe_compensation.nc", &text).unwrap();
    assert!(fig.columns);
    assert_eq!(fig.panels.len(), 2);
    let zoom = &fig.panels[1];
    assert!(zoom.caption.contains("zoomed"));
    let (x, y) = (zoom.x_range.unwrap(), zoom.y_range.unwrap());
    assert!(x.0 < -28.0 && x.1 > 2.0 && x.1 < 10.0, "{x:?}");
    assert!(y.0 < 8.0 && y.1 > 28.0 && y.1 < 40.0, "{y:?}");
    // the mill: the cutter centre is what is commanded (no tip series);
    // the pocket is most of the view: no zoom
    let m = Machine::builtin_mill();
    let text = example("mill_pocket_comp.nc");
    let fig = program_figure(&m, Dialect::Cnc836, "mill_pocket_comp.nc", &text).unwrap();
    let p = first_panel(&fig);
    assert!(p.series.iter().all(|s| s.label != labels::TIP));
    let centre = series(p, labels::CUTTER_CENTRE);
    // the first side: Y30 + 5
    assert!(centre[0]
        .windows(2)
        .any(|w| w[0] == (38.0, 35.0) && w[1] == (122.0, 35.0)));
    assert_eq!(fig.panels.len(), 2, "XY and XZ");
    // HEIDENHAIN polar blocks under G42
    let text = example("heidenhain_polar_comp.h");
    let fig = program_figure(&m, Dialect::Heidenhain, "heidenhain_polar_comp.h", &text).unwrap();
    assert!(!series(first_panel(&fig), labels::CUTTER).is_empty());
    // no G41/G42: the plot as before
    let text = example("mill_pocket.nc");
    let fig = program_figure(&m, Dialect::Cnc836, "mill_pocket.nc", &text).unwrap();
    let labels_of = |p: &Panel| p.series.iter().map(|s| s.label.clone()).collect::<Vec<_>>();
    assert_eq!(
        labels_of(first_panel(&fig)),
        [
            labels::PROGRAMMED,
            labels::SETPOINTS,
            labels::ACTUAL,
            labels::RAPID
        ]
    );
    if let Ok(keep) = std::env::var("CNC_PLOT_KEEP") {
        let m = Machine::builtin_lathe();
        let out = Path::new(&keep).join("lathe_compensation.png");
        let text = example("lathe_compensation.nc");
        plot_program(&m, Dialect::Cnc836, "lathe_compensation.nc", &text, &out).unwrap();
    }
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
    // the groove's phase on the line: one count of 4096 is 0.088° of the
    // spindle, so the setpoints' is within it
    let g = p.groove_set;
    assert_eq!(g.n, p.on_line_samples);
    assert!(
        g.worst_deg <= 360.0 / 4096.0 && g.mean_deg.abs() <= 0.01,
        "{g:?}"
    );
    assert!(
        (g.worst_deg - p.max_set_um / 1500.0 * 360.0).abs() < 1e-9,
        "{g:?}"
    );
    assert_eq!(p.groove_act.n, p.on_line_samples);
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
    // the run-in is symmetric about θ₀ (from -Δ/2 to Δ/2): the last
    // sample within 1 nm of the start (an S-curve moves less than that in
    // its first 0.33 ms at 160 m/s³) is at most a cycle, 4.8° at 800 rpm,
    // and those 0.33 ms after -Δ/2
    assert!(
        first.deg + a > -1.0 && first.deg + a < 4.8 * 1.33 + 1e-9,
        "{} vs {a}",
        first.deg
    );
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

/// Both figures of a program from one run (`cnc plot -o ... --thread ...`)
/// are those of the separate calls, which each run the program.
#[test]
fn one_run_for_both_figures() {
    let m = Machine::builtin_lathe();
    let text = example("lathe_thread.nc");
    let run = ProgramRun::new(&m, m.dialect, "lathe_thread.nc", &text, true, true).unwrap();
    assert!(
        run_figure(&run).unwrap()
            == program_figure(&m, m.dialect, "lathe_thread.nc", &text).unwrap()
    );
    let series = thread_error_series(&m, m.dialect, &text).unwrap();
    assert_eq!(run.thread_errors().unwrap(), &series);
    assert_eq!(series.passes.len(), 2);
    // only what was asked for
    let paths = ProgramRun::new(&m, m.dialect, "t.nc", &text, true, false).unwrap();
    assert!(paths.thread_errors().is_err());
    let thread = ProgramRun::new(&m, m.dialect, "t.nc", &text, false, true).unwrap();
    assert!(run_figure(&thread).is_err());
    // a program that fails the check is refused before any run
    let e = ProgramRun::new(&m, m.dialect, "bad.nc", "G1 X\n", true, true).err();
    assert!(e.is_some_and(|e| e.starts_with("bad.nc: ") && e.contains("nothing plotted")));
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
    // and each pass's groove phase, as for a recording
    assert_eq!(
        out.matches("    groove phase there (0 = the programmed start angle): setpoint mean ")
            .count(),
        2,
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
