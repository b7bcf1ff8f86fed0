//! The feed override through the controller (what `/cnc/feed_override`
//! drives): 0-200 %, applied to the running job at once, refused outside
//! that range without a change, kept for the next job, and shown in the
//! status.

use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use cnc_node::controller::{Controller, Job, State};

const MS: i64 = 1_000_000;
const T0: i64 = 1_795_000_000 * 1_000_000_000;

/// X speed of each cycle (mm/s) while `hook(cycle, ctl)` may act.
fn run(mut hook: impl FnMut(u64, &mut Controller)) -> (Vec<f64>, Controller) {
    let m = Machine::builtin_mill();
    // 300 mm in X at F9000 = 150 mm/s (X allows 250)
    let prog = "G01 X300 F9000\n";
    let r = check(StrSource::new(prog), Dialect::Cnc836, &m);
    assert!(r.ok(), "{}", r.message());
    let mut ctl = Controller::new(m.clone());
    hook(0, &mut ctl);
    ctl.start(Job {
        id: 1,
        text: prog.as_bytes().to_vec(),
        dialect: Dialect::Cnc836,
        ticks: r.ticks,
        // checked from home, where the machine stands
        start: m.axes.iter().map(|a| a.home_mm).collect(),
    })
    .unwrap();
    let mut x = Vec::new();
    let mut k = 0;
    while ctl.status().state != State::Idle && k < 20_000 {
        k += 1;
        hook(k, &mut ctl);
        let t = ctl.tick(T0 + k as i64 * MS);
        x.push(t.positions[0]);
    }
    let v = x.windows(2).map(|w| (w[1] - w[0]) * 1000.0).collect();
    (v, ctl)
}

#[test]
fn an_override_changes_the_running_jobs_speed_and_is_bounded() {
    let (v, _) = run(|_, _| {});
    let top = v.iter().cloned().fold(0.0, f64::max);
    assert!((top - 150.0).abs() < 1e-6, "{top}");
    let n100 = v.len();
    // 50 % from 300 ms on: 75 mm/s in the middle; the 1.7 s left take 3.4 s
    let (v, ctl) = run(|k, c| {
        if k == 300 {
            c.set_feed_override(50.0).unwrap();
        }
    });
    assert!((v[1000] - 75.0).abs() < 1e-6, "{}", v[1000]);
    assert!(v.len() > n100 + 1700, "{} vs {n100}", v.len());
    assert_eq!(ctl.status().feed_override, 0.5);
    // 200 % before the start: the axis's 250 mm/s, kept for the job
    let (v, _) = run(|k, c| {
        if k == 0 {
            c.set_feed_override(200.0).unwrap();
        }
    });
    let top = v.iter().cloned().fold(0.0, f64::max);
    assert!((top - 250.0).abs() < 1e-6, "{top}");
    assert!(v.len() + 600 < n100, "{} vs {n100}", v.len());
    // out of range or not a number: refused, nothing changes
    let (v, ctl) = run(|k, c| {
        if k == 100 {
            let e = c.set_feed_override(250.0).unwrap_err();
            assert_eq!(e, "feed override 250 % refused: expected 0 to 200 %");
            assert!(c.set_feed_override(-1.0).is_err());
            assert!(c.set_feed_override(f64::NAN).is_err());
        }
    });
    assert_eq!(v.len(), n100);
    assert_eq!(ctl.status().feed_override, 1.0);
}

/// A job ends where it stands, in ERROR, with the line and the reason,
/// when the control loop lost cycles (a tick 10 periods after the last)
/// or gave way (`end_job`), and the machine stays where it stood.
#[test]
fn a_job_ends_in_error_with_its_line_when_the_loop_loses_cycles_or_gives_way() {
    for gave_way in [false, true] {
        let mut at = 0.0;
        let (_, ctl) = run(|k, c| {
            if k == 400 {
                at = c.positions()[0];
                if gave_way {
                    c.end_job("the control loop cannot keep 1000 Hz on this host");
                } else {
                    // cycle 400 comes 10 ms late: 9 cycles were lost
                    let _ = c.tick(T0 + 409 * MS);
                }
            }
        });
        let s = ctl.status();
        assert_eq!(s.state, State::Error);
        let want = if gave_way {
            "line 1: the control loop cannot keep 1000 Hz on this host; the job ended where it stood"
        } else {
            "line 1: the control loop fell 9 ms behind (cycles skipped); the job ended where it stood"
        };
        assert_eq!(s.last_error, want);
        // it stopped at cycle 399's position (X moving at 150 mm/s there)
        assert!(at > 30.0, "{at}");
        assert_eq!((ctl.positions()[0] * 1000.0).round(), (at * 1000.0).round());
    }
}
