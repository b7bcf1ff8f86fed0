//! Property tests of the geometry with random inputs: arcs in G17/G18/G19
//! (centre offsets I/J/K, full circles, radii from 1 µm to 100 m),
//! HEIDENHAIN polar arcs (radius R and angle H about a pole), helices
//! (plain G02/G03 with the normal axis, cnc836's G09 with G73 turns), and
//! radius compensation of random convex polygons and rounded rectangles
//! (G41 inside, G42 outside), checked against an independent distance
//! oracle or refused with a clear error.
//!
//! (G02/G03 with a radius `R` instead of a centre is not in either
//! dialect: `R` is HEIDENHAIN's polar radius, tested here as such.)

use cnc_core::canon::Event;
use cnc_core::diag::num;
use cnc_core::exec::{Executor, Sample};
use cnc_core::geom::{Arc, Geom};
use cnc_core::interp::Interpreter;
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine, V3};
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};

mod common;
use common::{dist_inner, El};

/// A value as written in the program: rounded to 1 nm.
fn q6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// The mill with ±1 km of travel on every axis (for huge radii).
fn big_mill() -> Machine {
    let mut m = common::exact(&Machine::builtin_mill());
    for a in &mut m.axes {
        a.min_mm = -1e6;
        a.max_mm = 1e6;
    }
    m
}

const PLANES: [&str; 3] = ["G17", "G18", "G19"];

/// (p, q, n) axis indices of G17, G18, G19.
fn axes(plane: usize) -> (usize, usize, usize) {
    [(0, 1, 2), (2, 0, 1), (1, 2, 0)][plane]
}

/// `X.. Y.. Z..` of a point.
fn xyz(v: V3) -> String {
    format!("X{} Y{} Z{}", v.x, v.y, v.z)
}

/// The moves of a program that passes the check.
fn moves(text: &str, dialect: Dialect, m: &Machine) -> Vec<(u32, Geom)> {
    let r = check(StrSource::new(text), dialect, m);
    assert!(r.ok(), "{}\n{text}", r.message());
    Interpreter::new(StrSource::new(text), dialect, m)
        .filter_map(|e| match e {
            Event::Move { geom, src, .. } => Some((src.line, geom)),
            _ => None,
        })
        .collect()
}

/// The in-plane radius of `p` about the arc's centre.
fn plane_radius(a: &Arc, p: V3) -> f64 {
    let (i, j, _) = a.plane.axes();
    (p[i] - a.center[i]).hypot(p[j] - a.center[j])
}

/// The angle of `p` about the arc's centre.
fn angle(a: &Arc, p: V3) -> f64 {
    let (i, j, _) = a.plane.axes();
    (p[j] - a.center[j]).atan2(p[i] - a.center[i])
}

/// Samples `n + 1` points along the arc by path length and checks, with
/// an oracle independent of the arc's own parametrization: every point on
/// the circle within 1e-9 of the radius (relative), the turned angle
/// proportional to the path length (the angle unwrapped from the start),
/// the axial travel proportional to the angle (a helix of constant
/// pitch), the sum of the chords equal to n chords of the sweep / n, the
/// end points exact.
fn check_arc(g: &Geom, n: usize) -> Result<(), TestCaseError> {
    let Geom::Arc(a) = g else {
        return Err(TestCaseError::fail("not an arc"));
    };
    let (_, _, ax) = a.plane.axes();
    prop_assert_eq!(g.eval(0.0), a.start);
    prop_assert_eq!(g.eval(a.length), a.end);
    prop_assert_eq!(g.eval(2.0 * a.length + 1.0), a.end);
    let plane_len = a.radius * a.sweep.abs();
    prop_assert!(
        (a.length - plane_len.hypot(a.axial)).abs() <= 1e-12 * a.length,
        "length {} vs r·θ {} and axial {}",
        a.length,
        plane_len,
        a.axial
    );
    let mut prev = a.start;
    let mut turned = 0.0;
    let mut chords = 0.0;
    for k in 1..=n {
        let f = k as f64 / n as f64;
        let p = g.eval(a.length * f);
        let r = plane_radius(a, p);
        prop_assert!(
            (r - a.radius).abs() <= 1e-9 * a.radius,
            "point {} at radius {} of {} (relative {:e})",
            k,
            r,
            a.radius,
            (r - a.radius).abs() / a.radius
        );
        // steps of at most 2π/n·turns: unwrap the angle
        let mut d = angle(a, p) - angle(a, prev);
        let step = a.sweep / n as f64;
        while d - step > PI {
            d -= TAU;
        }
        while d - step < -PI {
            d += TAU;
        }
        turned += d;
        // the angle turned so far, by the oracle, equals f × the sweep
        let tol = 1e-9 * (1.0 + a.sweep.abs());
        prop_assert!(
            (turned - f * a.sweep).abs() <= tol,
            "after {} of {}: turned {} rad, want {}",
            k,
            n,
            turned,
            f * a.sweep
        );
        // the axial travel is proportional to the angle turned: constant pitch
        let axial = p[ax] - a.start[ax];
        let want = a.axial * turned / a.sweep;
        prop_assert!(
            (axial - want).abs() <= 1e-9 * (1.0 + a.axial.abs()),
            "axial {} at angle {}, want {}",
            axial,
            turned,
            want
        );
        chords += (p - prev).norm();
        prev = p;
    }
    // n equal steps: each chord is √((2r sin(θ/2n))² + (axial/n)²)
    let chord =
        (2.0 * a.radius * (a.sweep.abs() / (2.0 * n as f64)).sin()).hypot(a.axial / n as f64);
    // (each chord from two points rounded at the coordinates' scale)
    let scale = a.start.amax().max(a.center.amax()) + a.radius;
    prop_assert!(
        (chords - n as f64 * chord).abs()
            <= 1e-9 * a.length + 8.0 * f64::EPSILON * scale * n as f64,
        "chords {} vs {}",
        chords,
        n as f64 * chord
    );
    Ok(())
}

#[derive(Clone, Debug)]
struct ArcCase {
    plane: usize,
    ccw: bool,
    /// log10 of the radius, mm
    log_r: f64,
    a0: f64,
    /// fraction of the sweep between its margins; None: a full circle
    u: Option<f64>,
    start: (f64, f64, f64),
    /// normal-axis travel (a helix), mm
    dz: f64,
}

fn arc_case(helix: bool) -> impl Strategy<Value = ArcCase> {
    (
        0..3usize,
        any::<bool>(),
        -3.0..5.0f64,
        0.0..TAU,
        prop_oneof![1 => Just(None), 5 => (0.0..1.0f64).prop_map(Some)],
        (-200.0..200.0f64, -200.0..200.0f64, -200.0..200.0f64),
        if helix {
            (-50.0..50.0f64).boxed()
        } else {
            Just(0.0).boxed()
        },
    )
        .prop_map(|(plane, ccw, log_r, a0, u, start, dz)| ArcCase {
            plane,
            ccw,
            log_r,
            a0,
            u,
            start,
            dz,
        })
}

/// The program of an arc case: (text, start, end, centre, radius and
/// sweep intended).
fn arc_program(c: &ArcCase) -> (String, V3, V3, f64, f64) {
    let (p, q, n) = axes(c.plane);
    let r = 10f64.powf(c.log_r);
    let s = V3::new(q6(c.start.0), q6(c.start.1), q6(c.start.2));
    let mut centre = s;
    centre[p] = q6(s[p] - r * c.a0.cos());
    centre[q] = q6(s[q] - r * c.a0.sin());
    // keep clear of a sweep of 0 or 2π: the rounding to 1 nm moves the
    // end point by up to 1e-6/r rad
    let margin = 0.05 + 1e-4 / r;
    let sweep = match c.u {
        None => TAU,
        Some(u) => margin + u * (TAU - 2.0 * margin),
    };
    let mut e = s;
    if c.u.is_some() {
        let a1 = if c.ccw { c.a0 + sweep } else { c.a0 - sweep };
        e[p] = q6(centre[p] + r * a1.cos());
        e[q] = q6(centre[q] + r * a1.sin());
    }
    e[n] = q6(s[n] + c.dz);
    let letters = [b'I', b'J', b'K'];
    let text = format!(
        "G90 {} G00 {}\nF1000\n{} {} {}{} {}{}\nM30\n",
        PLANES[c.plane],
        xyz(s),
        if c.ccw { "G03" } else { "G02" },
        xyz(e),
        letters[p] as char,
        q6(centre[p] - s[p]),
        letters[q] as char,
        q6(centre[q] - s[q]),
    );
    (text, s, e, r, sweep)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Arcs and helices in every plane, I/J/K form: on their circle, start
    /// and end exact, length r·θ (with the axial travel: √((rθ)² + h²)),
    /// the sweep's sign and size as programmed.
    #[test]
    fn arcs_and_helices_in_every_plane(c in prop_oneof![arc_case(false), arc_case(true)]) {
        let m = big_mill();
        let (text, s, e, r, sweep) = arc_program(&c);
        let mv = moves(&text, Dialect::Cnc836, &m);
        prop_assert_eq!(mv.len(), 2, "{}", text);
        let (line, g) = mv[1];
        prop_assert_eq!(line, 3);
        let Geom::Arc(a) = g else { return Err(TestCaseError::fail("not an arc")) };
        prop_assert_eq!(a.plane.axes(), axes(c.plane));
        prop_assert_eq!(a.start, s);
        prop_assert_eq!(a.end, e);
        prop_assert_eq!(a.sweep > 0.0, c.ccw);
        // the radius as programmed (centre and points rounded to 1 nm)
        prop_assert!((a.radius - r).abs() <= 3e-6 + 1e-12 * r, "radius {} for {}", a.radius, r);
        prop_assert!((a.sweep.abs() - sweep).abs() <= 5e-6 / r + 1e-9, "sweep {} for {}\n{}", a.sweep, sweep, text);
        if c.u.is_none() {
            prop_assert_eq!(a.sweep.abs(), TAU);
        }
        let (_, _, n) = axes(c.plane);
        prop_assert_eq!(a.axial, e[n] - s[n]);
        check_arc(&g, 96)?;
    }

    /// HEIDENHAIN polar arcs G12/G13 about a pole, incremental angle up to
    /// 15 turns (the arc's sweep), optionally with a linear axis (helix):
    /// the centre is the pole, the radius is R, the end is at angle H,
    /// the length is R·|ΔH| (helix: with the axial travel).
    #[test]
    fn polar_arcs_about_the_pole(
        plane in 0..3usize,
        pole in (-100.0..100.0f64, -100.0..100.0f64),
        log_r in -2.0..3.0f64,
        h0 in prop_oneof![-360.0..360.0f64, (-4i32..=4).prop_map(|k| 90.0 * k as f64)],
        dh in prop_oneof![
            (-5400.0..5400.0f64).prop_map(|h| (h * 1000.0).round() / 1000.0),
            (-60i32..=60).prop_map(|k| 90.0 * k as f64),
        ],
        dz in prop_oneof![Just(0.0), -20.0..20.0f64],
    ) {
        prop_assume!(dh.abs() >= 0.01);
        let (p, q, n) = axes(plane);
        let r = q6(10f64.powf(log_r));
        let (pp, pq) = (q6(pole.0), q6(pole.1));
        let h0 = (h0 * 1000.0).round() / 1000.0;
        let letters = [b'I', b'J', b'K'];
        let axis = [b'X', b'Y', b'Z'];
        let dz = q6(dz);
        let text = format!(
            "{} G90 G00 X0 Y0 Z0\n{}{} {}{}\nG10 R{} H{}\nG91 {} H{}{} F2000\nG90\nM30\n",
            PLANES[plane],
            letters[p] as char, pp, letters[q] as char, pq,
            r, h0,
            if dh > 0.0 { "G13" } else { "G12" },
            dh,
            if dz != 0.0 { format!(" {}{}", axis[n] as char, dz) } else { String::new() },
        );
        let m = big_mill();
        let mv = moves(&text, Dialect::Heidenhain, &m);
        let (line, g) = *mv.last().unwrap();
        prop_assert_eq!(line, 4);
        let Geom::Arc(a) = g else { return Err(TestCaseError::fail("not an arc")) };
        // (the centre is projected onto the bisector of start and end: a
        // rounding's worth off the pole)
        let scale = 1.0 + pp.abs().max(pq.abs()) + r;
        prop_assert!((a.center[p] - pp).abs() <= 1e-14 * scale && (a.center[q] - pq).abs() <= 1e-14 * scale,
            "centre ({}, {}), pole ({}, {})", a.center[p], a.center[q], pp, pq);
        prop_assert!((a.radius - r).abs() <= 1e-12 * r.max(1.0), "radius {} for R{}", a.radius, r);
        prop_assert!((a.sweep - dh.to_radians()).abs() <= 1e-12 * dh.abs(), "sweep {} for H{}", a.sweep.to_degrees(), dh);
        let h1 = (h0 + dh).to_radians();
        let want = (pp + r * h1.cos(), pq + r * h1.sin());
        prop_assert!((a.end[p] - want.0).abs() <= 1e-9 * (1.0 + r) && (a.end[q] - want.1).abs() <= 1e-9 * (1.0 + r),
            "end ({}, {}) for ({}, {})", a.end[p], a.end[q], want.0, want.1);
        prop_assert_eq!(a.axial, dz);
        if (h0 + dh) % 90.0 == 0.0 {
            // multiples of 90° land exactly on their point
            let k = ((h0 + dh) / 90.0).rem_euclid(4.0) as usize;
            let exact = [(pp + r, pq), (pp, pq + r), (pp - r, pq), (pp, pq - r)][k];
            prop_assert_eq!((a.end[p], a.end[q]), exact);
        }
        check_arc(&g, 64 * (1 + (dh.abs() / 360.0) as usize))?;
    }

    /// cnc836's helix: G09 with the pitch set by G10, full circles
    /// repeated by G73: every turn climbs exactly the pitch, and the end
    /// after q + 1 turns is z0 + (q + 1) × pitch.
    #[test]
    fn g09_helix_turns_climb_the_pitch(
        plane in 0..3usize,
        log_r in -1.0..3.0f64,
        a0 in 0.0..TAU,
        pitch in -5.0..5.0f64,
        q in 0u32..40,
        ccw in any::<bool>(),
    ) {
        let pitch = q6(pitch);
        prop_assume!(pitch.abs() >= 1e-3);
        let (p, qa, n) = axes(plane);
        let r = 10f64.powf(log_r);
        let s = V3::new(q6(1.0), q6(2.0), q6(3.0));
        let axis = [b'X', b'Y', b'Z'];
        let letters = [b'I', b'J', b'K'];
        let (i, j) = (q6(-r * a0.cos()), q6(-r * a0.sin()));
        let text = format!(
            "N5 {} G90 G00 {}\nN6 F3000\nN10 {}{} G10\nN20 G09 {} {}{} {}{} G73 L20 Q{}\nN30 G98\nN40 M30\n",
            PLANES[plane], xyz(s),
            axis[n] as char, pitch,
            if ccw { "G03" } else { "G02" },
            letters[p] as char, i, letters[qa] as char, j,
            q,
        );
        let m = big_mill();
        let mv = moves(&text, Dialect::Cnc836, &m);
        let arcs: Vec<Geom> = mv.iter().filter(|x| x.0 == 4).map(|x| x.1).collect();
        prop_assert_eq!(arcs.len() as u32, q + 1);
        for (k, g) in arcs.iter().enumerate() {
            let Geom::Arc(a) = g else { return Err(TestCaseError::fail("not an arc")) };
            prop_assert_eq!(a.sweep.abs(), TAU);
            prop_assert_eq!((a.start[p], a.start[qa]), (s[p], s[qa]));
            prop_assert_eq!((a.end[p], a.end[qa]), (s[p], s[qa]));
            // turn k ends at z0 + (k + 1) × pitch
            let want = s[n] + pitch * (k + 1) as f64;
            prop_assert!((a.end[n] - want).abs() <= 1e-9 * (1.0 + want.abs()), "turn {}: {} vs {}", k, a.end[n], want);
            prop_assert!((a.axial - pitch).abs() <= 1e-9 * (1.0 + want.abs()), "turn {}: climbs {}", k, a.axial);
            check_arc(g, 48)?;
        }
    }
}

/// Samples of a program that passes the check; the last one on `end`
/// (without the jerk filter: these tests measure the arcs themselves).
fn run(text: &str, m: &Machine) -> Vec<Sample> {
    let m = &common::exact(m);
    let r = check(StrSource::new(text), Dialect::Cnc836, m);
    assert!(r.ok(), "{}\n{text}", r.message());
    let s: Vec<Sample> = Executor::new(StrSource::new(text), Dialect::Cnc836, m).collect();
    assert_eq!(s.last().unwrap().k, r.ticks);
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// The executor's samples of an arc or helix: every one on the circle
    /// (1e-9 relative), the axial position proportional to the angle, and
    /// the last sample exactly on the end point.
    #[test]
    fn executed_arcs_stay_on_their_circle(c in prop_oneof![arc_case(false), arc_case(true)]) {
        let c = ArcCase { log_r: c.log_r.min(1.5), ..c };
        let m = big_mill();
        let (text, s, e, _, _) = arc_program(&c);
        let mv = moves(&text, Dialect::Cnc836, &m);
        let Geom::Arc(a) = mv[1].1 else { return Err(TestCaseError::fail("not an arc")) };
        let samples = run(&text, &m);
        let on_arc: Vec<&Sample> = samples.iter().filter(|x| x.src.line == 3).collect();
        prop_assert!(!on_arc.is_empty());
        let (_, _, n) = axes(c.plane);
        for x in &on_arc {
            let r = plane_radius(&a, x.pos);
            prop_assert!((r - a.radius).abs() <= 1e-9 * a.radius, "sample {} at radius {} of {}", x.k, r, a.radius);
            let f = (x.pos[n] - s[n]) / (e[n] - s[n]);
            if a.axial != 0.0 {
                prop_assert!((-1e-12..=1.0 + 1e-12).contains(&f));
            }
        }
        let last = samples.last().unwrap();
        prop_assert_eq!(last.pos, e);
        prop_assert_eq!(on_arc.last().unwrap().pos, e);
    }
}

/// The mill with tool 1 of radius `r` and rounded outside corners.
fn mill_with_tool(r: f64) -> Machine {
    let mut m = common::exact(&Machine::builtin_mill());
    m.tools[0].radius_mm = r;
    m.compensation.round_outside_corners = true;
    m
}

/// The side of a point from an element, + left, − right.
fn sign(side: f64) -> f64 {
    if side > 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Runs a closed contour under G41 or G42 (tool radius `r`), entered from
/// `inside` at the contour's first point, and checks every sample of the
/// contour's blocks against the oracle: at distance `r` from the nearest
/// element (within 1e-6 mm), on the programmed side wherever the nearest
/// point is inside an element. Returns the check's errors instead when
/// the program is refused.
fn run_contour(
    contour: &[El],
    blocks: &str,
    inside: (f64, f64),
    g41: bool,
    r: f64,
) -> Result<Result<usize, Vec<String>>, TestCaseError> {
    let first = match contour[0] {
        El::Line(a, _) => a,
        El::Arc(c, rr, a0, _) => (c.0 + rr * a0.cos(), c.1 + rr * a0.sin()),
    };
    let text = format!(
        "N10 G17 G90 G94 M03 S3000 T1\nN20 G00 X{} Y{} Z5\nN30 G01 Z-2 F300\nN40 {} X{} Y{} F600\n{blocks}N900 G40 G01 X{} Y{}\nN910 G00 Z5\nN920 M30\n",
        inside.0, inside.1,
        if g41 { "G41" } else { "G42" },
        first.0, first.1,
        inside.0, inside.1,
    );
    let m = mill_with_tool(r);
    let rep = check(StrSource::new(&text), Dialect::Cnc836, &m);
    if !rep.ok() {
        return Ok(Err(rep.errors.iter().map(|e| e.to_string()).collect()));
    }
    let samples: Vec<Sample> = Executor::new(StrSource::new(&text), Dialect::Cnc836, &m).collect();
    prop_assert_eq!(samples.last().unwrap().k, rep.ticks);
    let first_line = 5;
    let last_line = 4 + contour.len() as u32;
    let want_side = if g41 { 1.0 } else { -1.0 };
    let mut n = 0;
    for x in samples
        .iter()
        .filter(|x| (first_line..=last_line).contains(&x.src.line))
    {
        let pt = (x.pos[0], x.pos[1]);
        let (d, side, inner) = contour
            .iter()
            .map(|e| dist_inner(e, pt))
            .fold((f64::MAX, 0.0, false), |b, v| if v.0 < b.0 { v } else { b });
        prop_assert!(
            (d - r).abs() <= 1e-6,
            "line {}: ({}, {}) is {} mm from the contour, tool radius {}\n{}",
            x.src.line,
            pt.0,
            pt.1,
            d,
            r,
            text
        );
        if inner && (d - r).abs() <= 1e-6 {
            prop_assert_eq!(
                sign(side),
                want_side,
                "line {}: on the wrong side at ({}, {})\n{}",
                x.src.line,
                pt.0,
                pt.1,
                text
            );
        }
        prop_assert_eq!(x.pos[2], -2.0);
        n += 1;
    }
    Ok(Ok(n))
}

/// Intersection of the lines p + s·u and q + t·v.
fn meet(p: (f64, f64), u: (f64, f64), q: (f64, f64), v: (f64, f64)) -> (f64, f64) {
    let den = u.0 * v.1 - u.1 * v.0;
    let s = ((q.0 - p.0) * v.1 - (q.1 - p.1) * v.0) / den;
    (p.0 + s * u.0, p.1 + s * u.1)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random convex polygons (vertices on a circle at random angles),
    /// walked counter-clockwise from the middle of an edge and closed
    /// there, under G41 (inside) or G42 (outside) with a random tool: run
    /// at exactly the tool radius from the contour on the programmed side,
    /// or refused, naming the block, exactly when an edge's offset would
    /// run backwards (computed here from the offset lines).
    #[test]
    fn compensated_convex_polygons(
        gaps in prop::collection::vec(0.2..1.0f64, 3..8),
        size in 8.0..60.0f64,
        r in 0.5..15.0f64,
        g41 in any::<bool>(),
    ) {
        let total: f64 = gaps.iter().sum();
        let (cx, cy) = (250.0, 250.0);
        let mut ang: f64 = 0.0;
        let mut v: Vec<(f64, f64)> = Vec::new();
        for g in &gaps {
            v.push((q6(cx + size * ang.cos()), q6(cy + size * ang.sin())));
            ang += TAU * g / total;
        }
        let nv = v.len();
        let mid = (q6((v[0].0 + v[1].0) / 2.0), q6((v[0].1 + v[1].1) / 2.0));
        // the contour: mid → v1 → … → v[n-1] → v0 → mid
        let mut pts = vec![mid];
        pts.extend_from_slice(&v[1..]);
        pts.push(v[0]);
        pts.push(mid);
        let contour: Vec<El> = pts.windows(2).map(|w| El::Line(w[0], w[1])).collect();
        let mut blocks = String::new();
        for (k, p) in pts[1..].iter().enumerate() {
            blocks += &format!("N{} X{} Y{}\n", 50 + 10 * k, p.0, p.1);
        }
        // the oracle: the offset lines (left for G41) and where
        // neighbours meet; an element is valid when its offset runs forward
        let side = if g41 { 1.0 } else { -1.0 };
        let dir = |a: (f64, f64), b: (f64, f64)| {
            let l = (b.0 - a.0).hypot(b.1 - a.1);
            ((b.0 - a.0) / l, (b.1 - a.1) / l)
        };
        let off = |a: (f64, f64), u: (f64, f64)| (a.0 - side * r * u.1, a.1 + side * r * u.0);
        let us: Vec<(f64, f64)> = pts.windows(2).map(|w| dir(w[0], w[1])).collect();
        let ne = us.len();
        // offset start and end of each element
        let mut starts = vec![off(pts[0], us[0])];
        let mut ends = Vec::new();
        for k in 0..ne - 1 {
            let j = if g41 {
                // inside corners: the offset lines meet
                meet(off(pts[k], us[k]), us[k], off(pts[k + 1], us[k + 1]), us[k + 1])
            } else {
                // outside corners are rounded: each offset ends beside its corner
                off(pts[k + 1], us[k])
            };
            ends.push(j);
            starts.push(if g41 { j } else { off(pts[k + 1], us[k + 1]) });
        }
        ends.push(off(pts[ne], us[ne - 1]));
        let forward: Vec<f64> = (0..ne)
            .map(|k| (ends[k].0 - starts[k].0) * us[k].0 + (ends[k].1 - starts[k].1) * us[k].1)
            .collect();
        prop_assume!(forward.iter().all(|f| f.abs() > 1e-3));
        let want_ok = forward.iter().all(|f| *f > 0.0);
        // enter from the centre (G41) or from outside, beyond the first point
        let (mx, my) = (mid.0 - cx, mid.1 - cy);
        let k = 1.0 + (3.0 * r + 5.0) / mx.hypot(my);
        let from = if g41 { (cx, cy) } else { (q6(cx + k * mx), q6(cy + k * my)) };
        match run_contour(&contour, &blocks, from, g41, r)? {
            Ok(n) => {
                prop_assert!(want_ok, "ran, but an offset runs backwards: {:?}\n{}", forward, blocks);
                prop_assert!(n > 100, "{} samples", n);
            }
            Err(errs) => {
                prop_assert!(!want_ok, "refused: {:?}\n{}", errs, blocks);
                prop_assert!(nv >= 3);
                for e in &errs {
                    prop_assert!(e.starts_with("line "), "{}", e);
                    prop_assert!(e.contains("radius compensation: block N") && e.contains("is too short for the tool radius"), "{}", e);
                }
            }
        }
    }

    /// Rounded rectangles (lines and tangent corner arcs), counter-clockwise
    /// from the middle of the bottom edge, under G41 (inside: the corner
    /// arcs are concave for the tool) or G42 (outside): at exactly the tool
    /// radius from the contour, or refused with "not larger than the tool
    /// radius" exactly when G41 and the tool is not smaller than the
    /// corner radius.
    #[test]
    fn compensated_rounded_rectangles(
        w in 2.0..80.0f64,
        h in 2.0..80.0f64,
        rc in 0.5..20.0f64,
        r in 0.5..10.0f64,
        g41 in any::<bool>(),
    ) {
        let (rc, r) = (q6(rc), q6(r));
        prop_assume!((r - rc).abs() > 1e-3);
        let (x0, y0) = (200.0, 200.0);
        let (x1, y1) = (q6(x0 + 2.0 * rc + w), q6(y0 + 2.0 * rc + h));
        let xm = q6((x0 + x1) / 2.0);
        use std::f64::consts::FRAC_PI_2 as H;
        let contour = vec![
            El::Line((xm, y0), (x1 - rc, y0)),
            El::Arc((x1 - rc, y0 + rc), rc, -H, H),
            El::Line((x1, y0 + rc), (x1, y1 - rc)),
            El::Arc((x1 - rc, y1 - rc), rc, 0.0, H),
            El::Line((x1 - rc, y1), (x0 + rc, y1)),
            El::Arc((x0 + rc, y1 - rc), rc, H, H),
            El::Line((x0, y1 - rc), (x0, y0 + rc)),
            El::Arc((x0 + rc, y0 + rc), rc, 2.0 * H, H),
            El::Line((x0 + rc, y0), (xm, y0)),
        ];
        let blocks = format!(
            "N50 G01 X{} Y{}\nN60 G03 X{} Y{} I0 J{}\nN70 G01 Y{}\nN80 G03 X{} Y{} I{} J0\nN90 G01 X{}\nN100 G03 X{} Y{} I0 J{}\nN110 G01 Y{}\nN120 G03 X{} Y{} I{} J0\nN130 G01 X{}\n",
            q6(x1 - rc), y0,
            x1, q6(y0 + rc), rc,
            q6(y1 - rc),
            q6(x1 - rc), y1, -rc,
            q6(x0 + rc),
            x0, q6(y1 - rc), -rc,
            q6(y0 + rc),
            q6(x0 + rc), y0, rc,
            xm,
        );
        let inside = (xm, q6((y0 + y1) / 2.0));
        let outside = (xm, q6(y0 - r - 5.0));
        let want_ok = !g41 || r < rc;
        match run_contour(&contour, &blocks, if g41 { inside } else { outside }, g41, r)? {
            Ok(n) => {
                prop_assert!(want_ok, "ran with a tool of {} in corners of {}", r, rc);
                prop_assert!(n > 100);
            }
            Err(errs) => {
                prop_assert!(!want_ok, "refused: {:?}\n{}", errs, blocks);
                // each corner arc named; a tool wider than the pocket also
                // makes the lines between them run backwards
                for b in ["N60", "N80", "N100", "N120"] {
                    let want = format!("radius compensation: the arc of block {b} (radius ");
                    let tool = format!(") is not larger than the tool radius {}: the tool would cut into the contour", num(r));
                    prop_assert!(errs.iter().any(|e| e.contains(&want) && e.contains(&tool)), "{}…{} missing in {:?}", want, tool, errs);
                }
                for e in &errs {
                    prop_assert!(e.contains("is not larger than the tool radius") || (e.contains("is too short for the tool radius") && 2.0 * r > 2.0 * rc + w.min(h)), "{}", e);
                }
            }
        }
    }
}

/// A polar arc's radius came from the start point's coordinates, (pole +
/// R) − pole, which is R only up to a rounding: H+450 after H360 landed
/// 4e-15 mm off pole + (0, R). (Found by `polar_arcs_about_the_pole`.)
#[test]
fn a_polar_arc_after_a_polar_move_lands_exactly_on_pole_plus_r() {
    let m = big_mill();
    let text = "G17 G90 G00 X1 Y1 Z1\nI24.907143 J0\nG10 R37.069166 H360\nG91 G13 H450 F2000\nG90 G12 H0\nG13 H-90\nM30\n";
    let mv = moves(text, Dialect::Heidenhain, &m);
    let ends: Vec<V3> = mv.iter().map(|(_, g)| g.end()).collect();
    assert_eq!(ends.len(), 5);
    assert_eq!((ends[1].x, ends[1].y), (24.907143 + 37.069166, 0.0));
    assert_eq!((ends[2].x, ends[2].y), (24.907143, 37.069166));
    assert_eq!((ends[3].x, ends[3].y), (24.907143 + 37.069166, 0.0));
    assert_eq!((ends[4].x, ends[4].y), (24.907143, -37.069166));
    let Geom::Arc(a) = mv[2].1 else { panic!() };
    assert_eq!(a.sweep, 450f64.to_radians());
    assert!((a.length - 37.069166 * 450f64.to_radians()).abs() < 1e-12);
}

/// A polar arc ending close to its start had its centre moved off the
/// pole onto the bisector of start and end: by 5.5e-13 mm for three turns
/// less 0.17° at R1 (the rounding of the points over their distance,
/// growing as the end nears the start). The pole is the centre.
/// (Found by `polar_arcs_about_the_pole`.)
#[test]
fn a_nearly_full_polar_arc_turns_about_its_pole() {
    let m = big_mill();
    for (pole, dh) in [
        (-27.407963f64, -1079.83f64),
        (3.3, 359.9999999),
        (-71.25, -0.0001),
    ] {
        let text = format!(
            "G17 G90 G00 X1 Y1 Z1\nI{pole} J0\nG10 R1 H0\nG91 {} H{dh} F2000\nG90\nM30\n",
            if dh > 0.0 { "G13" } else { "G12" }
        );
        let mv = moves(&text, Dialect::Heidenhain, &m);
        let Geom::Arc(a) = mv[2].1 else { panic!() };
        assert_eq!(
            (a.center.x, a.center.y, a.radius),
            (pole, 0.0, 1.0),
            "H{dh}"
        );
        assert_eq!(a.sweep, dh.to_radians());
        let g = Geom::Arc(a);
        for k in 0..=1000 {
            let p = g.eval(a.length * k as f64 / 1000.0);
            assert!(
                ((p.x - pole).hypot(p.y) - 1.0).abs() <= 1e-13,
                "H{dh}: {p:?}"
            );
        }
    }
}
