//! Corner blending's own tests (beside blend.rs, which they would take over 800 lines).

use super::*;

fn mv(a: V3, b: V3) -> Event {
    Event::Move {
        geom: Geom::Line { start: a, end: b },
        feed: Feed::PerMin(1000.0),
        src: Src::default(),
    }
}

#[test]
fn a_right_angle_is_rounded_within_the_tolerance() {
    let mut b = Blender::default();
    let mut out = VecDeque::new();
    let o = V3::zeros();
    let c = V3::new(10.0, 0.0, 0.0);
    let e = V3::new(10.0, 10.0, 0.0);
    b.push(mv(o, c), 0.1, &mut out);
    b.push(mv(c, e), 0.1, &mut out);
    b.flush(&mut out);
    assert_eq!(out.len(), 3);
    let Event::Move {
        geom: Geom::Arc(arc),
        ..
    } = out[1]
    else {
        panic!("an arc")
    };
    // r (√2 − 1) = 0.1
    let r = 0.1 / (2f64.sqrt() - 1.0);
    assert!((arc.radius - r).abs() < 1e-12);
    let mid = arc.start + (arc.end - arc.start) * 0.5;
    let apex = arc.center + (mid - arc.center).normalize() * arc.radius;
    assert!(((apex - c).norm() - 0.1).abs() < 1e-12);
    // the lines are tangent to it and keep their outer ends
    let Event::Move { geom: g0, .. } = out[0] else {
        panic!()
    };
    let Event::Move { geom: g2, .. } = out[2] else {
        panic!()
    };
    assert_eq!(g0.start(), o);
    assert_eq!(g2.end(), e);
    let ga = Geom::Arc(arc);
    assert!((g0.end_tangent() - ga.start_tangent()).norm() < 1e-12);
    assert!((ga.end_tangent() - g2.start_tangent()).norm() < 1e-12);
}

#[test]
fn a_polyline_of_equal_lines_is_blended_into_arcs_of_its_circle() {
    // 3° per line around R10 (a CAM circle): every blend takes half of
    // both its lines, so its radius is R·cos(1.5°) and no line is left
    // between two blends (each blend taking half of what the last one
    // left would give arcs of 2/3 of that radius)
    let (r0, step) = (10.0, 3f64.to_radians());
    let pt = |k: usize| {
        let a = step * k as f64;
        V3::new(r0 * a.cos(), r0 * a.sin(), 0.0)
    };
    let mut b = Blender::default();
    let mut out = VecDeque::new();
    // (at 0.02 no two lines merge: a chord over two of them is
    // R(1 − cos 3°) = 13.7 µm off the middle vertex, over 0.01)
    for k in 0..20 {
        b.push(mv(pt(k), pt(k + 1)), 0.02, &mut out);
    }
    b.flush(&mut out);
    let geoms: Vec<Geom> = out
        .iter()
        .map(|ev| match ev {
            Event::Move { geom, .. } => *geom,
            _ => panic!("a move"),
        })
        .collect();
    // line, then the 19 blends without lines between, then the rest of
    // the last line
    assert_eq!(geoms.len(), 21, "{geoms:?}");
    assert!(matches!(geoms[0], Geom::Line { .. }));
    assert!(matches!(geoms[20], Geom::Line { .. }));
    let want = r0 * (0.5 * step).cos();
    for (k, g) in geoms[1..20].iter().enumerate() {
        let Geom::Arc(arc) = g else {
            panic!("blend {k} is not an arc: {g:?}")
        };
        assert!((arc.radius - want).abs() < 1e-9, "{k}: {}", arc.radius);
        // its deviation from the corner stays within the tolerance
        let apex_dev = arc.radius * (1.0 / (0.5 * step).cos() - 1.0);
        assert!(apex_dev <= 0.02, "{apex_dev}");
    }
    // the path is continuous: each piece starts where the last ended
    for w in geoms.windows(2) {
        assert!((w[0].end() - w[1].start()).norm() < 1e-12);
    }
    assert_eq!(geoms[0].start(), pt(0));
    assert_eq!(geoms[20].end(), pt(20));
}

/// The arc of a blended corner between `a→c` and `c→e` at `tol`.
#[test]
fn a_corner_whose_blend_is_slower_than_a_stop_is_left_exact() {
    // 1000 mm/s², 100 mm/s, 50 m/s³: path filter 80 samples at 1 kHz
    let stops = StopCost {
        jerk: JerkBudget::new(0.001, 80, Some(5e4)),
        accel: 1000.0,
        vmax: 100.0,
        amax: V3::repeat(1000.0),
        vmax_axes: V3::repeat(100.0),
        exact_stop_cos: 2f64.to_radians().cos(),
    };
    let corner = |turn_deg: f64, f: f64, tol: f64, stops: Option<StopCost>| {
        let mut b = Blender::new(0.0, stops);
        let mut out = VecDeque::new();
        let (o, c) = (V3::zeros(), V3::new(20.0, 0.0, 0.0));
        let t = turn_deg.to_radians();
        let e = c + V3::new(t.cos(), t.sin(), 0.0) * 20.0;
        let line = |a: V3, b: V3| Event::Move {
            geom: Geom::Line { start: a, end: b },
            feed: Feed::PerMin(f),
            src: Src::default(),
        };
        b.push(line(o, c), tol, &mut out);
        b.push(line(c, e), tol, &mut out);
        b.flush(&mut out);
        out.iter()
            .find_map(|ev| match ev {
                Event::Move {
                    geom: Geom::Arc(a), ..
                } => Some(a.radius),
                _ => None,
            })
            .unwrap_or(0.0)
    };
    // a right angle at 100 mm/s within 10 µm: r = 24 µm, a speed cap
    // of 1.6 mm/s (a_n 99 mm/s²) held over 0.25 mm of either line;
    // a stop costs 0.1 s and the 88-sample hold
    let r = 0.01 / (2f64.sqrt() - 1.0);
    assert_eq!(corner(90.0, 6000.0, 0.01, Some(stops)), 0.0);
    assert!((corner(90.0, 6000.0, 0.01, None) - r).abs() < 1e-12);
    // a 10° turn at 10 mm/s within 0.2 mm: r = 52.4 mm, 10 mm/s
    // through it: the blend pays
    let r10 = 0.2 / (1.0 / 5f64.to_radians().cos() - 1.0);
    assert!((corner(10.0, 600.0, 0.2, Some(stops)) - r10).abs() < 1e-9);
    // with no jerk caps (no limit) every blend pays
    let none = StopCost {
        jerk: JerkBudget::new(0.001, 1, None),
        ..stops
    };
    assert!((corner(90.0, 6000.0, 0.01, Some(none)) - r).abs() < 1e-12);
}

fn blend_of(a: V3, c: V3, e: V3, tol: f64) -> Option<Arc> {
    let mut b = Blender::default();
    let mut out = VecDeque::new();
    b.push(mv(a, c), tol, &mut out);
    b.push(mv(c, e), tol, &mut out);
    b.flush(&mut out);
    out.iter().find_map(|ev| match ev {
        Event::Move {
            geom: Geom::Arc(arc),
            ..
        } => Some(*arc),
        _ => None,
    })
}

#[test]
fn a_corner_climbing_at_one_slope_is_blended_with_a_helix() {
    // a 90° turn in XY, both lines falling 1 mm per 10 mm in the plane
    let (a, c, e) = (
        V3::new(0.0, 0.0, 0.0),
        V3::new(10.0, 0.0, -1.0),
        V3::new(10.0, 10.0, -2.0),
    );
    let arc = blend_of(a, c, e, 0.1).expect("a helical blend");
    assert_eq!(arc.plane, Plane::XY);
    // 90 % of the tolerance in the plane: r (√2 − 1) = 0.09
    let r = 0.09 / (2f64.sqrt() - 1.0);
    assert!((arc.radius - r).abs() < 1e-12, "{}", arc.radius);
    // it climbs from line to line: the trims are r in the plane, so
    // 0.1·r of Z on each side
    assert!(
        (arc.start.z - (-1.0 + 0.1 * r)).abs() < 1e-12,
        "{}",
        arc.start.z
    );
    assert!(
        (arc.end.z - (-1.0 - 0.1 * r)).abs() < 1e-12,
        "{}",
        arc.end.z
    );
    assert!((arc.axial + 0.2 * r).abs() < 1e-12);
    // the junctions turn by about slope·(2·tan(φ/2)/φ − 1): 1.6° here
    let ga = Geom::Arc(arc);
    let g0 = Geom::Line { start: a, end: c };
    let turn = g0
        .end_tangent()
        .dot(&ga.start_tangent())
        .acos()
        .to_degrees();
    assert!(turn > 1.5 && turn < 1.7, "{turn}");
    // CAM-rounded: slopes 0.1 and 0.1001 still blend; 0.1 and 0.2 do not
    assert!(blend_of(a, c, V3::new(10.0, 10.0, -2.001), 0.1).is_some());
    assert!(blend_of(a, c, V3::new(10.0, 10.0, -3.0), 0.1).is_none());
}

/// The moves `b` makes of the polyline through `pts` at `tol`.
fn blended(pts: &[V3], tol: f64) -> Vec<Geom> {
    let mut b = Blender::default();
    let mut out = VecDeque::new();
    for w in pts.windows(2) {
        b.push(mv(w[0], w[1]), tol, &mut out);
    }
    b.flush(&mut out);
    out.iter()
        .map(|ev| match ev {
            Event::Move { geom, .. } => *geom,
            _ => panic!("a move"),
        })
        .collect()
}

/// Largest distance of `p` from the polyline through `pts`.
fn dist_to_polyline(p: V3, pts: &[V3]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let t = ((p - w[0]).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
            (p - (w[0] + d * t)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_cam_polyline_rounded_to_a_micrometre_is_merged_and_stays_within_the_tolerance() {
    // an R20 arc of 0.1 mm lines, every vertex rounded to 1 µm: the
    // turn per vertex is 0.29° on the curve but 0–1.28° as rounded, so
    // blends into the programmed angles would have radii from 4.5 mm
    // up (a tenth of them under 7.2 mm)
    let (r0, step) = (20.0, 0.005);
    let pts: Vec<V3> = (0..=400)
        .map(|k| {
            let a = step * k as f64;
            let round = |x: f64| (x * 1000.0).round() / 1000.0;
            V3::new(round(r0 * a.cos()), round(r0 * a.sin()), 0.0)
        })
        .collect();
    let tol = 0.01;
    let geoms = blended(&pts, tol);
    // merged: lines of about √(8·R·tol/2) = 0.9 mm, 9 programmed lines
    // each, and an arc between each two of them
    let lines = geoms
        .iter()
        .filter(|g| matches!(g, Geom::Line { .. }))
        .count();
    let arcs: Vec<&Arc> = geoms
        .iter()
        .filter_map(|g| match g {
            Geom::Arc(a) => Some(a),
            _ => None,
        })
        .collect();
    assert!(lines < 400 / 6, "{lines} lines");
    assert!(arcs.len() > 30, "{} arcs", arcs.len());
    // the blends follow the curve, not the rounding: radii within 10 %
    // of R, but the last, next to the short rest of the polyline
    // (18.3–20.9 mm and 11.8 mm)
    for a in &arcs[..arcs.len() - 1] {
        assert!((a.radius - r0).abs() < 0.1 * r0, "{}", a.radius);
    }
    // continuous, from the first point to the last
    assert_eq!(geoms[0].start(), pts[0]);
    assert_eq!(geoms.last().map(|g| g.end()), Some(pts[400]));
    for w in geoms.windows(2) {
        assert!((w[0].end() - w[1].start()).norm() < 1e-12);
    }
    // every point of the new path within the tolerance of the
    // programmed polyline (lines at 50 points, arcs at 50 angles)
    let mut worst: f64 = 0.0;
    for g in &geoms {
        for k in 0..=50 {
            let f = k as f64 / 50.0;
            let p = match g {
                Geom::Line { start, end } => start + (end - start) * f,
                Geom::Arc(a) => {
                    let t = a.theta0 + a.sweep * f;
                    a.center + V3::new(a.radius * t.cos(), a.radius * t.sin(), 0.0)
                }
            };
            worst = worst.max(dist_to_polyline(p, &pts));
        }
    }
    assert!(worst <= tol && worst > 0.5 * tol, "{worst}");
}

#[test]
fn lines_that_turn_back_or_leave_half_the_tolerance_are_not_merged() {
    let tol = 0.01;
    // a zigzag of 4 µm amplitude turning back along X: within the
    // tolerance of a line, but not in order along it
    let back = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(0.5, 0.004, 0.0),
        V3::new(2.0, 0.0, 0.0),
    ];
    let g = blended(&back, tol);
    assert!(
        g.iter().filter(|g| matches!(g, Geom::Line { .. })).count() >= 2,
        "{g:?}"
    );
    assert_eq!(g.last().map(|g| g.end()), Some(back[3]));
    // a vertex 6 µm off the line through its neighbours: over half of
    // 0.01, so the corner is blended, not merged; at 4 µm it merges
    for (off, merged) in [(0.006, false), (0.004, true)] {
        let pts = [
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, off, 0.0),
            V3::new(2.0, 0.0, 0.0),
        ];
        let g = blended(&pts, tol);
        assert_eq!(g.len() == 1, merged, "{off}: {g:?}");
        if merged {
            assert_eq!(
                g[0],
                Geom::Line {
                    start: pts[0],
                    end: pts[2]
                }
            );
        }
    }
    // a feed change ends the run: two lines at different feeds stay two
    let mut b = Blender::default();
    let mut out = VecDeque::new();
    let (p0, p1, p2) = (
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.0, 0.0, 0.0),
        V3::new(2.0, 0.0, 0.0),
    );
    b.push(mv(p0, p1), tol, &mut out);
    b.push(
        Event::Move {
            geom: Geom::Line { start: p1, end: p2 },
            feed: Feed::PerMin(500.0),
            src: Src::default(),
        },
        tol,
        &mut out,
    );
    b.flush(&mut out);
    assert_eq!(out.len(), 2, "{out:?}");
}
