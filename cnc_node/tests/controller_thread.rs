//! The node's controller (`Controller`, as the node's loop drives it) cutting
//! threads against the simulated machine with the encoder readings coming
//! late, as over DDS: the simulator steps half a cycle after the controller
//! (its own grid), its readings reach the controller a millisecond after
//! they were latched, and the controller sees them at its next cycle; the
//! simulator applies each setpoint at its stamp plus the machine's
//! setpoint delay (as the node does), and the controller leads G33 by it.
//! The lead error is measured as the ROS test measures it: the encoder
//! count interpolated at each setpoint's stamp plus that lead (and, for the
//! simulated axis, at its own stamp). Also the faults: a lost encoder
//! (the axes stop under control, State::Error with the reason) and an abort
//! in a thread (a controlled stop, not a jump).

use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use cnc_node::controller::{ActualSample, Controller, EncoderSample, Job, State};
use sim_axes::machine::model_for;
use sim_axes::SetpointQueue;
use std::collections::VecDeque;

const MS: i64 = 1_000_000;
/// some wall-clock time, ns (the controller's clock)
const T0: i64 = 1_795_000_000 * 1_000_000_000;

/// Called after each cycle with the Z setpoint (mm); false: readings are
/// no longer delivered.
type Hook = Box<dyn FnMut(&mut Controller, f64) -> bool>;

/// When readings arrive and what the bench does during the run.
struct Bench {
    machine: Machine,
    /// the simulator's step instants lag the controller's cycles by this, ns
    phase_ns: i64,
    /// a reading reaches the controller this long after it was latched, ns
    latency_ns: i64,
    /// readings latched within these cycles arrive together after them
    /// (a stalled simulator or transport): (first cycle, cycles)
    stalls: Vec<(i64, i64)>,
    /// from this cycle on, the drives apply each setpoint this much later
    /// than the machine's setpoint delay: (first cycle, ns)
    drives_late: Option<(i64, i64)>,
    /// the simulated axes' positions go back to the controller (the
    /// joint states), a cycle after their instant
    joint_states: bool,
    hook: Hook,
}

/// What a run produced.
struct Run {
    /// (stamp ns, setpoints mm in joint order, state)
    setpoints: Vec<(i64, Vec<f64>, State)>,
    /// (stamp ns, count, true revolutions of the spindle)
    readings: Vec<(i64, i64, f64)>,
    /// (stamp ns, simulated actual positions mm in joint order)
    actual: Vec<(i64, Vec<f64>)>,
    /// how far G33 setpoints lead their stamps (the setpoint delay plus
    /// Z's servo lag), ns
    ahead_ns: i64,
    cpr: f64,
    state: State,
    last_error: String,
    /// the spindle command after the run, rpm
    spindle_rpm: f64,
}

impl Bench {
    fn lathe() -> Self {
        Bench {
            machine: Machine::builtin_lathe(),
            phase_ns: MS / 2,
            latency_ns: MS,
            stalls: Vec::new(),
            drives_late: None,
            joint_states: false,
            hook: Box::new(|_, _| true),
        }
    }

    fn run(mut self, program: &str) -> Run {
        let m = self.machine.clone();
        let report = check(StrSource::new(program), Dialect::Cnc836, &m);
        assert!(report.ok(), "{}", report.message());
        let mut model = model_for(&m, 7);
        let mut ctl = Controller::new(m.clone());
        let n = m.axes.len();
        let z = m.axes.iter().position(|a| a.name == "z").unwrap();
        let cpr = m.spindle.as_ref().unwrap().encoder_counts_per_rev as f64;
        let dt = m.dt();
        // a second of the spindle standing before the job, as in the node
        let mut set: Vec<f64> = m.axes.iter().map(|a| a.home_mm).collect();
        let mut spindle = 0.0;
        let mut in_flight: VecDeque<(i64, EncoderSample)> = VecDeque::new();
        let delay_ns = (m.setpoint_delay_s() * 1e9).round() as i64;
        let mut queue = SetpointQueue::new(set.clone(), delay_ns);
        let mut run = Run {
            setpoints: Vec::new(),
            readings: Vec::new(),
            actual: Vec::new(),
            ahead_ns: delay_ns + (m.servo_lag_s()[2] * 1e9).round() as i64,
            cpr,
            state: State::Idle,
            last_error: String::new(),
            spindle_rpm: 0.0,
        };
        let mut deliver = true;
        let mut started = false;
        for k in -1000i64..600_000 {
            let now = T0 + k * MS;
            if k == 0 {
                ctl.start(Job {
                    id: 1,
                    text: program.as_bytes().to_vec(),
                    dialect: Dialect::Cnc836,
                    ticks: report.ticks,
                    // checked from home, where the machine stands
                    start: m.axes.iter().map(|a| a.home_mm).collect(),
                })
                .unwrap();
                started = true;
            }
            // the readings that arrived by now
            while in_flight.front().is_some_and(|(at, _)| *at <= now) {
                let (_, e) = in_flight.pop_front().unwrap();
                if deliver {
                    ctl.encoder(e);
                }
            }
            // the joint states of the simulator's last step
            if let (true, Some((t, p))) = (self.joint_states, run.actual.last()) {
                let mut positions = [0.0; 3];
                positions[..n].copy_from_slice(p);
                ctl.actual(ActualSample {
                    stamp_ns: *t,
                    positions,
                    n,
                });
            }
            let tick = ctl.tick(now);
            set.copy_from_slice(&tick.positions[..n]);
            spindle = tick.spindle_rpm;
            if started {
                run.setpoints.push((now, set.clone(), tick.state));
                deliver = (self.hook)(&mut ctl, set[z]);
                if tick.state != State::Running && tick.state != State::Hold {
                    break;
                }
            }
            // the simulator's step half a cycle later, with the setpoint
            // meant for its instant less the delay
            queue.push(now, set.iter().copied().enumerate());
            let t_sim = now + self.phase_ns;
            let late = self
                .drives_late
                .filter(|(a, _)| k >= *a)
                .map_or(0, |(_, l)| l);
            model.step(queue.at(t_sim - late), spindle, dt);
            run.actual
                .push((t_sim, model.axes.iter().map(|a| a.position()).collect()));
            let sp = model.spindle.as_ref().unwrap();
            let e = sp.encoder();
            let held = self
                .stalls
                .iter()
                .find(|(a, n)| (*a..a + n).contains(&k))
                .map_or(0, |(a, n)| (a + n - k) * MS);
            in_flight.push_back((
                t_sim + self.latency_ns + held,
                EncoderSample {
                    stamp_ns: t_sim,
                    count: e.count,
                    counts_per_rev: e.counts_per_rev,
                    index_count: e.index_count,
                    count_at_index: e.count_at_index,
                },
            ));
            run.readings.push((t_sim, e.count, sp.revolutions()));
        }
        let st = ctl.status();
        run.state = st.state;
        run.last_error = st.last_error;
        run.spindle_rpm = spindle;
        run
    }
}

impl Run {
    /// (lead travel mm, revolutions by the counts, true revolutions) at
    /// each setpoint of the pass from Z `start` with Z within lo..hi, the
    /// encoder interpolated at the setpoint's stamp plus the lead.
    fn pass(&self, z: usize, start: f64, lo: f64, hi: f64) -> Vec<(f64, f64, f64)> {
        let sps: Vec<(i64, Vec<f64>)> = self
            .setpoints
            .iter()
            .map(|(t, p, _)| (t + self.ahead_ns, p.clone()))
            .collect();
        self.pass_of(&sps, z, start, lo, hi)
    }

    /// The same for the simulated axis, at its own stamps.
    fn actual_pass(&self, z: usize, start: f64, lo: f64, hi: f64) -> Vec<(f64, f64, f64)> {
        self.pass_of(&self.actual, z, start, lo, hi)
    }

    fn pass_of(
        &self,
        pts: &[(i64, Vec<f64>)],
        z: usize,
        start: f64,
        lo: f64,
        hi: f64,
    ) -> Vec<(f64, f64, f64)> {
        let last = (0..pts.len())
            .min_by(|&a, &b| pts[a].1[z].total_cmp(&pts[b].1[z]))
            .unwrap();
        let first = (0..=last)
            .rev()
            .find(|&i| pts[i].1[z] >= start - 1e-9)
            .unwrap();
        let mut out = Vec::new();
        for (t, sp) in &pts[first..=last] {
            if sp[z] < lo || sp[z] > hi {
                continue;
            }
            let i = self.readings.partition_point(|r| r.0 < *t);
            if i == 0 || i >= self.readings.len() {
                continue;
            }
            let (a, b) = (self.readings[i - 1], self.readings[i]);
            let f = (t - a.0) as f64 / (b.0 - a.0) as f64;
            let counts = a.1 as f64 + f * (b.1 - a.1) as f64 + 0.5;
            let truth = a.2 + f * (b.2 - a.2);
            out.push((start - sp[z], counts / self.cpr, truth));
        }
        out
    }
}

/// Spread (max − min) of `u/pitch − revs` in counts, and its mean as a
/// phase in degrees (−180, 180].
fn spread_and_phase(v: &[f64], cpr: f64) -> (f64, f64) {
    let r = v[0];
    let d: Vec<f64> = v.iter().map(|x| x - (x - r).round()).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let lo = d.iter().copied().fold(f64::MAX, f64::min);
    let hi = d.iter().copied().fold(f64::MIN, f64::max);
    let mut ph = mean.rem_euclid(1.0) * 360.0;
    if ph > 180.0 {
        ph -= 360.0;
    }
    ((hi - lo) * cpr, ph)
}

fn example1(rpm: f64, z_end: f64) -> String {
    format!("N5 G00 X20 Z5\nN10 M03 S{rpm}\nN20 G33 Z{z_end} F1\nN30 G00 X30\nN40 Z5\nN50 M30\n")
}

#[test]
fn late_readings_a_thread_follows_the_spindle_within_two_counts() {
    let mut phases = Vec::new();
    for rpm in [200.0, 800.0, 2000.0] {
        let r = Bench::lathe().run(&example1(rpm, -40.0));
        assert_eq!(r.state, State::Idle, "{}", r.last_error);
        assert_eq!(r.last_error, "");
        let last = &r.setpoints.last().unwrap().1;
        assert_eq!((last[0], last[1]), (15.0, 5.0));
        let pass = r.pass(1, 5.0, -35.0, -2.0);
        assert!(pass.len() as f64 > 0.99 * 33.0 / (rpm / 60.0) * 1000.0);
        let by_count: Vec<f64> = pass.iter().map(|p| p.0 - p.1).collect();
        let by_truth: Vec<f64> = pass.iter().map(|p| p.0 - p.2).collect();
        let (spread, phase) = spread_and_phase(&by_count, r.cpr);
        let (spread_true, phase_true) = spread_and_phase(&by_truth, r.cpr);
        eprintln!(
            "S{rpm}: lead error spread {spread:.2} counts ({spread_true:.2} to the true angle), groove {phase:.4} deg ({phase_true:.4})"
        );
        assert!(spread <= 2.0, "S{rpm}: {spread} counts");
        assert!(spread_true <= 2.0, "S{rpm}: {spread_true} counts");
        assert!(phase.abs() <= 0.05, "S{rpm}: {phase} deg");
        // the simulated axis, at its own stamps: in the groove too
        let act: Vec<f64> = r
            .actual_pass(1, 5.0, -35.0, -2.0)
            .iter()
            .map(|p| p.0 - p.1)
            .collect();
        let (spread_act, phase_act) = spread_and_phase(&act, r.cpr);
        eprintln!("S{rpm}: actual Z spread {spread_act:.2} counts, groove {phase_act:.4} deg");
        assert!(phase_act.abs() <= 0.1, "S{rpm}: actual {phase_act} deg");
        phases.push(phase_true);
    }
    let lo = phases.iter().copied().fold(f64::MAX, f64::min);
    let hi = phases.iter().copied().fold(f64::MIN, f64::max);
    assert!(hi - lo <= 0.05, "{phases:?}");
}

#[test]
fn a_lost_encoder_stops_the_thread_under_control_and_the_job_ends_in_error() {
    let mut b = Bench::lathe();
    b.hook = Box::new(|_, z| z > -10.0);
    let r = b.run(&example1(800.0, -20.0));
    assert_eq!(r.state, State::Error);
    assert!(
        r.last_error
            .starts_with("line 3: spindle encoder signal lost: no reading for"),
        "{}",
        r.last_error
    );
    assert_eq!(r.spindle_rpm, 0.0);
    let zs: Vec<f64> = r.setpoints.iter().map(|s| s.1[1]).collect();
    let end = *zs.last().unwrap();
    assert!(end < -10.0 && end > -10.5, "{end}");
    assert_no_jump(&zs, 800.0);
    // it followed the spindle's predicted angle for a while, then decelerated
    let lost = zs.iter().position(|z| *z <= -10.0).unwrap();
    let v = 800.0 / 60.0 * 0.001;
    let slowing = zs[lost..]
        .windows(2)
        .position(|w| (w[0] - w[1]) < 0.99 * v)
        .unwrap();
    // the last reading the controller got (at the cycle before) was latched
    // 2.5 ms before this cycle: the thread went on until it was 25 ms old
    // (the default timeout, `ENCODER_TIMEOUT_CYCLES`)
    assert!((22..=24).contains(&slowing), "{slowing}");
}

#[test]
fn an_abort_in_a_thread_is_a_controlled_stop() {
    let mut b = Bench::lathe();
    let mut asked = false;
    b.hook = Box::new(move |ctl, z| {
        if z < -10.0 && !asked {
            asked = true;
            assert_eq!(ctl.abort().unwrap(), "job 1 stopping");
        }
        true
    });
    let r = b.run(&example1(800.0, -20.0));
    assert_eq!(r.state, State::Idle);
    assert_eq!(r.last_error, "job 1 aborted at line 3");
    assert_eq!(r.spindle_rpm, 0.0);
    let zs: Vec<f64> = r.setpoints.iter().map(|s| s.1[1]).collect();
    let end = *zs.last().unwrap();
    assert!(end < -10.0 && end > -10.2, "{end}");
    assert_no_jump(&zs, 800.0);
}

/// In the thread (Z from 5 down), Z setpoints never step more than the
/// lead speed (+5 % spindle margin) allows in a cycle, and their
/// acceleration stays within the axis limit.
fn assert_no_jump(zs: &[f64], rpm: f64) {
    let dt = 0.001;
    let v = rpm / 60.0;
    for w in zs.windows(3).filter(|w| w[0] <= 5.0) {
        let step = (w[2] - w[1]).abs();
        assert!(step <= v * 1.05 * dt + 1e-9, "step {step} mm");
        let a = (w[2] - 2.0 * w[1] + w[0]).abs() / (dt * dt);
        assert!(a <= 2500.0, "{a} mm/s²");
    }
    // and at rest at the end: the last step is the one of a speed of at
    // most one cycle's deceleration
    let n = zs.len();
    assert!((zs[n - 1] - zs[n - 2]).abs() <= 2500.0 * dt * dt);
}

/// Example 1's pass at S200 and S2000 with the readings held up `cycles`
/// cycles twenty times in the pass (a stalled simulator or transport: the
/// held readings then arrive together): the job ends without error, and
/// the lead error's spread (counts), the groove's phase (degrees) and Z's
/// largest sampled jerk on the pass (mm/s³) of each.
fn pass_with_stalls(cycles: i64) -> Vec<(f64, f64, f64, f64)> {
    let mut out = Vec::new();
    for rpm in [200.0, 2000.0] {
        let mut b = Bench::lathe();
        b.stalls = (0..20).map(|i| (2000 + i * 400, cycles)).collect();
        let dt = b.machine.dt();
        let r = b.run(&example1(rpm, -40.0));
        assert_eq!(r.state, State::Idle, "S{rpm}: {}", r.last_error);
        let pass = r.pass(1, 5.0, -35.0, -2.0);
        let by_count: Vec<f64> = pass.iter().map(|p| p.0 - p.1).collect();
        let (spread, phase) = spread_and_phase(&by_count, r.cpr);
        // (the third difference of Z's setpoints where all four lie on
        // the pass)
        let zs: Vec<f64> = r.setpoints.iter().map(|s| s.1[1]).collect();
        let jerk = zs
            .windows(4)
            .filter(|w| w.iter().all(|z| (-35.0..-2.0).contains(z)))
            .map(|w| (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs() / dt.powi(3))
            .fold(0.0, f64::max);
        eprintln!(
            "S{rpm}, stalls of {cycles} ms: lead error spread {spread:.2} counts, groove {phase:.4} deg, Z {:.1} m/s³",
            jerk / 1000.0
        );
        out.push((rpm, spread, phase, jerk));
    }
    out
}

/// Z's jerk limit on the bundled lathe, mm/s³.
fn lathe_z_jerk() -> f64 {
    Bench::lathe().machine.axes[1].max_jerk_mm_s3.unwrap()
}

#[test]
fn readings_held_up_8_ms_now_and_then_keep_the_thread_within_two_counts() {
    // (the newest reading is then up to 9.5 ms old; 2.0 counts before G33
    // led by the 3 ms setpoint delay: the newest reading is now up to 12.5
    // ms behind the angle predicted; 2.47 measured at S200, 1.77 at S2000,
    // where the tracker keeps its fit for the first 4 ms of a stall and
    // eases into the next; 2.43 and 1.68 when every ease took 8 ms)
    for (rpm, spread, _, jerk) in pass_with_stalls(8) {
        assert!(spread <= 2.5, "S{rpm}: {spread} counts");
        assert!(jerk <= lathe_z_jerk(), "S{rpm}: Z at {jerk} mm/s³");
    }
}

#[test]
fn readings_held_up_20_ms_now_and_then_do_not_lose_the_encoder() {
    // a VM that holds up the simulator's loop for 20 ms: under the default
    // timeout (25 cycles) the thread goes on, on the spindle's predicted
    // angle while no reading comes (with the 10 cycles of before, the
    // first stall ended the job), and eases into the new fit when they
    // come, within Z's jerk limit: 4.40 counts measured at S200, 2.79 at
    // S2000 (3.84 and 2.65 when the new fit took over at once, and Z
    // went to 1,632 and 802 m/s³)
    for (rpm, spread, phase, jerk) in pass_with_stalls(20) {
        assert!(spread <= 4.5, "S{rpm}: {spread} counts");
        assert!(phase.abs() <= 0.05, "S{rpm}: {phase} deg");
        assert!(jerk <= lathe_z_jerk(), "S{rpm}: Z at {jerk} mm/s³");
    }
}

/// Example 1 at S800 with the drives applying the setpoints 1 ms later than
/// the 3 ms the thread leads by, from Z3 on (at 13.3 mm/s, 4.8° of the
/// spindle): the final state and error.
fn drives_one_ms_late(limit_deg: Option<f64>) -> (State, String) {
    let mut b = Bench::lathe();
    if let Some(sp) = b.machine.spindle.as_mut() {
        sp.thread_phase_limit_deg = limit_deg;
    }
    b.joint_states = true;
    // the thread starts after the rapid and the spindle's ramp; cycle 3000
    // is well inside its 3.4 s pass
    b.drives_late = Some((3000, MS));
    let r = b.run(&example1(800.0, -40.0));
    (r.state, r.last_error)
}

/// The degrees behind in a "behind the thread line" error.
fn degrees_behind(err: &str) -> f64 {
    let rest = err
        .strip_prefix("line 3: the Z axis is ")
        .unwrap_or_else(|| panic!("{err}"));
    let (deg, rest) = rest
        .split_once("° behind the thread line: the machine follows its setpoints ")
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        rest.contains(" ms after their instant, not the 3.0 ms the thread leads by"),
        "{err}"
    );
    deg.parse().unwrap_or_else(|_| panic!("{err}"))
}

#[test]
fn drives_a_millisecond_late_stop_the_thread_beyond_two_degrees() {
    let (state, err) = drives_one_ms_late(None);
    assert_eq!(state, State::Error, "{err}");
    // stopped as the median of 50 joint states passes 2° on its way to 4.8°
    let deg = degrees_behind(&err);
    assert!(deg > 2.0 && deg < 3.0, "{err}");
}

#[test]
fn the_thread_phase_limit_is_a_machine_setting() {
    // the same drives under a limit of 6°: the thread is cut to its end
    let (state, err) = drives_one_ms_late(Some(6.0));
    assert_eq!((state, err.as_str()), (State::Idle, ""));
    // and under 4° it stops as the median passes 4°
    let (state, err) = drives_one_ms_late(Some(4.0));
    assert_eq!(state, State::Error, "{err}");
    let deg = degrees_behind(&err);
    assert!((4.0..=4.8).contains(&deg), "{err}");
    // out of range in the machine file: refused with the key
    let text = include_str!("../../config/lathe.toml").replace(
        "encoder_counts_per_rev = 4096",
        "encoder_counts_per_rev = 4096\nthread_phase_limit_deg = 0",
    );
    let e = Machine::from_toml(&text).unwrap_err();
    assert_eq!(
        e.0,
        "machine file: key `spindle.thread_phase_limit_deg`: must be between 0.1 and 180"
    );
}
