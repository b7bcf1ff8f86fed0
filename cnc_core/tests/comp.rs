//! Radius compensation G40/G41/G42 (`docs/compensation.md`) against an
//! independent geometry oracle: the distance of every sample to the
//! *programmed* contour, computed here from the contour's lines and arcs
//! (point-to-segment and point-to-arc distances), not by the offset code.

use cnc_core::canon::Event;
use cnc_core::exec::{Executor, Sample};
use cnc_core::interp::Interpreter;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};

mod common;
use common::{dist, exact, to_contour, El};

fn run(text: &str, m: &Machine) -> Vec<Sample> {
    let m = &exact(m);
    let r = check(StrSource::new(text), Dialect::Cnc836, m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    s
}

fn lathe_with_tip(tip: u8) -> Machine {
    let mut m = Machine::builtin_lathe();
    for t in &mut m.tools {
        t.tip = tip;
    }
    m
}

/// The lathe profile (diameters in the program; radius below): a Z line,
/// a taper, a convex arc R3, a concave arc R3 and a face.
const LATHE: &str = "N10 G18 G90 G94 M03 S1000 T0101
N20 G00 X30 Z5
N30 G42 G01 X20 Z2 F300
N40 Z-10
N50 X26 Z-18
N60 G03 X32 Z-21 I0 K-3
N70 G02 X38 Z-24 I3 K0
N80 G01 X50
N90 G40 G00 X60 Z-20
N100 M30
";

/// The same contour in (Z, X radius) coordinates, the G18 plane's (p, q).
fn lathe_contour() -> Vec<El> {
    use std::f64::consts::FRAC_PI_2 as H;
    vec![
        El::Line((2.0, 10.0), (-10.0, 10.0)),
        El::Line((-10.0, 10.0), (-18.0, 13.0)),
        // G03 about (Z-21, X13): from angle 0 to 90°
        El::Arc((-21.0, 13.0), 3.0, 0.0, H),
        // G02 about (Z-21, X19): from -90° to -180°
        El::Arc((-21.0, 19.0), 3.0, -H, -H),
        El::Line((-24.0, 19.0), (-24.0, 25.0)),
    ]
}

#[test]
fn lathe_nose_centre_keeps_exactly_r_on_the_right_under_g42() {
    let r = 0.8;
    let contour = lathe_contour();
    for tip in 0..=9u8 {
        let m = lathe_with_tip(tip);
        let s = run(LATHE, &m);
        let (tx, tz) = cnc_core::machine::tip_vector(tip);
        let mut n = 0;
        for x in s.iter().filter(|x| (4..=8).contains(&x.src.line)) {
            // the nose centre: the commanded tip minus R × the tip vector
            let nose = (x.pos[2] - r * tz, x.pos[0] - r * tx);
            let (d, side) = to_contour(&contour, nose);
            assert!(
                (d - r).abs() <= 1e-6,
                "type {tip}, line {}: nose centre {nose:?} is {d} from the contour",
                x.src.line
            );
            // G42: right of the direction of travel
            assert!(side < 0.0, "type {tip}: on the wrong side at {nose:?}");
            n += 1;
        }
        assert!(n > 2000, "{n}");
    }
}

/// The compensated moves (start, end) of a program.
fn moves(text: &str, m: &Machine) -> Vec<(u32, V3, V3)> {
    Interpreter::new(StrSource::new(text), Dialect::Cnc836, m)
        .filter_map(|e| match e {
            Event::Move { geom, src, .. } => Some((src.line, geom.start(), geom.end())),
            _ => None,
        })
        .collect()
}

#[test]
fn the_tip_path_is_the_nose_centre_path_plus_r_times_the_type_vector() {
    let centre = moves(LATHE, &lathe_with_tip(0));
    for tip in 1..=9u8 {
        let (tx, tz) = cnc_core::machine::tip_vector(tip);
        let v = V3::new(0.8 * tx, 0.0, 0.8 * tz);
        let with_tip = moves(LATHE, &lathe_with_tip(tip));
        assert_eq!(with_tip.len(), centre.len());
        for (a, b) in centre.iter().zip(&with_tip) {
            assert_eq!(a.0, b.0);
            if (4..=8).contains(&a.0) {
                assert!((b.1 - (a.1 + v)).norm() < 1e-12, "type {tip} line {}", a.0);
                assert!((b.2 - (a.2 + v)).norm() < 1e-12, "type {tip} line {}", a.0);
            }
        }
        // the entry starts and the exit ends uncompensated: the tip on the
        // programmed points
        let first = with_tip.iter().find(|x| x.0 == 3).unwrap();
        assert_eq!(first.1, V3::new(15.0, 0.0, 5.0));
        assert!((first.2 - (V3::new(10.8, 0.0, 2.0) + v)).norm() < 1e-12);
        let last = with_tip.iter().find(|x| x.0 == 9).unwrap();
        assert_eq!(last.2, V3::new(30.0, 0.0, -20.0));
    }
}

/// A pocket 100 × 60 with corner arcs R8, cut counter-clockwise under G41
/// with the 10 mm end mill (R5).
const POCKET: &str = "N10 G17 G90 G94 M03 S3000 T1
N20 G00 X50 Y50 Z5
N30 G01 Z-2 F300
N40 G41 X38 Y30 F600
N50 X122
N60 G03 X130 Y38 I0 J8
N70 G01 Y82
N80 G03 X122 Y90 I-8 J0
N90 G01 X38
N100 G03 X30 Y82 I0 J-8
N110 G01 Y38
N120 G03 X38 Y30 I8 J0
N130 G40 G01 X50 Y50
N140 G00 Z5
";

#[test]
fn mill_pocket_cutter_centre_keeps_exactly_r_on_the_left_under_g41() {
    use std::f64::consts::FRAC_PI_2 as H;
    let contour = [
        El::Line((38.0, 30.0), (122.0, 30.0)),
        El::Arc((122.0, 38.0), 8.0, -H, H),
        El::Line((130.0, 38.0), (130.0, 82.0)),
        El::Arc((122.0, 82.0), 8.0, 0.0, H),
        El::Line((122.0, 90.0), (38.0, 90.0)),
        El::Arc((38.0, 82.0), 8.0, H, H),
        El::Line((30.0, 82.0), (30.0, 38.0)),
        El::Arc((38.0, 38.0), 8.0, 2.0 * H, H),
    ];
    let m = Machine::builtin_mill();
    let s = run(POCKET, &m);
    let mut n = 0;
    for x in s.iter().filter(|x| (5..=12).contains(&x.src.line)) {
        let (d, side) = to_contour(&contour, (x.pos[0], x.pos[1]));
        assert!((d - 5.0).abs() <= 1e-6, "line {}: {d}", x.src.line);
        assert!(side > 0.0, "G41: left of the contour");
        assert_eq!(x.pos[2], -2.0);
        n += 1;
    }
    assert!(n > 1000);
}

#[test]
fn outside_corners_are_extended_or_rounded_by_configuration() {
    // a 40 × 40 boss, counter-clockwise under G42: the tool is outside,
    // every corner an outside corner
    let p = "N10 G17 G90 M03 S3000 T1\nN20 G00 X0 Y-20 Z-2\nN30 G42 G01 X20 Y0 F600\nN40 X60\nN50 Y40\nN60 X20\nN70 Y0\nN80 G40 X0 Y-20\n";
    let contour = [
        El::Line((20.0, 0.0), (60.0, 0.0)),
        El::Line((60.0, 0.0), (60.0, 40.0)),
        El::Line((60.0, 40.0), (20.0, 40.0)),
        El::Line((20.0, 40.0), (20.0, 0.0)),
    ];
    let far = |m: &Machine| {
        let s = run(p, m);
        let mut worst: f64 = 0.0;
        for x in s.iter().filter(|x| (4..=6).contains(&x.src.line)) {
            let (d, side) = to_contour(&contour, (x.pos[0], x.pos[1]));
            assert!(d >= 5.0 - 1e-6 && side < 0.0, "{d}");
            worst = worst.max(d);
        }
        worst
    };
    // extended: the corner points are R·√2 from the corner
    let worst = far(&Machine::builtin_mill());
    assert!((worst - 5.0 * 2f64.sqrt()).abs() < 1e-9, "{worst}");
    // rounded: exactly R everywhere
    let mut m = Machine::builtin_mill();
    m.compensation.round_outside_corners = true;
    let worst = far(&m);
    assert!((worst - 5.0).abs() < 1e-6, "{worst}");
}

fn errors(text: &str, m: &Machine) -> Vec<String> {
    check(StrSource::new(text), Dialect::Cnc836, m)
        .errors
        .iter()
        .map(|e| e.to_string())
        .collect()
}

#[track_caller]
fn refused(text: &str, line: u32, what: &str) {
    let e = errors(text, &Machine::builtin_mill());
    assert_eq!(e.len(), 1, "{e:#?}");
    assert!(
        e[0].starts_with(&format!("line {line}, ")) && e[0].contains(what),
        "{:?} (wanted line {line}: {what})",
        e[0]
    );
}

const MILL_PRE: &str = "N10 G17 G90 M03 S3000 T1\nN20 G00 X0 Y0 Z-2\n";

#[test]
fn every_compensation_error_names_its_blocks() {
    // no intersection: the path turns back on itself
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100\nN50 X60\nN60 G40 X0 Y0\n"),
        5,
        "radius compensation: the offset paths of blocks N40 and N50 do not intersect (tool radius 5): program a transition radius or a chamfer of at least 0.01 mm between them",
    );
    // a concave arc smaller than the tool
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100\nN50 G03 X103 Y33 I0 J3\nN60 G01 Y60\nN70 G40 X0 Y0\n"),
        5,
        "radius compensation: the arc of block N50 (radius 3) is not larger than the tool radius 5",
    );
    // the same arc between two lines on one line: only the arc's error
    // (the lines beside it were once reported too, as not intersecting)
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X10 Y50 F600\nN40 X40\nN50 G03 X46 Y50 I3\nN60 G01 X80\nN70 G40 X90 Y0\n"),
        5,
        "radius compensation: the arc of block N50 (radius 3) is not larger than the tool radius 5",
    );
    // a step narrower than the tool: its offset runs backwards
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100\nN50 Y34\nN60 X40\nN70 G40 X0 Y0\n"),
        6,
        "radius compensation: block N50 is too short for the tool radius 5: its offset path would run backwards",
    );
    // the same as the last element before G40: its offset, ending
    // perpendicular at its end, runs backwards
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100\nN50 Y32\nN60 G40 X0 Y0\n"),
        6,
        "radius compensation: block N50 is too short for the tool radius 5: its offset path would run backwards",
    );
    // no tool / a tool that is not in the table
    refused(
        "N20 G00 X0 Y0 Z-2\nN30 G41 G01 X40 Y30 F600\n",
        2,
        "G41 (radius compensation) needs a tool from the machine's tool table: select one with T first",
    );
    refused(
        "N10 T7\n",
        1,
        "tool T7 is not in the machine's tool table (it has 1, 2, 3)",
    );
    // a tool change, a plane change or a thread while it is on
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100 T2\nN50 G40 X0 Y0\n"),
        4,
        "a tool change while radius compensation is active",
    );
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 G18 X100\nN50 G40 X0 Y0\n"),
        4,
        "the plane cannot change while radius compensation is active",
    );
    // start and end on lines
    refused(
        &format!("{MILL_PRE}N30 G41 G02 X40 Y0 I20 J0 F600\nN40 G01 X100\nN50 G40 X0 Y0\n"),
        3,
        "radius compensation (G41/G42) must start on a line (G00/G01), but block N30 is an arc",
    );
    refused(
        &format!("{MILL_PRE}N30 G41 G01 X40 Y30 F600\nN40 X100\nN50 G40 G02 X120 Y50 I0 J20\n"),
        5,
        "radius compensation is cancelled (G40) on a line (G00/G01), but block N50 is an arc",
    );
    // travel limits hold for the compensated path: the cutter centre at
    // X-3 on the mill (X 0..500), and the bounding box is the commanded one
    refused(
        "N10 G17 G90 M03 S3000 T1\nN20 G00 X20 Y-20 Z-2\nN30 G41 G01 X2 Y0 F600\nN40 Y40\nN50 X20\nN60 G40 X30 Y60\n",
        4,
        "travel limit: with radius compensation the path of block N30 reaches X -3, outside the axis range 0..500",
    );
    let r = check(
        StrSource::new(POCKET),
        Dialect::Cnc836,
        &Machine::builtin_mill(),
    );
    let (lo, hi) = r.bbox.unwrap();
    // (from home at 0, 0; the contour reaches X130 Y90, the cutter 125, 85)
    assert_eq!((lo[0], lo[1], hi[0], hi[1]), (0.0, 0.0, 125.0, 85.0));
    // the lathe's offset numbers
    let e = errors("N10 T0105\n", &Machine::builtin_lathe());
    assert_eq!(
        e,
        vec!["line 1, column 5: block N10: tool offset 05 (T0105) is not in the machine's tool table (it has 1, 2, 3)".to_string()]
    );
    let e = errors(
        "N10 M03 S200 T0101\nN20 G00 X20 Z5\nN30 G42 G01 X20 Z2 F100\nN40 G33 Z-40 F1\n",
        &Machine::builtin_lathe(),
    );
    assert!(
        e.iter()
            .any(|e| e.contains("line 4")
                && e.contains("G33 (thread) with radius compensation active")),
        "{e:#?}"
    );
}

#[test]
fn polar_arcs_and_a_helix_are_compensated_in_the_plane_only() {
    // the seed's polar programs with their G42 (HEIDENHAIN), tool R3
    let text = include_str!("../../examples/heidenhain_polar_comp.h");
    let m = exact(&Machine::builtin_mill());
    let r = check(StrSource::new(text), Dialect::Heidenhain, &m);
    assert!(r.ok(), "{}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Heidenhain, &m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    let block = |n: u64| s.iter().filter(move |x| x.src.block_no == Some(n));
    // the half circle N200 and the helix N210 about the pole (25, 25),
    // programmed on R20, run on R23 (G42 outside a CCW arc)
    let mut n = 0;
    for x in block(200).chain(block(210)) {
        let d = (x.pos[0] - 25.0).hypot(x.pos[1] - 25.0);
        assert!((d - 23.0).abs() < 1e-9, "N{:?}: radius {d}", x.src.block_no);
        n += 1;
    }
    assert!(n > 500);
    // the helix drops 3 mm over its three turns, in proportion to the angle
    let helix: Vec<_> = block(210).collect();
    let mut turned = 0.0;
    let mut prev = (helix[0].pos[1] - 25.0).atan2(helix[0].pos[0] - 25.0);
    for x in &helix[1..] {
        let a = (x.pos[1] - 25.0).atan2(x.pos[0] - 25.0);
        let mut d = a - prev;
        if d < -std::f64::consts::PI {
            d += std::f64::consts::TAU;
        }
        turned += d;
        prev = a;
        let want = helix[0].pos[2] - 3.0 * turned / (3.0 * std::f64::consts::TAU);
        assert!((x.pos[2] - want).abs() < 1e-6, "z {} want {want}", x.pos[2]);
    }
    // the polar lines N140..N160 run 3 mm outside the hexagon's sides
    let side = |h0: f64, h1: f64| {
        let p = |h: f64| {
            let (sn, c) = h.to_radians().sin_cos();
            (45.0 + 30.0 * c, 45.0 + 30.0 * sn)
        };
        El::Line(p(h0), p(h1))
    };
    for (b, el) in [
        (140, side(0.0, 60.0)),
        (150, side(60.0, 120.0)),
        (160, side(120.0, 180.0)),
    ] {
        for x in block(b) {
            let (d, sd) = dist(&el, (x.pos[0], x.pos[1]));
            // (the corner points are farther: the offsets are extended)
            assert!(d >= 3.0 - 1e-9 && sd < 0.0, "N{b}: {d}");
        }
    }
}

/// Largest change of any axis between two samples, mm.
fn largest_step(s: &[Sample]) -> f64 {
    s.windows(2)
        .map(|w| (w[1].pos - w[0].pos).abs().max())
        .fold(0.0, f64::max)
}

/// A tool change whose geometry offset differs is taken up by the next
/// move (a line at that move's feed from where the tool stands), never by a
/// jump of the setpoints: before, T2 made Z step by its 10 mm length in one
/// sample (smoothed over the filter's 4).
#[test]
fn a_new_geometry_offset_is_taken_up_by_the_next_move() {
    let mut m = Machine::builtin_mill();
    m.tools[1].z_mm = 10.0;
    let number = m.tools[1].number;
    let text = format!("N10 G90 G00 X10 Y10 Z50\nN20 T{number}\nN30 G01 X20 F600\nN40 M30\n");
    let s = run(&text, &m);
    let vmax = m.vmax().max();
    let step = largest_step(&s);
    assert!(
        step <= vmax * m.dt() + 1e-9,
        "a setpoint moved {step} mm in one sample (at most {} mm)",
        vmax * m.dt()
    );
    // the offset point: Z50 programmed, the tool 10 mm longer
    let end = s.last().unwrap().pos;
    assert!(
        (end - V3::new(20.0, 10.0, 40.0)).norm() < 1e-9,
        "ends at {end:?}"
    );
    // the move from Z50 to Z40 runs at N30's feed (10 mm/s), within N30
    let taking_up: Vec<&Sample> = s.iter().filter(|x| x.src.line == 3).collect();
    let fastest = taking_up.iter().map(|x| x.path_speed).fold(0.0, f64::max);
    assert!((fastest - 10.0).abs() < 1e-9, "N30 ran at {fastest} mm/s");
    let z40 = taking_up
        .iter()
        .position(|x| (x.pos.z - 40.0).abs() < 1e-12)
        .unwrap();
    assert!(
        (taking_up[z40].pos.x - 10.0).abs() < 1e-9,
        "Z reached 40 at X{} (the offset first, then the line)",
        taking_up[z40].pos.x
    );
}

/// A thread is cut where the tool's geometry offset puts it, and a thread
/// right after a tool change that changes the offset is refused.
#[test]
fn threads_follow_the_geometry_offset() {
    let mut m = Machine::builtin_lathe();
    m.tools[0].x_mm = 1.5; // radius
    let t = m.tools[0].number;
    let text = format!(
        "N10 G18 G90 M03 S200 T01{t:02}\nN20 G00 X20 Z5\nN30 G33 Z-40 F1.5\nN40 G00 X30\nN50 M30\n"
    );
    let s = run(&text, &m);
    let in_thread: Vec<&Sample> = s.iter().filter(|x| x.src.line == 3).collect();
    assert!(!in_thread.is_empty());
    for x in &in_thread {
        // X20 is a radius of 10; the offset takes 1.5 off
        assert!(
            (x.pos.x - 8.5).abs() < 1e-12,
            "thread at X radius {}",
            x.pos.x
        );
    }
    assert!(largest_step(&s) <= m.vmax().max() * m.dt() + 1e-9);
    let late = format!(
        "N10 G18 G90 M03 S200\nN20 G00 X20 Z5\nN30 T01{t:02}\nN40 G33 Z-40 F1.5\nN50 M30\n"
    );
    let r = check(StrSource::new(&late), Dialect::Cnc836, &exact(&m));
    assert_eq!(
        r.errors.iter().map(|e| e.to_string()).collect::<Vec<_>>(),
        vec!["line 5, column 1: block N50: the G33 block N40 follows a tool change that changes the geometry offset: program a positioning move (G00/G01) to the thread's start before it".to_string()]
    );
}
