//! The simulator node: simulated axes (servo with following error) and a
//! spindle with an incremental encoder, as a ROS 2 node.
//!
//! Subscribes `<cnc>/joint_setpoints` (sensor_msgs/JointState, m) and
//! `<cnc>/spindle_command` (std_msgs/Float64, rad/s); publishes
//! `<ns>/joint_states` (m, m/s) and `<ns>/spindle_encoder`
//! (cnc_msgs/SpindleEncoder) at a fixed rate.
//!
//! Simulated time is locked to the clock: step n is the state at the
//! instant n·dt after the start (of the monotonic clock), stamped with that
//! instant in the system clock, as the controller stamps its setpoints; a
//! late wake-up runs the missed steps at once, so the spindle turns on in
//! real time whatever the scheduling (a reading is latched when it is
//! simulated, like a hardware time stamp).
//!
//! Setpoints are applied at their stamp plus the machine's setpoint delay
//! (`interpolation.setpoint_delay_ms`, or `--setpoint-delay-ms`), on this
//! node's step grid, interpolated between the two around the step's
//! instant ([`sim_axes::clocked`]): DDS latency below the delay does not
//! move the axes. With delay 0 they are applied on arrival.
//!
//! At rest (the setpoints come at the controller's resting rate, nothing
//! commanded changes, and the simulated state stands still) the joint
//! states and encoder readings go out at `ros::REST_RATE_HZ` only (every
//! step is still simulated); from the first setpoint that comes a cycle
//! after the last (a job), or anything that changes, every step again
//! (`ros::Pace`).
//!
//! Fault injection (std_srvs/SetBool): `<ns>/encoder_enabled` false stops
//! publishing encoder readings (the spindle turns on; true resumes);
//! `<ns>/spindle_stalled` true makes the spindle stand still whatever its
//! command (false releases it: it ramps up to the command again);
//! (cnc_msgs/SetDelay) `<ns>/setpoint_delay` changes the setpoint delay
//! from the next step on.
//!
//! Its options are ROS parameters too, and it takes `--ros-args`
//! (`sim_axes/params.rs`); `ripple`, `noise_rpm` and `setpoint_delay_ms`
//! can be set while it runs (`ros2 param set`), from the next step on.

#[path = "sim_axes/params.rs"]
mod params;

use cnc_core::machine::MAX_SETPOINT_DELAY_MS;
use cnc_msgs::params::Parameters;
use cnc_msgs::ros::{self, Grid, WallClock};
use cnc_msgs::{
    ros_error, ros_info, ros_warn, DiagnosticArray, Float64, Header, JointState, SetBoolRequest,
    SetBoolResponse, SetDelayRequest, SetDelayResponse, SpindleEncoder, Time,
};
use sim_axes::diagnostics::{SimMonitor, SpindleState};
use sim_axes::machine::{load_machine, model_for};
use sim_axes::SetpointQueue;
use std::time::Instant;

/// A wake-up this late is reported on stderr (at most a line a second,
/// which counts the stalls since the line before: see [`Stalls`]), s.
const STALL_WARN_S: f64 = 0.005;
/// A loop further behind than this skips the missed steps (the simulated
/// machine pauses) instead of running them all, s.
const MAX_BEHIND_S: f64 = 1.0;

fn main() {
    if let Err(e) = params::from_env().and_then(run) {
        ros_error!("{e}");
        std::process::exit(2);
    }
}

fn run(setup: params::Setup) -> Result<(), String> {
    let a = &setup.args;
    let mut machine = load_machine(&a.machine)?;
    if let Some(s) = machine.spindle.as_mut() {
        if let Some(r) = a.ripple {
            s.sim_ripple_fraction = r;
        }
        if let Some(n) = a.noise_rpm {
            s.sim_noise_rpm = n;
        }
    }
    let delay_ms = a
        .setpoint_delay_ms
        .unwrap_or(machine.interpolation.setpoint_delay_ms);
    check_delay(delay_ms).map_err(|e| format!("--setpoint-delay-ms {e}"))?;
    let rate = a.rate.unwrap_or(machine.interpolation.rate_hz);
    if !(rate.is_finite() && (10.0..=20_000.0).contains(&rate)) {
        return Err(format!("--rate {rate}: must be between 10 and 20000 Hz"));
    }
    let dt = 1.0 / rate;
    let domain = a.domain.unwrap_or_else(ros::domain_from_env);
    // (before any thread starts, so that every one takes it)
    ros::affinity::pin_process(&a.cpu_affinity).map_err(|e| format!("--cpu-affinity: {e}"))?;
    // DDS's threads start in join and inherit this thread's policy: real
    // time below the simulation loop, so a busy machine does not hold up
    // the encoder readings
    let dds_rt = ros::dds_priority(a.rt_priority);
    if dds_rt > 0 {
        if let Err(e) = ros::set_realtime(dds_rt) {
            ros_warn!("DDS threads stay at normal priority (SCHED_FIFO {dds_rt}: {e})");
        }
    }
    // (the thread that hands the signal on starts here, with this policy:
    // at normal priority it waited for seconds while the loops held both
    // CPUs, and SIGTERM seemed ignored)
    if let Err(e) = ros::shutdown::catch_signals() {
        ros_warn!("{e}");
    }
    let no_own_params = ros2_client::NodeOptions::new()
        .enable_rosout(false)
        .start_parameter_services(false);
    let (ctx, mut node) = ros::join_with(domain, &a.namespace, &setup.start.name, no_own_params)?;
    let (ripple, noise_rpm) = machine
        .spindle
        .as_ref()
        .map_or((0.0, 0.0), |s| (s.sim_ripple_fraction, s.sim_noise_rpm));
    let has_spindle = machine.spindle.is_some();
    let (parameters, param_changes) = Parameters::serve(
        &ctx,
        &mut node,
        params::NODE,
        params::in_force(&setup, rate, ripple, noise_rpm, delay_ms),
        Box::new(move |name, _| match name {
            "ripple" | "noise_rpm" if !has_spindle => {
                Err(format!("{name}: this machine has no spindle"))
            }
            _ => Ok(()),
        }),
    )?;
    cnc_msgs::rosout::init(&ctx, &mut node, &a.namespace, &setup.start.name)?;
    let pub_diag = ros::publisher::<DiagnosticArray>(&mut node, "/", "diagnostics")?;
    let mut mon = SimMonitor::default();
    let hardware_id = format!("{} ({})", machine.name, a.namespace.trim_end_matches('/'));
    let cns = a.controller_namespace.as_str();
    let sub_set = ros::subscription_stream::<JointState>(&mut node, cns, "joint_setpoints")?;
    let sub_spin = ros::subscription::<Float64>(&mut node, cns, "spindle_command")?;
    // a subscriber that dies (the controller) must not stop them for the others
    let window = ros::lease_window(rate);
    let pub_js = ros::publisher_with_window::<JointState>(
        &ctx,
        &mut node,
        &a.namespace,
        "joint_states",
        window,
    )?;
    let pub_enc = ros::publisher_with_window::<SpindleEncoder>(
        &ctx,
        &mut node,
        &a.namespace,
        "spindle_encoder",
        window,
    )?;
    let srv_enc =
        ros::server::<SetBoolRequest, SetBoolResponse>(&mut node, &a.namespace, "encoder_enabled")?;
    let srv_stall =
        ros::server::<SetBoolRequest, SetBoolResponse>(&mut node, &a.namespace, "spindle_stalled")?;
    let srv_delay = ros::server::<SetDelayRequest, SetDelayResponse>(
        &mut node,
        &a.namespace,
        "setpoint_delay",
    )?;

    let names: Vec<String> = machine.axes.iter().map(|x| x.name.clone()).collect();
    let mut model = model_for(&machine, a.seed);
    let home: Vec<f64> = machine.axes.iter().map(|x| x.home_mm).collect();
    let mut act = vec![0.0; home.len()];
    // the newest setpoint received (a change means busy, see the loop)
    let mut last_pos = home.clone();
    let mut queue = SetpointQueue::new(home, ms_to_ns(delay_ms));
    let mut late_reported = 0;
    let mut spindle_rpm = 0.0;
    let mut encoder_on = true;
    if a.rt_priority > 0 {
        if let Err(e) = ros::lock_memory() {
            ros_warn!("memory not locked (mlockall: {e})");
        }
        if let Err(e) = ros::set_realtime(a.rt_priority) {
            ros_warn!(
                "loop stays at normal priority (SCHED_FIFO {}: {e})",
                a.rt_priority
            );
        }
    }
    let start = Instant::now();
    // the steps are stamped with their grid instants whenever they run:
    // the loop sleeps to each one, it does not spin
    let mut grid = Grid::new(start, dt).without_spin();
    let mut clock = WallClock::new();
    let mut last_warn: Option<Instant> = None;
    let mut stalls = Stalls::default();
    let mut last_late: Option<Instant> = None;
    let mut states: Vec<JointState> = Vec::new();
    let mut pace = ros::Pace::new(rate);
    // the last setpoint's stamp (ns), and the last step's published state
    let mut last_set: Option<i64> = None;
    let mut last_state: Vec<f64> = Vec::new();
    let mut now_state: Vec<f64> = Vec::new();
    // the steps the last wait was for (more at rest, see the end)
    let mut intended = 1;
    let mut diag_at = Instant::now();
    ros_info!(
        "{} ({}), {} Hz, setpoints applied {}, domain {domain}, {ns}/joint_states, {ns}/spindle_encoder, {ns}/encoder_enabled, {ns}/spindle_stalled, {ns}/setpoint_delay",
        machine.name,
        names.join(" "),
        rate,
        applied(delay_ms),
        ns = a.namespace.trim_end_matches('/'),
    );
    loop {
        if ros::shutdown::requested() {
            ros_info!("SIGINT/SIGTERM: shut down");
            return Ok(());
        }
        // something happens: setpoints every cycle (closer than half the
        // resting period), a changed setpoint, command or fault
        let mut busy = false;
        // parameters set with `ros2 param set` (checked already)
        while let Ok((name, v)) = param_changes.try_recv() {
            set_parameter(&name, &v, &mut model, &mut queue);
            busy = true;
        }
        while let Ok(Some((m, _))) = ros::take_now(&sub_set) {
            let t = time_ns(&m.header.stamp);
            busy |= last_set.is_some_and(|p| t > p && ((t - p) as f64) < 0.5e9 / ros::REST_RATE_HZ);
            last_set = Some(t);
            let joints = || {
                m.name
                    .iter()
                    .zip(&m.position)
                    .filter_map(|(n, p)| names.iter().position(|x| x == n).map(|j| (j, p * 1000.0)))
            };
            for (j, p) in joints().filter(|(_, p)| p.is_finite()) {
                busy |= last_pos[j] != p;
                last_pos[j] = p;
            }
            queue.push(t, joints());
            mon.setpoint(start.elapsed().as_secs_f64());
        }
        while let Ok(Some((id, req))) = ros::receive_now(&srv_delay) {
            busy = true;
            let resp = match check_delay(req.delay_ms) {
                Ok(()) => {
                    let was = queue.delay_ns() as f64 * 1e-6;
                    queue.set_delay_ns(ms_to_ns(req.delay_ms));
                    let _ = parameters.set_local(
                        "setpoint_delay_ms",
                        ros2_client::ParameterValue::Double(req.delay_ms),
                    );
                    ros_warn!(
                        "setpoint delay {was} ms -> {} ms (fault injection)",
                        req.delay_ms
                    );
                    SetDelayResponse {
                        success: true,
                        message: format!(
                            "setpoints applied {} (was {was} ms)",
                            applied(req.delay_ms)
                        ),
                    }
                }
                Err(e) => SetDelayResponse {
                    success: false,
                    message: format!("delay_ms {e}; nothing changed"),
                },
            };
            let _ = srv_delay.send_response(id, resp);
        }
        while let Ok(Some((m, _))) = ros::take_now(&sub_spin) {
            if m.data.is_finite() {
                let rpm = m.data * 60.0 / std::f64::consts::TAU;
                busy |= rpm != spindle_rpm;
                spindle_rpm = rpm;
            }
        }
        while let Ok(Some((id, req))) = ros::receive_now(&srv_enc) {
            encoder_on = req.data;
            let message = match (model.spindle.is_some(), encoder_on) {
                (false, _) => "this machine has no spindle encoder".to_string(),
                (true, true) => "encoder readings published".to_string(),
                (true, false) => "encoder readings stopped".to_string(),
            };
            let success = model.spindle.is_some();
            let _ = srv_enc.send_response(id, SetBoolResponse { success, message });
            busy = true;
        }
        while let Ok(Some((id, req))) = ros::receive_now(&srv_stall) {
            busy = true;
            let resp = match model.spindle.as_mut() {
                Some(sp) => {
                    sp.set_stalled(req.data);
                    SetBoolResponse {
                        success: true,
                        message: if req.data {
                            "spindle stalled: it stands still whatever its command"
                        } else {
                            "spindle released: it follows its command"
                        }
                        .to_string(),
                    }
                }
                None => SetBoolResponse {
                    success: false,
                    message: "this machine has no spindle".to_string(),
                },
            };
            let _ = srv_stall.send_response(id, resp);
        }
        // the steps due by now (one, or the ones a late wake-up missed)
        let mut due = grid.due(Instant::now());
        // (1: on time)
        let late = (due + 1).saturating_sub(intended);
        if late as f64 * dt > MAX_BEHIND_S {
            ros_error!(
                "the loop fell {:.0} ms behind; the simulation skips it",
                due as f64 * dt * 1000.0
            );
            mon.skipped(due - 1);
            grid.skip(due - 1);
            due = 1;
        }
        if late as f64 * dt >= STALL_WARN_S {
            stalls.note(late);
        }
        if last_warn.is_none_or(|w| w.elapsed().as_secs() >= 1) {
            // (a reader of the encoder sees these readings late)
            if let Some(line) = stalls.report(dt) {
                ros_warn!("{line}");
                last_warn = Some(Instant::now());
            }
        }
        if busy {
            pace.busy(grid.next());
        }
        mon.wake(due, late, dt);
        // (the controller logs the system clock's moves)
        let _ = clock.update();
        // the encoder readings first (the controller waits for them), then
        // the joint states
        for _ in 0..due {
            let n = grid.advance();
            let stamp = clock.stamp(grid.at(n));
            let t_ns = time_ns(&stamp);
            model.step(queue.at(t_ns), spindle_rpm, dt);
            // a state that changes is published every step
            model.positions_into(&mut act);
            let e = model.spindle.as_ref().map(|sp| sp.encoder());
            now_state.clear();
            now_state.extend(
                act.iter()
                    .copied()
                    .chain(model.axes.iter().map(|x| x.velocity()))
                    .chain(e.map(|e| e.count as f64)),
            );
            if now_state != last_state {
                pace.busy(n);
                std::mem::swap(&mut now_state, &mut last_state);
            }
            if !pace.due(n) {
                continue;
            }
            if let (Some(sp), true) = (model.spindle.as_ref(), encoder_on) {
                let e = sp.encoder();
                let _ = pub_enc.publish(SpindleEncoder {
                    stamp,
                    count: e.count,
                    counts_per_rev: e.counts_per_rev,
                    index_count: e.index_count,
                    count_at_index: e.count_at_index,
                    velocity: e.velocity,
                });
            }
            states.push(JointState {
                header: Header {
                    stamp,
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: act.iter().map(|p| p / 1000.0).collect(),
                velocity: model.axes.iter().map(|x| x.velocity() / 1000.0).collect(),
                effort: Vec::new(),
            });
        }
        for js in states.drain(..) {
            let _ = pub_js.publish(js);
        }
        if queue.late() > late_reported && last_late.is_none_or(|w| w.elapsed().as_secs() >= 1) {
            ros_warn!(
                "{} setpoints arrived after their instant (stamp + {} ms) and were applied at once",
                queue.late() - late_reported,
                queue.delay_ns() as f64 * 1e-6
            );
            late_reported = queue.late();
            last_late = Some(Instant::now());
        }
        if diag_at.elapsed().as_secs_f64() >= 1.0 {
            diag_at = Instant::now();
            let spindle = model.spindle.as_ref().map(|sp| SpindleState {
                encoder_on,
                stalled: sp.stalled(),
                rpm: sp.speed_rpm(),
                command_rpm: spindle_rpm,
            });
            let status = mon.statuses(
                start.elapsed().as_secs_f64(),
                queue.late(),
                queue.delay_ns() as f64 * 1e-6,
                spindle,
                &hardware_id,
            );
            let _ = pub_diag.publish(DiagnosticArray {
                header: Header {
                    stamp: ros::wall_stamp(),
                    frame_id: String::new(),
                },
                status,
            });
        }
        if a.duration
            .is_some_and(|d| start.elapsed().as_secs_f64() >= d)
        {
            return Ok(());
        }
        // at rest the loop wakes only for the steps that publish and runs
        // the ones between at once (the model still takes every step)
        let next = grid.next();
        let target = if pace.resting(next) {
            pace.next_due(next)
        } else {
            next
        };
        intended = target + 1 - next;
        grid.wait_for(target);
    }
}

/// Puts a parameter set while the node runs into force.
fn set_parameter(
    name: &str,
    v: &ros2_client::ParameterValue,
    model: &mut sim_axes::MachineModel,
    queue: &mut SetpointQueue,
) {
    let ros2_client::ParameterValue::Double(x) = *v else {
        return;
    };
    match (name, model.spindle.as_mut()) {
        ("setpoint_delay_ms", _) => queue.set_delay_ns(ms_to_ns(x)),
        ("ripple", Some(sp)) => {
            let n = sp.params().noise_rpm;
            if let Err(e) = sp.set_disturbances(x, n) {
                ros_warn!("ripple {x}: {e}");
            }
        }
        ("noise_rpm", Some(sp)) => {
            let r = sp.params().ripple_fraction;
            if let Err(e) = sp.set_disturbances(r, x) {
                ros_warn!("noise_rpm {x}: {e}");
            }
        }
        _ => {}
    }
}

/// A setpoint delay is 0 to [`MAX_SETPOINT_DELAY_MS`] ms.
fn check_delay(ms: f64) -> Result<(), String> {
    if ms.is_finite() && (0.0..=MAX_SETPOINT_DELAY_MS).contains(&ms) {
        Ok(())
    } else {
        Err(format!(
            "{ms}: must be between 0 and {MAX_SETPOINT_DELAY_MS} ms"
        ))
    }
}

fn ms_to_ns(ms: f64) -> i64 {
    (ms * 1e6).round() as i64
}

fn applied(ms: f64) -> String {
    if ms > 0.0 {
        format!("{ms} ms after their stamps")
    } else {
        "on arrival".to_string()
    }
}

fn time_ns(t: &Time) -> i64 {
    i64::from(t.sec) * 1_000_000_000 + i64::from(t.nanosec)
}

/// The stalls not reported yet: a line a second at most, and none lost
/// to that limit (a test that runs a job again on a stall reads them).
#[derive(Default)]
struct Stalls {
    /// stalls since the last line, and the longest of them (steps)
    count: u64,
    worst: u64,
}

impl Stalls {
    fn note(&mut self, steps: u64) {
        self.count += 1;
        self.worst = self.worst.max(steps);
    }

    /// The line for the stalls noted since the last one (None: none),
    /// with steps of `dt` s.
    fn report(&mut self, dt: f64) -> Option<String> {
        let line = match self.count {
            0 => return None,
            1 => format!(
                "stalled: {} steps ({:.0} ms) ran late at once",
                self.worst,
                self.worst as f64 * dt * 1000.0
            ),
            n => format!(
                "stalled: {n} times since the last report, up to {} steps ({:.0} ms) late at once",
                self.worst,
                self.worst as f64 * dt * 1000.0
            ),
        };
        *self = Stalls::default();
        Some(line)
    }
}

#[cfg(test)]
mod tests {
    use super::Stalls;

    #[test]
    fn stalls_within_a_second_are_counted_in_the_next_line() {
        let mut s = Stalls::default();
        assert_eq!(s.report(0.001), None);
        s.note(5);
        assert_eq!(
            s.report(0.001).as_deref(),
            Some("stalled: 5 steps (5 ms) ran late at once")
        );
        s.note(6);
        s.note(12);
        s.note(7);
        assert_eq!(
            s.report(0.001).as_deref(),
            Some("stalled: 3 times since the last report, up to 12 steps (12 ms) late at once")
        );
        assert_eq!(s.report(0.001), None);
    }
}
