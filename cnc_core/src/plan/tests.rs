//! The planner's own tests (beside plan.rs, which they would take over 800 lines).

use super::*;
use crate::jerk::JerkBudget;
use crate::machine::Machine;

/// A polyline from the origin through `ends` at F6000 on the bundled
/// mill, planned to a stop: the pieces made beyond the programmed
/// moves and every move's profile, in order.
fn planned(ends: &[V3]) -> (u64, Vec<Profile>) {
    let mut p = Planner::new(PlanLimits::from_machine(&Machine::builtin_mill()));
    let mut at = V3::new(0.0, 0.0, 0.0);
    for &end in ends {
        p.push(Event::Move {
            geom: Geom::Line { start: at, end },
            feed: Feed::PerMin(6000.0),
            src: Src::default(),
        });
        at = end;
    }
    p.flush();
    let mut out = Vec::new();
    while let Some(it) = p.pop() {
        if let Item::Move(m) = it {
            out.push(m.profile);
        }
    }
    (p.split_extra(), out)
}

#[test]
fn lines_between_stops_stay_whole_and_smooth_neighbours_cut_their_ends() {
    assert!(PlanLimits::from_machine(&Machine::builtin_mill())
        .jerk
        .limited());
    // a corner of 90° is a stop: both lines whole, each from rest to rest
    let (extra, p) = planned(&[V3::new(50.0, 0.0, 0.0), V3::new(50.0, 50.0, 0.0)]);
    assert_eq!((extra, p.len()), (0, 2));
    assert!(p.iter().all(|p| p.v0 == 0.0 && p.v1 == 0.0));
    assert_eq!(p[0].vp, 100.0);
    // two lines in line: each cut towards the junction and the stops,
    // the junction passed at speed
    let (extra, p) = planned(&[V3::new(50.0, 0.0, 0.0), V3::new(100.0, 0.0, 0.0)]);
    assert!(extra >= 4, "{extra}");
    assert_eq!(p.len() as u64, 2 + extra);
    let total: f64 = p.iter().map(|p| p.length).sum();
    assert!((total - 100.0).abs() < 1e-9, "{total}");
    let mid = p.iter().scan(0.0, |s, p| {
        *s += p.length;
        Some((*s, p.v1))
    });
    let at_junction = mid.filter(|(s, _)| (s - 50.0).abs() < 1e-9).map(|x| x.1);
    assert_eq!(at_junction.collect::<Vec<_>>(), vec![100.0]);
}

#[test]
fn a_fine_kink_costs_its_moves_two_percent_a_kink_fifteen() {
    // without a jerk limit (no pieces): X at 2000 mm/s², lines along
    // X turning into Z by `dz` per mm at the junction
    let m = Machine::builtin_mill();
    let lim = PlanLimits {
        jerk: JerkBudget::none(m.dt()),
        ..PlanLimits::from_machine(&m)
    };
    let run = |dz: f64| {
        let mut p = Planner::new(lim);
        let (a, b, c) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(100.0, 0.0, 0.0),
            V3::new(200.0, 0.0, 100.0 * dz),
        );
        for (s, e) in [(a, b), (b, c)] {
            p.push(Event::Move {
                geom: Geom::Line { start: s, end: e },
                feed: Feed::PerMin(6000.0),
                src: Src::default(),
            });
        }
        p.flush();
        let mut out = Vec::new();
        while let Some(it) = p.pop() {
            if let Item::Move(m) = it {
                out.push(m.profile);
            }
        }
        assert_eq!(out.len(), 2);
        (out[0].a, out[0].v1)
    };
    // the fastest path speed (X, Y 250, Z 150 mm/s): 391 mm/s; a fine
    // kink changes a unit tangent's component by at most 0.02·a·dt /
    // 391 per axis (Z: 0.02 · 1500 · 0.001 / 391 = 7.7e-5)
    let top = (250f64.powi(2) * 2.0 + 150f64.powi(2)).sqrt();
    let fine_dz = 0.5 * 0.02 * 1500.0 * 0.001 / top;
    let (a, v1) = run(fine_dz);
    assert!((a - 0.98 * 2000.0).abs() < 1e-6, "{a}");
    assert_eq!(v1, 100.0, "passed at the feed");
    // at the fine limit itself: the same
    let (a, _) = run(2.0 * fine_dz);
    assert!((a - 0.98 * 2000.0).abs() < 1e-6, "{a}");
    // past the fine limit: a kink, 15 % kept for its jump, and the
    // junction speed capped so the jump stays within it
    let (a, v1) = run(3.0 * fine_dz);
    assert!((a - 0.85 * 2000.0).abs() < 1e-6, "{a}");
    assert_eq!(v1, 100.0);
    // in line: the whole acceleration
    let (a, _) = run(0.0);
    assert_eq!(a, 2000.0);
}

#[test]
fn arcs_that_continue_one_circle_run_at_the_inside_speed_and_its_ends_at_the_end_cap() {
    // the bundled mill at 50 m/s³: a circle R10 programmed as 36 arcs of
    // 10° at F6000. Each junction continues the circle, so every arc but
    // the first and the last is planned as an arc's inside; as separate
    // arcs each would be an end, capped at √(a_n·R)
    let mut m = Machine::builtin_mill();
    for a in &mut m.axes {
        a.max_jerk_mm_s3 = Some(5.0e4);
    }
    let lim = PlanLimits::from_machine(&m);
    let (end_cap, _) = lim.jerk.arc_caps(0.1, ArcPart::End);
    let (inside_cap, _) = lim.jerk.arc_caps(0.1, ArcPart::Inside);
    // (31.5 and 49.3 mm/s: the inside's offset within the XYZ filter's
    // 1 µm allows more than the ends' a_n)
    assert!(end_cap > 31.0 && end_cap < 32.0, "{end_cap}");
    assert!(inside_cap > 49.0 && inside_cap < 50.0, "{inside_cap}");
    let mut p = Planner::new(lim);
    let c = V3::new(100.0, 100.0, 0.0);
    let at = |k: usize| {
        let a = (10.0 * k as f64).to_radians();
        V3::new(c.x + 10.0 * a.cos(), c.y + 10.0 * a.sin(), 0.0)
    };
    for k in 0..36 {
        p.push(Event::Move {
            geom: Geom::Arc(crate::geom::Arc::new(
                at(k),
                at(k + 1),
                c,
                crate::geom::Plane::XY,
                true,
                0,
            )),
            feed: Feed::PerMin(6000.0),
            src: Src {
                line: k as u32 + 1,
                block_no: None,
            },
        });
    }
    p.flush();
    let mut by_line = vec![0.0f64; 37];
    while let Some(it) = p.pop() {
        if let Item::Move(mv) = it {
            let l = mv.src.line as usize;
            by_line[l] = by_line[l].max(mv.profile.vp);
        }
    }
    // the middle of the circle at the inside's cap, to rounding
    let mid = by_line[18];
    assert!(
        (mid - inside_cap).abs() < 1e-6 * inside_cap,
        "{mid} against {inside_cap}"
    );
    // the first and the last arc (ends, meeting a stop) at most the end cap
    assert!(by_line[1] <= end_cap * (1.0 + 1e-9), "{}", by_line[1]);
    assert!(by_line[36] <= end_cap * (1.0 + 1e-9), "{}", by_line[36]);
}
