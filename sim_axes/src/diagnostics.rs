//! The simulator node's health as `diagnostic_msgs/DiagnosticStatus`es
//! (the node publishes them on `/diagnostics` once a second): its loop's
//! stalls, the setpoints it gets, the spindle's fault injection.
//!
//! - `sim_axes: simulation loop`: steps run, stalls (wake-ups that ran
//!   steps of [`STALL_S`] or more at once: the encoder's readings of them
//!   reach the controller late) and the longest, steps skipped (a loop
//!   more than a second behind pauses the simulated machine). OK; WARN
//!   on stalls; ERROR when steps were skipped.
//! - `sim_axes: setpoints`: setpoints that arrived after their instant
//!   (stamp + setpoint delay) in the period, the delay, the time since the
//!   last one arrived. OK; WARN when some were late, or none came for
//!   [`SETPOINTS_QUIET_S`] (the axes hold where they are).
//! - `sim_axes: spindle`: the encoder published or stopped and the spindle
//!   stalled or free (fault injection), the speed. WARN while a fault is
//!   injected.
//!
//! Pure: the node hands in the times (s of its monotonic clock).

use cnc_msgs::{short_num as num, DiagnosticStatus, KeyValue};

/// A wake-up that runs this much simulated time at once is a stall, s.
pub const STALL_S: f64 = 0.005;

/// No setpoint for this long is worth a warning, s.
pub const SETPOINTS_QUIET_S: f64 = 1.0;

/// The name of the loop's status.
pub const LOOP_NAME: &str = "sim_axes: simulation loop";
/// The name of the setpoints' status.
pub const SETPOINTS_NAME: &str = "sim_axes: setpoints";
/// The name of the spindle's status.
pub const SPINDLE_NAME: &str = "sim_axes: spindle";

/// What the simulator's loop did in the current period.
#[derive(Clone, Debug, Default)]
pub struct SimMonitor {
    steps: u64,
    stalls: u64,
    longest_stall_s: f64,
    skipped: u64,
    late_at_start: u64,
    last_setpoint_s: Option<f64>,
}

/// The spindle's state for its status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpindleState {
    /// encoder readings published (false: stopped by fault injection)
    pub encoder_on: bool,
    /// held still by fault injection
    pub stalled: bool,
    /// simulated speed, rpm
    pub rpm: f64,
    /// commanded speed, rpm
    pub command_rpm: f64,
}

impl SimMonitor {
    /// A wake-up that ran `steps` steps of `dt` s, `late` of them late (at
    /// rest the loop wakes for every 20th step and runs the ones between
    /// on time: those are not a stall).
    pub fn wake(&mut self, steps: u64, late: u64, dt: f64) {
        self.steps += steps;
        let span = late as f64 * dt;
        if span >= STALL_S {
            self.stalls += 1;
            self.longest_stall_s = self.longest_stall_s.max(span);
        }
    }

    /// `n` steps skipped (the loop fell more than a second behind).
    pub fn skipped(&mut self, n: u64) {
        self.skipped += n;
    }

    /// A setpoint arrived at `now_s`.
    pub fn setpoint(&mut self, now_s: f64) {
        self.last_setpoint_s = Some(now_s);
    }

    /// The statuses at `now_s`: `late` setpoints so far (the queue's
    /// count), the setpoint `delay_ms`, the spindle (None: the machine has
    /// none); the period's counts start again.
    pub fn statuses(
        &mut self,
        now_s: f64,
        late: u64,
        delay_ms: f64,
        spindle: Option<SpindleState>,
        hardware_id: &str,
    ) -> Vec<DiagnosticStatus> {
        let status = |level, name: &str, message: String, values| DiagnosticStatus {
            level,
            name: name.to_string(),
            message,
            hardware_id: hardware_id.to_string(),
            values,
        };
        let (level, message) = if self.skipped > 0 {
            (
                DiagnosticStatus::ERROR,
                format!(
                    "fell more than a second behind: {} steps skipped (the machine paused)",
                    self.skipped
                ),
            )
        } else if self.stalls > 0 {
            (
                DiagnosticStatus::WARN,
                format!(
                    "{} stalls, the longest {} ms",
                    self.stalls,
                    num(self.longest_stall_s * 1e3, 0)
                ),
            )
        } else {
            (
                DiagnosticStatus::OK,
                format!("{} steps on time", self.steps),
            )
        };
        let mut out = vec![status(
            level,
            LOOP_NAME,
            message,
            vec![
                KeyValue::new("steps", self.steps),
                KeyValue::new("stalls", self.stalls),
                KeyValue::new("longest stall (ms)", num(self.longest_stall_s * 1e3, 1)),
                KeyValue::new("skipped steps", self.skipped),
            ],
        )];
        let new_late = late.saturating_sub(self.late_at_start);
        let quiet = self.last_setpoint_s.map(|t| now_s - t);
        let (level, message) = match quiet {
            None => (
                DiagnosticStatus::WARN,
                "no setpoint yet: the axes stand at home".to_string(),
            ),
            Some(q) if q >= SETPOINTS_QUIET_S => (
                DiagnosticStatus::WARN,
                format!("no setpoint for {} s: the axes hold", num(q, 1)),
            ),
            Some(_) if new_late > 0 => (
                DiagnosticStatus::WARN,
                format!(
                    "{new_late} setpoints arrived after their instant (stamp + {} ms)",
                    num(delay_ms, 3)
                ),
            ),
            Some(_) => (DiagnosticStatus::OK, "setpoints on time".to_string()),
        };
        out.push(status(
            level,
            SETPOINTS_NAME,
            message,
            vec![
                KeyValue::new("late setpoints", new_late),
                KeyValue::new("late setpoints since start", late),
                KeyValue::new("setpoint delay (ms)", num(delay_ms, 3)),
                KeyValue::new(
                    "since last setpoint (ms)",
                    quiet.map_or("none".to_string(), |q| num(q * 1e3, 1)),
                ),
            ],
        ));
        if let Some(sp) = spindle {
            let mut faults = Vec::new();
            if !sp.encoder_on {
                faults.push("encoder readings stopped");
            }
            if sp.stalled {
                faults.push("spindle stalled");
            }
            let (level, message) = if faults.is_empty() {
                (DiagnosticStatus::OK, format!("{} rpm", num(sp.rpm, 0)))
            } else {
                (
                    DiagnosticStatus::WARN,
                    format!("fault injected: {}", faults.join(", ")),
                )
            };
            out.push(status(
                level,
                SPINDLE_NAME,
                message,
                vec![
                    KeyValue::new("encoder published", sp.encoder_on),
                    KeyValue::new("stalled", sp.stalled),
                    KeyValue::new("speed (rpm)", num(sp.rpm, 1)),
                    KeyValue::new("command (rpm)", num(sp.command_rpm, 1)),
                ],
            ));
        }
        *self = SimMonitor {
            late_at_start: late,
            last_setpoint_s: self.last_setpoint_s,
            ..SimMonitor::default()
        };
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value<'a>(s: &'a DiagnosticStatus, key: &str) -> &'a str {
        s.values
            .iter()
            .find(|k| k.key == key)
            .map(|k| k.value.as_str())
            .unwrap()
    }

    #[test]
    fn stalls_late_setpoints_and_faults_are_warnings_skips_an_error() {
        let mut m = SimMonitor::default();
        let st = m.statuses(0.0, 0, 3.0, None, "mill");
        assert_eq!(st.len(), 2);
        assert_eq!(
            (st[0].level, st[1].level),
            (DiagnosticStatus::OK, DiagnosticStatus::WARN)
        );
        assert_eq!(st[1].message, "no setpoint yet: the axes stand at home");
        // a quiet second at 1 kHz with setpoints
        for k in 0..1000 {
            m.wake(1, 1, 0.001);
            m.setpoint(1.0 + k as f64 * 0.001);
        }
        let on = SpindleState {
            encoder_on: true,
            stalled: false,
            rpm: 999.6,
            command_rpm: 1000.0,
        };
        let st = m.statuses(2.0, 0, 3.0, Some(on), "mill");
        assert!(st.iter().all(|s| s.level == DiagnosticStatus::OK), "{st:?}");
        assert_eq!(st[0].name, LOOP_NAME);
        assert_eq!(st[0].message, "1000 steps on time");
        assert_eq!(st[2].message, "1000 rpm");
        // a 12 ms stall and 7 late setpoints (of 9 since the start)
        m.wake(12, 12, 0.001);
        m.wake(1, 1, 0.001);
        m.setpoint(2.5);
        let st = m.statuses(3.0, 9, 3.0, Some(on), "mill");
        assert_eq!(st[0].level, DiagnosticStatus::WARN);
        assert_eq!(st[0].message, "1 stalls, the longest 12 ms");
        assert_eq!(value(&st[0], "longest stall (ms)"), "12");
        assert_eq!(st[1].level, DiagnosticStatus::WARN);
        assert_eq!(
            st[1].message,
            "9 setpoints arrived after their instant (stamp + 3 ms)"
        );
        // the next period counts from there
        let st = m.statuses(3.2, 9, 3.0, Some(on), "mill");
        assert_eq!(value(&st[1], "late setpoints"), "0");
        assert_eq!(st[1].level, DiagnosticStatus::OK);
        // no setpoints for 1.5 s; the encoder stopped; steps skipped
        m.skipped(1500);
        let off = SpindleState {
            encoder_on: false,
            stalled: true,
            ..on
        };
        let st = m.statuses(4.0, 9, 3.0, Some(off), "mill");
        assert_eq!(st[0].level, DiagnosticStatus::ERROR);
        assert!(st[0].message.contains("1500 steps skipped"));
        assert_eq!(st[1].message, "no setpoint for 1.5 s: the axes hold");
        assert_eq!(st[2].level, DiagnosticStatus::WARN);
        assert_eq!(
            st[2].message,
            "fault injected: encoder readings stopped, spindle stalled"
        );
    }
}
