//! Whatever the spindle encoder topic carries (any publisher may send it:
//! counts anywhere in i64, jumps, any counts per revolution, index counts
//! and angles that make no sense), a G33/G95 job never panics, never
//! hangs, and every setpoint it gives is finite. A reading the tracker
//! cannot follow ends the run with a fault, or the thread's phase check
//! stops it; that is the node's business, not this test's.

use cnc_core::exec::Executor;
use cnc_core::source::StrSource;
use cnc_core::tracker::EncoderReading;
use cnc_core::{Dialect, Machine};
use proptest::prelude::*;

const PROGRAM: &str =
    "N5 G00 X20 Z5\nN10 M03 S800\nN20 G33 Z-10 F1.5\nN30 G95 G01 Z-20 F0.2\nN40 G00 X30\nN50 M30\n";

/// [`PROGRAM`] on the bundled lathe, following an encoder, its drives 3
/// ms behind the setpoints.
fn lathe_job() -> (Machine, Executor<StrSource<'static>>) {
    let m = Machine::builtin_lathe();
    let mut ex = Executor::new(StrSource::new(PROGRAM), Dialect::Cnc836, &m);
    ex.attach_encoder();
    ex.set_setpoint_delay(0.003);
    (m, ex)
}

#[derive(Clone, Copy, Debug)]
enum Jump {
    /// the steady spindle's count (800 rpm at 4096 counts/rev)
    Steady,
    /// a step of this many counts from then on
    Step(i64),
    /// this count, once
    Anywhere(i64),
}

fn jump() -> impl Strategy<Value = Jump> {
    prop_oneof![
        8 => Just(Jump::Steady),
        1 => any::<i64>().prop_map(Jump::Step),
        1 => any::<i64>().prop_map(Jump::Anywhere),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn any_encoder_readings_end_or_run_the_job_with_finite_setpoints(
        jumps in proptest::collection::vec((0usize..3000, jump()), 0..6),
        cpr in prop_oneof![Just(4096u32), any::<u32>()],
        index in prop_oneof![Just((1i64, 0i64)), any::<(i64, i64)>()],
    ) {
        let (m, mut ex) = lathe_job();
        let dt = m.dt();
        let mut offset: i64 = 0;
        let mut k = 0usize;
        loop {
            let t = k as f64 * dt;
            let steady = (800.0 / 60.0 * t * 4096.0) as i64;
            let mut count = steady.saturating_add(offset);
            for &(at, j) in &jumps {
                if at == k {
                    match j {
                        Jump::Steady => {}
                        Jump::Step(d) => {
                            offset = offset.saturating_add(d);
                            count = steady.saturating_add(offset);
                        }
                        Jump::Anywhere(c) => count = c,
                    }
                }
            }
            ex.encoder(EncoderReading {
                t,
                count,
                counts_per_rev: cpr,
                index_count: index.0,
                count_at_index: index.1,
            });
            let Some(s) = ex.next_sample() else { break };
            prop_assert!(s.pos.iter().all(|v| v.is_finite()), "sample {k}: {:?}", s.pos);
            k += 1;
            // (the job takes about 6 s; a run that never ends is a hang)
            prop_assert!(k < 120_000, "still running after {k} samples");
        }
    }
}

/// The count jumps back by 1528 revolutions in the middle of the thread
/// (a counter reset, a glitch): the executor does not follow it (the lead
/// would jump by 2.3 m, or wait two minutes for the spindle to come
/// round again) but stops the thread under control, within the axes'
/// acceleration, and ends the run with a fault that says why.
#[test]
fn a_count_that_jumps_stops_the_thread_under_control() {
    let (m, mut ex) = lathe_job();
    let dt = m.dt();
    let mut pos = Vec::new();
    let mut synced_at_jump = false;
    for k in 0..20_000usize {
        let t = k as f64 * dt;
        let steady = (800.0 / 60.0 * t * 4096.0) as i64;
        let count = if k >= 1000 {
            steady - 6_257_868
        } else {
            steady
        };
        ex.encoder(EncoderReading {
            t,
            count,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: 0,
        });
        let Some(s) = ex.next_sample() else { break };
        if k == 999 {
            synced_at_jump = s.sync.is_some_and(|y| y.on_line);
        }
        pos.push(s.pos);
    }
    assert!(synced_at_jump, "the jump comes on the thread line");
    let fault = ex.fault().expect("a fault");
    assert!(
        fault.starts_with("line 3: spindle encoder fault: its count jumped by -6257813 in 1.0 ms"),
        "{fault}"
    );
    // the stop: a few hundred samples, within each axis's acceleration
    // and jerk
    assert!(pos.len() < 1000 + 500, "{} samples", pos.len());
    for w in pos[990..].windows(4) {
        for i in [0, 2] {
            let a = ((w[2][i] - 2.0 * w[1][i] + w[0][i]) / (dt * dt)).abs();
            let lim = m.amax()[i];
            assert!(a <= lim * (1.0 + 1e-9), "axis {i}: {a} mm/s² (limit {lim})");
            let j = ((w[3][i] - 3.0 * w[2][i] + 3.0 * w[1][i] - w[0][i]) / (dt * dt * dt)).abs();
            let lim = m.jmax()[i];
            assert!(j <= lim * (1.0 + 1e-6), "axis {i}: {j} mm/s³ (limit {lim})");
        }
    }
}

/// An index pulse far ahead of the count (no real encoder's is): the
/// thread would wait for the spindle to come round to it, 1537
/// revolutions later. The job ends before the thread moves, and says why.
#[test]
fn an_index_ahead_of_the_count_ends_the_job_before_the_thread_moves() {
    let m = Machine::builtin_lathe();
    let mut ex = Executor::new(StrSource::new(PROGRAM), Dialect::Cnc836, &m);
    ex.attach_encoder();
    let dt = m.dt();
    let mut last = None;
    for k in 0..20_000usize {
        let t = k as f64 * dt;
        ex.encoder(EncoderReading {
            t,
            count: (800.0 / 60.0 * t * 4096.0) as i64,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: 6_294_732,
        });
        let Some(s) = ex.next_sample() else { break };
        last = Some((k, s));
    }
    let (k, s) = last.unwrap();
    assert!(k < 2000, "ended after {k} samples");
    // at the thread's start point (X20 is a diameter: radius 10), Z5
    assert!(
        s.last && (s.pos[0] - 10.0).abs() < 1e-9 && (s.pos[2] - 5.0).abs() < 1e-9,
        "{s:?}"
    );
    let fault = ex.fault().expect("a fault");
    assert!(
        fault.starts_with("line 3: G33 cannot start: the spindle encoder's last index pulse is ")
            && fault.ends_with(" revolutions ahead of its count"),
        "{fault}"
    );
}

/// The same jump (with the index pulse's count moving with it, as a
/// counter reset does) while the axes rapid to the thread's start, before
/// any block follows the spindle: the tracker starts over from the new
/// count, and the thread and the G95 move run to the end without a fault.
#[test]
fn a_count_that_jumps_before_the_thread_starts_the_tracker_over() {
    let (m, mut ex) = lathe_job();
    let dt = m.dt();
    let mut synced = 0;
    let mut last = None;
    for k in 0..20_000usize {
        let t = k as f64 * dt;
        let steady = (800.0 / 60.0 * t * 4096.0) as i64;
        let shift = if k >= 20 { -6_257_868 } else { 0 };
        ex.encoder(EncoderReading {
            t,
            count: steady + shift,
            counts_per_rev: 4096,
            index_count: 1,
            count_at_index: shift,
        });
        let Some(s) = ex.next_sample() else { break };
        if k == 20 {
            assert!(s.sync.is_none(), "the jump comes before the thread");
        }
        synced += usize::from(s.sync.is_some_and(|y| y.on_line));
        last = Some(s.pos);
    }
    assert_eq!(ex.fault(), None);
    // the thread's line at 800 rpm and 1.5 mm: 15 mm at 20 mm/s
    assert!(synced > 600, "{synced} samples on the thread line");
    // X30 is a diameter: the X axis ends at 15 mm
    assert_eq!(last.map(|p| (p[0], p[2])), Some((15.0, -20.0)));
}
