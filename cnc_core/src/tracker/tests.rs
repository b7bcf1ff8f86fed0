//! The spindle tracker's tests (a file of their own: tracker.rs would
//! be over 800 lines).
use super::*;

#[test]
fn tracker_predicts_a_steady_spindle_within_half_a_count() {
    let mut tr = SpindleTracker::default();
    let cpr = 4096.0;
    let rps = 2000.0 / 60.0;
    let mut worst: f64 = 0.0;
    for k in 0..200 {
        let t = k as f64 * 0.001;
        let true_counts = |t: f64| (rps * t + 0.123) * cpr;
        tr.push(EncoderReading {
            t,
            count: true_counts(t).floor() as i64,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: 0,
        });
        if k > 20 {
            let p = tr.predict(t + 0.001, t + 0.001).unwrap().0;
            worst = worst.max((p - true_counts(t + 0.001)).abs());
        }
    }
    assert!(worst < 0.5, "worst {worst}");
    let rpm = tr.predict(0.2, 0.2).unwrap().1 / cpr * 60.0;
    assert!((rpm - 2000.0).abs() < 1.0, "{rpm}");
}

/// The predicted angle's third difference from one 1 ms cycle to the
/// next on a steady spindle, at speeds from 100 to 4000 rpm, each at
/// three start angles, predicted 3 ms ahead: within 0.35 counts (on a
/// 1.5 mm pitch at 4096 counts, 128 m/s³ of lead jerk; measured 0.30
/// at 2050 rpm). With equal weights it reaches 1.02 counts (3415
/// rpm).
#[test]
fn a_steady_spindle_s_prediction_changes_smoothly() {
    let mut worst: (f64, f64) = (0.0, 0.0);
    for i in 0..60 {
        let rpm = 100.0 + 65.0 * f64::from(i);
        for phase in [0.0, 0.37, 0.71] {
            let mut tr = SpindleTracker::default();
            let counts = |t: f64| (rpm / 60.0 * t) * 4096.0 + phase * 4096.0;
            let mut p = Vec::new();
            for k in 0..150 {
                let t = k as f64 * 0.001;
                tr.push(EncoderReading {
                    t,
                    count: counts(t).floor() as i64,
                    counts_per_rev: 4096,
                    index_count: 1,
                    count_at_index: 0,
                });
                if k >= 30 {
                    p.push(tr.predict(t + 0.003, t + 0.001).unwrap().0);
                }
            }
            for w in p.windows(4) {
                let d3 = (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs();
                if d3 > worst.0 {
                    worst = (d3, rpm);
                }
            }
        }
    }
    assert!(worst.0 < 0.35, "{:.3} counts at {} rpm", worst.0, worst.1);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
    /// Any readings a publisher may send (times out of order or far
    /// apart, counts anywhere in i64, any counts per revolution):
    /// never a panic, and every prediction finite.
    #[test]
    fn any_readings_give_a_finite_prediction_or_none(
        readings in proptest::collection::vec(
            (-2_000i64..50_000, proptest::prelude::any::<i64>(), 0u32..8, proptest::prelude::any::<u32>()),
            0..80,
        ),
        ahead in -0.1f64..1.0,
    ) {
        let mut tr = SpindleTracker::default();
        let mut t = 0.0;
        for (dt_us, count, kind, cpr) in readings {
            t += dt_us as f64 * 1e-6;
            // mostly counts near the last, sometimes anywhere
            let count = match (kind, tr.last) {
                (0, _) | (_, None) => count,
                (_, Some(l)) => l.count.saturating_add(count % 100_000),
            };
            tr.push(EncoderReading {
                t,
                count,
                counts_per_rev: cpr,
                index_count: 1,
                count_at_index: 0,
            });
            if let Some(p) = tr.predict_motion(t + ahead, t) {
                proptest::prop_assert!(
                    p.counts.is_finite() && p.per_s.is_finite() && p.per_s2.is_finite(),
                    "{p:?}"
                );
            }
        }
    }
}

/// Predictions that resume after a pause (the next pass of a thread)
/// with a reading late start from a fit of the readings there, not by
/// easing out of the fit made before the pause.
#[test]
fn a_prediction_after_a_pause_starts_afresh() {
    let mut tr = SpindleTracker::default();
    let counts = |t: f64| (800.0 / 60.0 * t + 0.3) * 4096.0;
    let reading = |k: i32| EncoderReading {
        t: f64::from(k) * 0.001,
        count: counts(f64::from(k) * 0.001).floor() as i64,
        counts_per_rev: 4096,
        index_count: 1,
        count_at_index: 0,
    };
    for k in 0..600 {
        // reading 599 comes late
        if k != 599 {
            tr.push(reading(k));
        }
        let now = f64::from(k + 1) * 0.001;
        if (30..100).contains(&k) || k == 599 {
            let p = tr.predict(now + 0.003, now).unwrap().0;
            let err = p - counts(now + 0.003);
            assert!(err.abs() < 1.0, "cycle {k}: {err} counts");
        }
    }
}

/// Readings the transport holds back: on a spindle at S2000 with ±2 %
/// ripple at 5 Hz, `n` readings in a row come late (each with the next
/// on-time one), the cycles half a period after the sampling, each
/// predicting 3 ms ahead. Against a tracker that had every reading on
/// time, the prediction moves by at most 0.010°, 0.010°, 0.031°,
/// 0.066° and 0.100° for 1, 2, 3, 5 and 8 held back (measured): the
/// tracker then predicts from older readings, further ahead, through
/// the ripple's jerk, and a held cycle goes on by the last on-time
/// fit's move, which is off this cycle's by up to a tenth of a count
/// (without it 0.005°, 0.017°, 0.038°, 0.071° and 0.101°, and the lead's
/// jerk stepped: `cnc_node/tests/encoder_timing.rs`). The node logs how a job's readings came, so
/// that a measured thread can be told apart from a transport that
/// held them back.
#[test]
fn readings_held_back_move_the_prediction_by_what_older_readings_predict() {
    let (w0, rip, f) = (2000.0 / 60.0, 0.02, 5.0);
    let tau = std::f64::consts::TAU;
    let angle = |t: f64| w0 * t - w0 * rip / (tau * f) * (tau * f * t + 0.3).cos();
    let reading = |k: usize| {
        let t = k as f64 * 0.001;
        EncoderReading {
            t,
            count: (angle(t) * 4096.0).floor() as i64,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: 0,
        }
    };
    for (n, most) in [(1, 0.012), (2, 0.012), (3, 0.035), (5, 0.07), (8, 0.105)] {
        let (mut on, mut late) = (SpindleTracker::default(), SpindleTracker::default());
        let mut held = Vec::new();
        let mut worst: f64 = 0.0;
        for k in 0..360 {
            on.push(reading(k));
            if (300..300 + n).contains(&k) {
                held.push(k);
            } else {
                for h in held.drain(..) {
                    late.push(reading(h));
                }
                late.push(reading(k));
            }
            let now = k as f64 * 0.001 + 0.0005;
            let (a, b) = (
                on.predict_motion(now + 0.003, now).unwrap(),
                late.predict_motion(now + 0.003, now).unwrap(),
            );
            let d = (b.counts - a.counts) * 360.0 / 4096.0;
            if k < 300 {
                assert_eq!(d, 0.0, "cycle {k}");
            }
            worst = worst.max(d.abs());
        }
        assert!(
            worst <= most && worst > 0.5 * most,
            "{n} held back: {worst:.4} deg"
        );
    }
}

fn reading(t_ms: f64, count: i64) -> EncoderReading {
    EncoderReading {
        t: t_ms * 1.0e-3,
        count,
        counts_per_rev: 4096,
        index_count: 1,
        count_at_index: 0,
    }
}

/// Three readings lost in a row (10.5 counts a ms, no fit yet, so no
/// curvature) are filled in on the line between their neighbours, each
/// as a count and its fraction; the measured ones keep a fraction of 0.
#[test]
fn lost_readings_are_filled_in_as_counts_and_fractions() {
    let mut tr = SpindleTracker::default();
    for k in 0..=4 {
        tr.push(reading(
            f64::from(k),
            42 + (10.5 * f64::from(k)).floor() as i64,
        ));
    }
    tr.push(reading(8.0, 42 + 84));
    assert_eq!(tr.len, 9);
    // newest first: the reading at 8 ms, then the three filled in
    let got: Vec<(f64, i64, f64)> = (0..5)
        .map(|k| {
            let (t, c) = tr.ring[(tr.head + HISTORY - k) % HISTORY];
            (t * 1000.0, c, tr.frac_at(k))
        })
        .collect();
    let want = [
        (8.0, 126, 0.0),
        (7.0, 115, 0.5),
        (6.0, 105, 0.0),
        (5.0, 94, 0.5),
        (4.0, 84, 0.0),
    ];
    for ((t, c, f), (wt, wc, wf)) in got.iter().zip(want) {
        assert!((t - wt).abs() < 1e-9, "{got:?}");
        assert_eq!(*c, wc, "{got:?}");
        assert!((f - wf).abs() < 1e-9, "{got:?}");
    }
}

/// A filled-in count that would leave an i64's range (near −2⁶³, the fit
/// curving down between two equal counts) leaves the whole gap unfilled,
/// not the readings before that count filled and the rest lost.
#[test]
fn a_gap_whose_fill_leaves_an_i64_s_range_is_not_filled_at_all() {
    let mut tr = SpindleTracker::default();
    let low = i64::MIN + 3;
    for k in 0..=4 {
        tr.push(reading(f64::from(k), low));
    }
    // 1 count/ms² of curvature: −3, −4 and −3 counts below the line at
    // 5, 6 and 7 ms; the first fits, the second does not
    tr.current = Some(Fit {
        t0: 0.004,
        count0: low,
        c: [0.0, 0.0, 1.0],
    });
    tr.push(reading(8.0, low));
    assert_eq!(tr.len, 6);
    assert_eq!(tr.ring[tr.head], (0.008, low));
    assert_eq!(tr.ring[(tr.head + HISTORY - 1) % HISTORY], (0.004, low));
}

/// A step taken on by an ease that started 2 ms before (every slot busy)
/// is the same parabola from there: its angle, slope and curvature at the
/// step's cycle are the step's, added to the ease's own.
#[test]
fn a_step_taken_on_by_an_older_ease_keeps_its_parabola() {
    let mut b = Blend::new(1.000, [0.5, 0.02, 0.001], BLEND_RATE_MS);
    let e = [1.2, -0.3, 0.004];
    b.absorb(1.002, e);
    // the raw parabolas (no easing) 2 ms after the ease's start
    let d = 2.0;
    let at = |e: [f64; 3], x: f64| [e[0] + e[1] * x + 0.5 * e[2] * x * x, e[1] + e[2] * x, e[2]];
    let (got, own) = (at(b.e, d), at([0.5, 0.02, 0.001], d));
    for i in 0..3 {
        assert!((got[i] - own[i] - e[i]).abs() < 1e-12, "{i}: {got:?}");
    }
}
