use super::*;

#[test]
fn beside_a_line_an_arc_fed_slower_than_its_end_cap_keeps_the_ends_caps() {
    // (a higher speed cap lowers the tangential acceleration cap: an
    // arc beside a line takes the higher one only as far as its feed)
    let jb = JerkBudget::new(0.001, 40, Some(2.0e5));
    let kappa = 0.5;
    let end = jb.arc_caps(kappa, ArcPart::End);
    let beside = jb.arc_caps(kappa, ArcPart::Beside);
    assert!(
        beside.0 > end.0 * 1.3 && beside.1 < end.1,
        "{end:?} {beside:?}"
    );
    assert_eq!(jb.arc_caps_below(kappa, ArcPart::Beside, 0.9 * end.0), end);
    let v = 0.5 * (end.0 + beside.0);
    let (vb, ab) = jb.arc_caps_below(kappa, ArcPart::Beside, v);
    assert_eq!(vb, v);
    assert!((ab * v * kappa - TURN_JERK_SHARE * 2.0e5).abs() < 1e-6);
    assert_eq!(jb.arc_caps_below(kappa, ArcPart::Beside, 1e9), beside);
}

#[test]
fn an_arcs_inside_keeps_its_budgets_and_is_never_slower_than_its_ends() {
    for j in [2.0e4, 5.0e4, 1.0e5, 3.0e5, 1.0e6] {
        for m_s in [4, 40, 400] {
            let jb = JerkBudget::new(0.001, m_s, Some(j));
            let w = jb.step_span();
            for r in [0.01, 0.1, 1.0, 2.0, 8.0, 50.0, 1000.0] {
                let kappa = 1.0 / r;
                let (v_end, a_end) = jb.arc_caps(kappa, ArcPart::End);
                let (v_b, a_b) = jb.arc_caps(kappa, ArcPart::Beside);
                let (v, a) = jb.arc_caps(kappa, ArcPart::Inside);
                assert!(v_end <= v_b && v_b <= v.max(v_end), "{j} {r}");
                // beside a line: the normal acceleration within b_step
                // and a_dev, its turn over W within a quarter of b_step
                if v_b > v_end {
                    assert!(v_b * v_b * kappa <= jb.b_step.min(jb.a_dev) * (1.0 + 1e-12));
                    assert!(
                        v_b * v_b * v_b * kappa * kappa * w <= 0.25 * jb.b_step * (1.0 + 1e-12)
                    );
                    assert!(a_b * v_b * kappa <= TURN_JERK_SHARE * j * (1.0 + 1e-12));
                }
                assert!(v >= v_end && v.is_finite() && a > 0.0, "{j} {r}");
                // at the ends: the normal acceleration within a_n
                assert!(v_end * v_end * kappa <= jb.a_n * (1.0 + 1e-12));
                assert!(a_end * v_end * kappa <= TURN_JERK_SHARE * j * (1.0 + 1e-12));
                if v > v_end {
                    // inside: the offset, the turn and the growth
                    let q = 0.25 * jb.b_step * (1.0 + 1e-12);
                    assert!(v * v * kappa <= jb.a_dev * (1.0 + 1e-12), "{j} {r}");
                    assert!(v * v * v * kappa * kappa * w <= q, "{j} {r}");
                    assert!(2.0 * v * a * kappa * w <= 2.0 * q, "{j} {r}");
                    assert!(a * v * kappa <= TURN_JERK_SHARE * j * (1.0 + 1e-12));
                }
            }
        }
    }
}

#[test]
fn high_jerk_machines_run_the_single_average_and_low_jerk_ones_the_caps() {
    for (m, mm, (ms, mf)) in [
        (crate::machine::Machine::builtin_mill(), 4, (40, 6)),
        (crate::machine::Machine::builtin_lathe(), 5, (50, 6)),
    ] {
        // the bundled 200 m/s³: the path filter, the XYZ filter and
        // the caps
        let b = m.jerk_budget();
        assert_eq!(
            (b.m_s, b.m_f, b.hold_ticks()),
            (ms, mf, (ms + mf - 2) as u64)
        );
        assert!(b.limited() && b.filtered());
        assert_eq!(
            b,
            JerkBudget::new(m.dt(), m.smoothing_samples(), Some(2.0e5))
        );
        assert!(b.error_mm() <= XYZ_FILTER_ERROR_MM * (1.0 + 1e-12));
        // 1000 m/s³ under G64 P0.01: one XYZ moving average of M
        // samples, no caps
        let mut high = m.clone();
        for a in &mut high.axes {
            a.max_jerk_mm_s3 = Some(1.0e6);
        }
        high.planner.path_tolerance_mm = 0.01;
        let b = high.jerk_budget();
        assert_eq!((b.m_s, b.m_f, b.hold_ticks()), (1, mm, mm as u64 - 1));
        assert!(!b.limited() && b.filtered());
        assert_eq!(b.error_mm(), high.single_average_error_mm());
        assert!(b.error_mm() <= crate::shares::SINGLE_AVERAGE_ERROR_MM);
        assert_eq!(
            b.arc_caps(0.1, ArcPart::End),
            (f64::INFINITY, f64::INFINITY)
        );
        assert_eq!(b.kink_cap(0.5), f64::INFINITY);
        // but under G61 (and P 0.001) the average would cut arcs by more
        // than the 1 µm an exact path may be off: the caps, and back to
        // the average under P0.01
        assert!(high.single_average_error_mm() > 2.0 * XYZ_FILTER_ERROR_MM);
        for tol in [0.0, 0.001] {
            let g61 = b.for_tolerance(tol);
            assert!(g61.limited() && g61.m_s == high.smoothing_samples() && g61.m_f > 1);
            assert!(g61.error_mm() <= XYZ_FILTER_ERROR_MM * (1.0 + 1e-12));
            assert_eq!(g61.for_tolerance(0.01), b);
        }
        high.planner.path_tolerance_mm = 0.0;
        assert_eq!(high.jerk_budget(), b.for_tolerance(0.0));
        // 50 m/s³: the caps, a longer path filter
        let mut low = m;
        for a in &mut low.axes {
            a.max_jerk_mm_s3 = Some(5.0e4);
        }
        let b = low.jerk_budget();
        assert!(b.limited() && b.m_s > ms && b.m_f > mf);
        assert_eq!(
            b,
            JerkBudget::new(low.dt(), low.smoothing_samples(), Some(5.0e4))
        );
        assert!(b.error_mm() <= XYZ_FILTER_ERROR_MM * (1.0 + 1e-12));
    }
}

#[test]
fn pieces_are_in_order_within_the_move() {
    for reach in [0.05, 0.5, 3.0, 20.0] {
        for length in [0.01, 0.1, 1.0, 5.0, 40.0, 300.0] {
            for inner in [None, Some(0.3 * length), Some(2.0 * reach), Some(length)] {
                let Some((cuts, n)) = piece_cuts(reach, length, inner) else {
                    continue;
                };
                let cuts = &cuts[..n];
                assert!((2..=MAX_CUTS).contains(&n));
                assert!(cuts[0] > 0.0 && cuts[n - 1] < length, "{cuts:?}");
                assert!(
                    cuts.windows(2).all(|c| c[0] < c[1]),
                    "{reach} {length} {cuts:?}"
                );
            }
        }
    }
}
