//! The node's health as `diagnostic_msgs/DiagnosticStatus`es, for
//! `/diagnostics` once a second (`observe` publishes them), and the job's
//! log lines:
//!
//! - `cnc_node: control loop` ([`LoopMonitor`]): its wake-up lateness
//!   (p50, p99, max), the cycles that ran more than a period after their
//!   instant, cycles skipped (a loop more than 200 ms behind) and samples
//!   dropped (the publisher's queue full), over the last period. OK; WARN
//!   when cycles ran late or p99 is over half the period; ERROR when cycles
//!   were skipped, samples dropped, or the loop did not run at all.
//! - `cnc_node: spindle encoder` ([`EncoderWatch`]): the age of the newest
//!   reading (now minus its stamp), the longest it got in the period,
//!   readings per second, whether the index was seen, the speed. ERROR
//!   while the newest reading is older than the encoder timeout (the one
//!   that ends G33/G95 jobs: `spindle.encoder_timeout_ms`, default 25
//!   cycles); WARN when it was older than that in the period, or before
//!   the first reading; OK otherwise (and on a machine without spindle).
//! - `cnc_node: job` ([`JobWatch`]): state, job id, line, block, progress,
//!   override, spindle, last error; ERROR while the last job is in ERROR.
//!
//! [`JobWatch`] also says what the job's log lines are (held, resumed,
//! finished, aborted, failed), from the status the loop reports (its
//! start is the check worker's "accepted" line).

use crate::controller::{State, Status};
use cnc_core::Machine;
use cnc_msgs::rosout::Level;
use cnc_msgs::{short_num as num, DiagnosticStatus, KeyValue, SpindleEncoder};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// How often the node publishes `/diagnostics`.
pub const PERIOD: Duration = Duration::from_secs(1);

/// Bins of the lateness histogram: 1 µs up to 100 µs, 10 µs up to 1 ms,
/// 100 µs up to 10 ms, 1 ms up to 200 ms, then one for the rest.
const BINS: usize = 471;

fn bin_of(us: u64) -> usize {
    match us {
        0..100 => us as usize,
        100..1_000 => 100 + (us as usize - 100) / 10,
        1_000..10_000 => 190 + (us as usize - 1_000) / 100,
        10_000..200_000 => 280 + (us as usize - 10_000) / 1_000,
        _ => BINS - 1,
    }
}

/// The upper edge of a bin, µs (the last: 200 ms).
fn bin_top_us(b: usize) -> f64 {
    (match b {
        0..100 => b + 1,
        100..190 => 100 + (b - 100 + 1) * 10,
        190..280 => 1_000 + (b - 190 + 1) * 100,
        _ => 10_000 + (b.min(BINS - 2) - 280 + 1) * 1_000,
    }) as f64
}

/// The control loop's wake-ups, counted without locks or allocation by the
/// loop ([`wake`](Self::wake)) and summed up once a period by the DDS
/// thread ([`take`](Self::take)). The node's loop counts into [`LOOP`].
pub struct LoopMonitor {
    bins: [AtomicU64; BINS],
    wakeups: AtomicU64,
    cycles: AtomicU64,
    late_cycles: AtomicU64,
    skipped: AtomicU64,
    dropped: AtomicU64,
    max_ns: AtomicU64,
}

/// The node's control loop.
pub static LOOP: LoopMonitor = LoopMonitor::new();

impl Default for LoopMonitor {
    fn default() -> Self {
        Self::new()
    }
}

impl LoopMonitor {
    pub const fn new() -> Self {
        LoopMonitor {
            bins: [const { AtomicU64::new(0) }; BINS],
            wakeups: AtomicU64::new(0),
            cycles: AtomicU64::new(0),
            late_cycles: AtomicU64::new(0),
            skipped: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            max_ns: AtomicU64::new(0),
        }
    }

    /// A wake-up `late` after the instant of the first cycle due, running
    /// `cycles` cycles one period `dt` (s) apart: those more than a period
    /// after their instant count as late.
    pub fn wake(&self, late: Duration, cycles: u64, dt: f64) {
        let ns = late.as_nanos().min(u64::MAX as u128) as u64;
        self.bins[bin_of(ns / 1000)].fetch_add(1, Ordering::Relaxed);
        self.wakeups.fetch_add(1, Ordering::Relaxed);
        self.cycles.fetch_add(cycles, Ordering::Relaxed);
        self.max_ns.fetch_max(ns, Ordering::Relaxed);
        // cycle k of this wake-up is late - k·dt after its instant
        let periods = late.as_secs_f64() / dt - 1.0;
        if periods > 0.0 {
            let n = (periods.ceil() as u64).min(cycles);
            self.late_cycles.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// `n` cycles skipped (the loop fell too far behind).
    pub fn skipped(&self, n: u64) {
        self.skipped.fetch_add(n, Ordering::Relaxed);
    }

    /// `n` samples the publisher's queue had no room for.
    pub fn dropped(&self, n: u64) {
        self.dropped.fetch_add(n, Ordering::Relaxed);
    }

    /// What was counted since the last call (the counts start again).
    pub fn take(&self) -> LoopWindow {
        let take = |a: &AtomicU64| a.swap(0, Ordering::Relaxed);
        let mut bins = [0u64; BINS];
        for (b, a) in bins.iter_mut().zip(&self.bins) {
            *b = take(a);
        }
        let n: u64 = bins.iter().sum();
        let pct = |p: f64| {
            if n == 0 {
                return 0.0;
            }
            let want = ((p / 100.0) * n as f64).ceil().max(1.0) as u64;
            let mut acc = 0;
            for (i, &c) in bins.iter().enumerate() {
                acc += c;
                if acc >= want {
                    return bin_top_us(i);
                }
            }
            bin_top_us(BINS - 1)
        };
        LoopWindow {
            wakeups: take(&self.wakeups),
            cycles: take(&self.cycles),
            late_cycles: take(&self.late_cycles),
            skipped: take(&self.skipped),
            dropped: take(&self.dropped),
            p50_us: pct(50.0),
            p99_us: pct(99.0),
            max_us: take(&self.max_ns) as f64 / 1000.0,
        }
    }
}

/// The control loop over one period ([`LoopMonitor::take`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopWindow {
    pub wakeups: u64,
    pub cycles: u64,
    /// cycles run more than one period after their instant
    pub late_cycles: u64,
    pub skipped: u64,
    pub dropped: u64,
    /// wake-up lateness percentiles (upper edge of the bin) and maximum, µs
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
}

/// The names of the node's statuses (`<node>: <what>`).
pub const LOOP_NAME: &str = "cnc_node: control loop";
pub const ENCODER_NAME: &str = "cnc_node: spindle encoder";
pub const JOB_NAME: &str = "cnc_node: job";

impl LoopWindow {
    /// The status of the loop at `rate_hz` over `period_s`.
    pub fn status(&self, rate_hz: f64, period_s: f64, hardware_id: &str) -> DiagnosticStatus {
        let dt_us = 1e6 / rate_hz;
        let (level, message) = if self.wakeups == 0 {
            (
                DiagnosticStatus::ERROR,
                "the control loop did not run".to_string(),
            )
        } else if self.skipped > 0 || self.dropped > 0 {
            let mut m = Vec::new();
            if self.skipped > 0 {
                m.push(format!("fell behind: {} cycles skipped", self.skipped));
            }
            if self.dropped > 0 {
                m.push(format!(
                    "{} samples dropped (publisher queue full)",
                    self.dropped
                ));
            }
            (DiagnosticStatus::ERROR, m.join("; "))
        } else if self.late_cycles > 0 {
            (
                DiagnosticStatus::WARN,
                format!(
                    "{} cycles ran more than a period late (max {} ms)",
                    self.late_cycles,
                    num(self.max_us / 1000.0, 1)
                ),
            )
        } else if self.p99_us > dt_us / 2.0 {
            (
                DiagnosticStatus::WARN,
                format!(
                    "lateness p99 {} us, over half the period ({} us)",
                    num(self.p99_us, 0),
                    num(dt_us, 0)
                ),
            )
        } else {
            (
                DiagnosticStatus::OK,
                format!(
                    "on time: lateness p99 {} us, max {} us",
                    num(self.p99_us, 0),
                    num(self.max_us, 0)
                ),
            )
        };
        DiagnosticStatus {
            level,
            name: LOOP_NAME.to_string(),
            message,
            hardware_id: hardware_id.to_string(),
            values: vec![
                KeyValue::new("period (s)", num(period_s, 3)),
                KeyValue::new("rate (Hz)", num(rate_hz, 3)),
                KeyValue::new("wake-ups", self.wakeups),
                KeyValue::new("cycles", self.cycles),
                KeyValue::new("lateness p50 (us)", num(self.p50_us, 0)),
                KeyValue::new("lateness p99 (us)", num(self.p99_us, 0)),
                KeyValue::new("lateness max (us)", num(self.max_us, 1)),
                KeyValue::new("late cycles", self.late_cycles),
                KeyValue::new("skipped cycles", self.skipped),
                KeyValue::new("samples dropped", self.dropped),
            ],
        }
    }
}

/// The spindle encoder's readings as the node receives them.
#[derive(Clone, Debug)]
pub struct EncoderWatch {
    /// None: the machine has no spindle
    timeout_ns: Option<i64>,
    newest: Option<SpindleEncoder>,
    newest_ns: i64,
    readings: u64,
    max_age_ns: i64,
}

impl EncoderWatch {
    /// For `machine`: its encoder timeout (`spindle.encoder_timeout_ms`,
    /// else 25 interpolation cycles, as the executor's).
    pub fn new(machine: &Machine) -> Self {
        let timeout_ns = machine.spindle.as_ref().map(|s| {
            let t = s.encoder_timeout_ms.map_or(
                cnc_core::thread::ENCODER_TIMEOUT_CYCLES * machine.dt(),
                |ms| ms * 1e-3,
            );
            (t * 1e9).round() as i64
        });
        EncoderWatch {
            timeout_ns,
            newest: None,
            newest_ns: 0,
            readings: 0,
            max_age_ns: 0,
        }
    }

    /// A reading, received at `now_ns` (the system clock).
    pub fn reading(&mut self, m: &SpindleEncoder, now_ns: i64) {
        let ns = crate::convert::time_ns(&m.stamp);
        self.readings += 1;
        if self.newest.is_none() || ns >= self.newest_ns {
            self.newest_ns = ns;
            self.newest = Some(m.clone());
        }
        self.look(now_ns);
    }

    /// Notes the age of the newest reading at `now_ns` (call often: the
    /// longest age in the period is what it saw).
    pub fn look(&mut self, now_ns: i64) {
        if self.newest.is_some() {
            self.max_age_ns = self.max_age_ns.max(now_ns - self.newest_ns);
        }
    }

    /// The newest reading's angle, rad (0 before any).
    pub fn angle(&self) -> f64 {
        self.newest.as_ref().map_or(0.0, |m| {
            m.count as f64 / f64::from(m.counts_per_rev.max(1)) * std::f64::consts::TAU
        })
    }

    /// The status at `now_ns` over the last `period_s`; the period's counts
    /// start again.
    pub fn status(&mut self, now_ns: i64, period_s: f64, hardware_id: &str) -> DiagnosticStatus {
        self.look(now_ns);
        let ms = |ns: i64| num(ns as f64 / 1e6, 1);
        let mut st = DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: ENCODER_NAME.to_string(),
            message: String::new(),
            hardware_id: hardware_id.to_string(),
            values: Vec::new(),
        };
        let per_s = self.readings as f64 / period_s.max(1e-3);
        let max_age = self.max_age_ns;
        self.readings = 0;
        self.max_age_ns = 0;
        let Some(timeout) = self.timeout_ns else {
            st.message = "this machine has no spindle".to_string();
            return st;
        };
        let age = self.newest.as_ref().map(|_| now_ns - self.newest_ns);
        st.values = vec![
            KeyValue::new("age of last reading (ms)", age.map_or("none".into(), ms)),
            KeyValue::new("max age in period (ms)", ms(max_age)),
            KeyValue::new("readings per s", num(per_s, 1)),
            KeyValue::new("timeout (ms)", ms(timeout)),
        ];
        if let Some(m) = &self.newest {
            st.values.extend([
                KeyValue::new("index seen", m.index_count > 0),
                KeyValue::new("index pulses", m.index_count),
                KeyValue::new("count", m.count),
                KeyValue::new("counts per rev", m.counts_per_rev),
                KeyValue::new(
                    "speed (rpm)",
                    num(m.velocity * 60.0 / std::f64::consts::TAU, 1),
                ),
            ]);
        }
        (st.level, st.message) = match age {
            None => (DiagnosticStatus::WARN, "no reading yet".to_string()),
            Some(a) if a > timeout => (
                DiagnosticStatus::ERROR,
                format!(
                    "encoder signal lost: no reading for {} ms (timeout {} ms)",
                    num(a as f64 / 1e6, 0),
                    ms(timeout)
                ),
            ),
            Some(_) if max_age > timeout => (
                DiagnosticStatus::WARN,
                format!(
                    "readings stopped for up to {} ms in the last period (timeout {} ms)",
                    num(max_age as f64 / 1e6, 0),
                    ms(timeout)
                ),
            ),
            Some(a) => (
                DiagnosticStatus::OK,
                format!("{} readings/s, the last {} ms old", num(per_s, 0), ms(a)),
            ),
        };
        st
    }
}

/// The state's name, as `cnc status` prints it.
pub fn state_name(s: State) -> &'static str {
    match s {
        State::Idle => "IDLE",
        State::Running => "RUNNING",
        State::Hold => "HOLD",
        State::Error => "ERROR",
    }
}

/// The job as the loop reports it: its diagnostic status, and its log
/// lines on state changes.
#[derive(Clone, Debug, Default)]
pub struct JobWatch {
    last: Option<Status>,
    /// (job id, stamp ns of its first RUNNING status)
    started: Option<(u32, i64)>,
}

impl JobWatch {
    /// A status stamped `stamp_ns`: the log line its change of state
    /// calls for, if any.
    pub fn status(&mut self, s: &Status, stamp_ns: i64) -> Option<(Level, String)> {
        let prev = self.last.replace(s.clone());
        let (was, was_job) = prev.map_or((State::Idle, 0), |p| (p.state, p.job_id));
        if s.state == was && s.job_id == was_job {
            return None;
        }
        let id = s.job_id;
        let line = s.source_line;
        match s.state {
            State::Running if was == State::Hold && was_job == id => {
                Some((Level::Info, format!("job {id} resumed at line {line}")))
            }
            State::Running => {
                self.started = Some((id, stamp_ns));
                None
            }
            State::Hold => Some((Level::Info, format!("job {id} held at line {line}"))),
            State::Idle if s.last_error.is_empty() => {
                let took = self
                    .started
                    .filter(|(j, _)| *j == id)
                    .map(|(_, t0)| format!(" in {} s", num((stamp_ns - t0) as f64 / 1e9, 3)))
                    .unwrap_or_default();
                Some((Level::Info, format!("job {id} finished{took}")))
            }
            State::Idle => Some((Level::Warn, s.last_error.clone())),
            State::Error => Some((Level::Error, format!("job {id} failed: {}", s.last_error))),
        }
    }

    /// The job's diagnostic status.
    pub fn diagnostic(&self, hardware_id: &str) -> DiagnosticStatus {
        let mut st = DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: JOB_NAME.to_string(),
            message: "no job yet".to_string(),
            hardware_id: hardware_id.to_string(),
            values: Vec::new(),
        };
        let Some(s) = &self.last else {
            return st;
        };
        let state = state_name(s.state);
        st.values = vec![
            KeyValue::new("state", state),
            KeyValue::new("job id", s.job_id),
            KeyValue::new("line", s.source_line),
            KeyValue::new("block", s.block_number),
            KeyValue::new("progress (%)", num(s.progress * 100.0, 1)),
            KeyValue::new("feed override (%)", num(s.feed_override * 100.0, 1)),
            KeyValue::new("spindle (rpm)", num(s.spindle_rpm, 1)),
            KeyValue::new("tool", s.active_tool),
            KeyValue::new("last error", &s.last_error),
        ];
        st.message = match s.state {
            _ if s.job_id == 0 => "no job yet".to_string(),
            State::Running | State::Hold => format!(
                "job {} {}, line {}, {} %",
                s.job_id,
                if s.state == State::Hold {
                    "held"
                } else {
                    "running"
                },
                s.source_line,
                num(s.progress * 100.0, 1)
            ),
            State::Idle if s.last_error.is_empty() => format!("job {} finished", s.job_id),
            State::Idle => s.last_error.clone(),
            State::Error => format!("job {} failed: {}", s.job_id, s.last_error),
        };
        if s.state == State::Error {
            st.level = DiagnosticStatus::ERROR;
        }
        st
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
            .unwrap_or_else(|| panic!("no {key} in {s:?}"))
    }

    #[test]
    fn bins_cover_the_range_and_their_edges_are_above_their_values() {
        let mut last = 0;
        for us in 0..250_000u64 {
            let b = bin_of(us);
            assert!(b >= last && b < BINS, "{us}");
            last = b;
            if b < BINS - 1 {
                assert!(bin_top_us(b) > us as f64, "{us}: bin {b}");
                assert!(bin_top_us(b) <= us as f64 * 1.1 + 1.0, "{us}: bin {b}");
            }
        }
    }

    #[test]
    fn an_on_time_loop_is_ok_with_its_percentiles() {
        let m = LoopMonitor::new();
        // 1000 wake-ups at 1 kHz: 990 at 5 µs, 10 at 300 µs
        for i in 0..1000 {
            let late = if i % 100 == 0 { 300 } else { 5 };
            m.wake(Duration::from_micros(late), 1, 0.001);
        }
        let w = m.take();
        assert_eq!((w.wakeups, w.cycles, w.late_cycles), (1000, 1000, 0));
        assert_eq!((w.p50_us, w.p99_us), (6.0, 6.0));
        assert_eq!(w.max_us, 300.0);
        let s = w.status(1000.0, 1.0, "mill (/cnc)");
        assert_eq!(s.level, DiagnosticStatus::OK, "{s:?}");
        assert_eq!(s.name, LOOP_NAME);
        assert_eq!(value(&s, "lateness p99 (us)"), "6");
        assert_eq!(value(&s, "lateness max (us)"), "300");
        assert_eq!(value(&s, "cycles"), "1000");
        // the counts start again
        assert_eq!(m.take().wakeups, 0);
    }

    #[test]
    fn late_cycles_warn_and_skipped_cycles_are_an_error() {
        let m = LoopMonitor::new();
        for _ in 0..95 {
            m.wake(Duration::from_micros(10), 1, 0.001);
        }
        // woke 3.5 ms late and ran 2 cycles (catching up): both over a
        // period after their instants; then 2.2 ms late with 2 cycles: the
        // first 2.2 ms, the second 1.2 ms late
        m.wake(Duration::from_micros(3500), 2, 0.001);
        m.wake(Duration::from_micros(2200), 2, 0.001);
        // 1.0 ms late exactly: not more than a period
        m.wake(Duration::from_micros(1000), 1, 0.001);
        let w = m.take();
        assert_eq!(w.late_cycles, 4);
        assert_eq!(w.cycles, 100);
        // (98 wake-ups: the 99th percentile is the latest, in the bin up to 3.6 ms)
        assert_eq!((w.wakeups, w.p99_us, w.max_us), (98, 3600.0, 3500.0));
        let s = w.status(1000.0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::WARN, "{s:?}");
        assert!(
            s.message
                .starts_with("4 cycles ran more than a period late (max 3.5 ms)"),
            "{}",
            s.message
        );
        m.wake(Duration::from_millis(250), 2, 0.001);
        m.skipped(249);
        m.dropped(3);
        let s = m.take().status(1000.0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::ERROR);
        assert_eq!(
            s.message,
            "fell behind: 249 cycles skipped; 3 samples dropped (publisher queue full)"
        );
        assert_eq!(value(&s, "skipped cycles"), "249");
        // a loop that did not wake at all
        let s = m.take().status(1000.0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::ERROR);
        // a jittery loop: p99 over half the period
        for i in 0..100 {
            m.wake(
                Duration::from_micros(if i < 5 { 700 } else { 20 }),
                1,
                0.001,
            );
        }
        let s = m.take().status(1000.0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::WARN);
        assert!(s.message.contains("over half the period"), "{}", s.message);
    }

    fn reading(stamp_ns: i64, count: i64, index_count: i64) -> SpindleEncoder {
        SpindleEncoder {
            stamp: crate::convert::time_from_ns(stamp_ns as u64),
            count,
            counts_per_rev: 4096,
            index_count,
            count_at_index: 0,
            velocity: 104.72,
        }
    }

    #[test]
    fn the_encoder_is_an_error_once_its_newest_reading_is_older_than_the_timeout() {
        let m = Machine::builtin_mill();
        let mut e = EncoderWatch::new(&m);
        let t0 = 1_700_000_000_000_000_000i64;
        let s = e.status(t0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::WARN);
        assert_eq!(s.message, "no reading yet");
        // 1000 readings a second, each received 0.3 ms after its stamp
        for k in 0..1000 {
            let ns = t0 + k * 1_000_000;
            e.reading(&reading(ns, k * 100, k / 41), ns + 300_000);
        }
        let now = t0 + 999_000_000 + 800_000;
        let s = e.status(now, 1.0, "mill (/cnc)");
        assert_eq!(s.level, DiagnosticStatus::OK, "{s:?}");
        assert_eq!(s.name, ENCODER_NAME);
        assert_eq!(value(&s, "age of last reading (ms)"), "0.8");
        assert_eq!(value(&s, "readings per s"), "1000");
        assert_eq!(value(&s, "index seen"), "true");
        assert_eq!(value(&s, "timeout (ms)"), "25");
        assert_eq!(value(&s, "speed (rpm)"), "1000");
        // the angle of the newest reading: 99 900 counts of 4096 a turn
        assert!((e.angle() - 99_900.0 / 4096.0 * std::f64::consts::TAU).abs() < 1e-9);
        // a gap (the newest reading 25.8 ms old), then readings again: a
        // warning for the period
        e.look(now + 25_000_000);
        e.reading(&reading(now + 25_000_000, 0, 25), now + 25_100_000);
        let s = e.status(now + 25_200_000, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::WARN, "{s:?}");
        assert!(
            s.message.starts_with("readings stopped for up to 26 ms"),
            "{}",
            s.message
        );
        // then none: an error, with the age
        let s = e.status(now + 1_525_000_000, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::ERROR);
        assert_eq!(
            s.message,
            "encoder signal lost: no reading for 1500 ms (timeout 25 ms)"
        );
        assert_eq!(value(&s, "age of last reading (ms)"), "1500");
        assert_eq!(value(&s, "readings per s"), "0");
    }

    #[test]
    fn a_machine_without_spindle_has_an_ok_encoder_status() {
        let mut m = Machine::builtin_mill();
        m.spindle = None;
        let mut e = EncoderWatch::new(&m);
        let s = e.status(0, 1.0, "");
        assert_eq!(s.level, DiagnosticStatus::OK);
        assert!(s.values.is_empty());
    }

    fn status(state: State, job: u32, line: u32, err: &str) -> Status {
        Status {
            state,
            job_id: job,
            source_line: line,
            block_number: -1,
            active_g_codes: Vec::new(),
            active_tool: 0,
            spindle_rpm: 0.0,
            feed_override: 1.0,
            progress: 0.5,
            last_error: err.to_string(),
        }
    }

    #[test]
    fn the_jobs_log_lines_and_status() {
        let mut w = JobWatch::default();
        assert_eq!(w.diagnostic("").message, "no job yet");
        assert_eq!(w.status(&status(State::Idle, 0, 0, ""), 0), None);
        let s = 1_000_000_000;
        // (the start is logged by the check worker: "job 1 accepted")
        assert_eq!(w.status(&status(State::Running, 1, 1, ""), s), None);
        assert_eq!(w.status(&status(State::Running, 1, 2, ""), s + 1), None);
        let d = w.diagnostic("mill (/cnc)");
        assert_eq!(
            (d.level, d.message.as_str()),
            (DiagnosticStatus::OK, "job 1 running, line 2, 50 %")
        );
        assert_eq!(value(&d, "state"), "RUNNING");
        assert_eq!(value(&d, "progress (%)"), "50");
        assert_eq!(
            w.status(&status(State::Hold, 1, 2, ""), s + 2),
            Some((Level::Info, "job 1 held at line 2".into()))
        );
        assert_eq!(
            w.status(&status(State::Running, 1, 2, ""), s + 3),
            Some((Level::Info, "job 1 resumed at line 2".into()))
        );
        assert_eq!(
            w.status(&status(State::Idle, 1, 4, ""), s + 2_500_000_000),
            Some((Level::Info, "job 1 finished in 2.5 s".into()))
        );
        w.status(&status(State::Running, 2, 1, ""), s);
        assert_eq!(
            w.status(&status(State::Idle, 2, 3, "job 2 aborted at line 3"), s),
            Some((Level::Warn, "job 2 aborted at line 3".into()))
        );
        w.status(&status(State::Running, 3, 1, ""), s);
        let err = "line 3: spindle encoder signal lost: no reading for 26 ms";
        assert_eq!(
            w.status(&status(State::Error, 3, 3, err), s),
            Some((Level::Error, format!("job 3 failed: {err}")))
        );
        let d = w.diagnostic("");
        assert_eq!(d.level, DiagnosticStatus::ERROR);
        assert_eq!(d.message, format!("job 3 failed: {err}"));
        assert_eq!(value(&d, "last error"), err);
        // the next job clears it
        w.status(&status(State::Running, 4, 1, ""), s);
        assert_eq!(w.diagnostic("").level, DiagnosticStatus::OK);
    }
}
