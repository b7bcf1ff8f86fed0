//! Time for fixed-rate loops: the cycle grid ([`Grid`]), stamps in the
//! wall clock ([`WallClock`]) and wake-up lateness ([`Lateness`]).

use std::time::{Duration, Instant};

/// The cycles of a fixed-rate loop on the grid `origin + n·dt` of the
/// monotonic clock. Cycle n is *meant for* its grid instant: a loop that
/// woke late runs the cycles it missed ([`Grid::due`]) rather than shifting
/// every later one, so its n-th cycle always stands for the same instant
/// and its stamps ([`WallClock::stamp`]) are exactly n·dt apart. Instants are
/// computed from n (no accumulated rounding, also when dt is not a whole
/// number of nanoseconds).
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    origin: Instant,
    dt: f64,
    next: u64,
    /// how long before an instant the sleep ends (the rest is spun): the
    /// sleep's own lateness, learnt (see [`Grid::wait`]), ns
    margin_ns: f64,
    /// the margin's bound, ns ([`MAX_SPIN`], or 0 for a grid that only
    /// sleeps)
    max_spin_ns: f64,
    /// how long before the instant a wait may return: zero (it spins
    /// from the sleep's end to the instant), or for a grid that runs early
    /// ([`Grid::running_early`]) up to a quarter period, spinning only what
    /// the margin leaves beyond that
    early: Duration,
    /// the share of sleeps that end before the instant they wake for,
    /// which the margin follows ([`ON_TIME_SHARE`], or
    /// [`EARLY_ON_TIME_SHARE`] for a grid that runs early)
    on_time: f64,
    last_wake: Option<Instant>,
}

/// The longest a [`Grid`] wakes before an instant (its margin's bound,
/// and at most half a period): it spins that long at most, or runs its
/// cycle that early.
pub const MAX_SPIN: Duration = Duration::from_micros(150);
/// The share of a [`Grid`]'s sleeps that end before the instant they wake
/// for: its margin follows this quantile of the sleep's lateness.
const ON_TIME_SHARE: f64 = 0.9;
/// The same share for a grid that runs early ([`Grid::running_early`]) by
/// up to its whole margin (at rates up to 1.6 kHz): its margin costs no
/// spin (the cycle runs when the sleep ends), so it follows the 99th
/// percentile of the sleep's lateness, and one wake-up in a hundred, not
/// one in ten, comes after its instant (at 1 kHz the controller's
/// wake-ups were up to 55–72 µs late at p99 with 0.9, on a quiet host).
const EARLY_ON_TIME_SHARE: f64 = 0.99;

/// The margin after a sleep that ended `late_ns` after it was asked to
/// end (`margin_ns` before the instant): a step of `on_time` µs up when the
/// sleep ended after the instant, of `1 − on_time` µs down otherwise, so it
/// settles where that share of sleeps end before the instant; within
/// `0..=max_ns`.
fn next_margin(margin_ns: f64, late_ns: f64, on_time: f64, max_ns: f64) -> f64 {
    if late_ns > margin_ns {
        margin_ns + 1000.0 * on_time
    } else {
        margin_ns - 1000.0 * (1.0 - on_time)
    }
    .clamp(0.0, max_ns)
}

impl Grid {
    /// Cycle 0 at `origin`, one every `dt` seconds. Create it on the
    /// loop's thread: it sets that thread's timer slack to 1 ns.
    pub fn new(origin: Instant, dt: f64) -> Self {
        // SAFETY: prctl(PR_SET_TIMERSLACK) only changes this thread's timer
        // slack (1 ns instead of the default 50 µs); no memory is touched.
        unsafe {
            libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0);
        }
        // (at most half a period: a loop at several kHz spun all the time,
        // its margin a whole period)
        let max_spin_ns = (MAX_SPIN.as_nanos() as f64).min(0.5 * dt * 1e9);
        Grid {
            origin,
            dt,
            next: 0,
            margin_ns: max_spin_ns.min(50_000.0),
            max_spin_ns,
            early: Duration::ZERO,
            on_time: ON_TIME_SHARE,
            last_wake: None,
        }
    }

    /// The same grid, but its waits end with the sleep, up to the learnt
    /// margin before the instant, instead of spinning the rest: the caller
    /// runs the cycle then, stamped with its instant. For a loop whose
    /// cycles compute from their stamps, not from the time they run (the
    /// controller): without a spin to pay for, its margin follows the
    /// 99th percentile of the sleep's lateness ([`EARLY_ON_TIME_SHARE`]),
    /// so 99 wake-ups in 100 come a few tens of µs before the instant and
    /// the rest as late as the sleep leaves them, without the spin (most
    /// of a 1 kHz loop's CPU time). A wait returns at most a quarter period
    /// early, so a cycle never runs before the one ahead of it was meant
    /// to; where the margin is larger (rates over 1.6 kHz), the rest is
    /// spun as before.
    pub fn running_early(mut self) -> Self {
        self.early = Duration::from_nanos((0.25 * self.dt * 1e9).min(self.max_spin_ns) as u64);
        // (where a part of the margin is spun, over 1.6 kHz, a larger
        // margin costs CPU again: there it stays at the 90th percentile)
        if self.early.as_nanos() as f64 >= self.max_spin_ns {
            self.on_time = EARLY_ON_TIME_SHARE;
        }
        self
    }

    /// How long before an instant a wait may return at most (zero unless
    /// the grid runs early).
    pub fn early(&self) -> Duration {
        self.early
    }

    /// The same grid, but its waits only sleep (no spin): wake-ups end some
    /// tens of µs after the instant. For a loop that stamps its cycles with
    /// their grid instants whenever it runs them (the simulator), whose
    /// lateness changes no value it computes: the spin would cost a few %
    /// of a core at 1 kHz, at real-time priority, for nothing.
    pub fn without_spin(mut self) -> Self {
        self.margin_ns = 0.0;
        self.max_spin_ns = 0.0;
        self
    }

    /// The instant of cycle `n`.
    pub fn at(&self, n: u64) -> Instant {
        self.origin + Duration::from_secs_f64(n as f64 * self.dt)
    }

    /// The next cycle to run.
    pub fn next(&self) -> u64 {
        self.next
    }

    /// How many cycles are due at `now` and not run yet (0 when the next
    /// one's instant is still to come).
    pub fn due(&self, now: Instant) -> u64 {
        if self.at(self.next) > now {
            return 0;
        }
        let x = now.saturating_duration_since(self.origin).as_secs_f64() / self.dt;
        let mut last = (x.floor() as u64).max(self.next);
        // (the division may land a hair either side of a whole cycle)
        while last > self.next && self.at(last) > now {
            last -= 1;
        }
        while self.at(last + 1) <= now {
            last += 1;
        }
        last + 1 - self.next
    }

    /// Moves every instant from the next cycle on `by` later (a loop at
    /// rest that lines its cycles up with another clock's; the stamps of
    /// the cycles before and after are then not whole periods apart).
    pub fn delay(&mut self, by: Duration) {
        self.origin += by;
    }

    /// Marks the next cycle as run; returns its number.
    pub fn advance(&mut self) -> u64 {
        self.next += 1;
        self.next - 1
    }

    /// Skips `n` cycles without running them (a loop too far behind).
    pub fn skip(&mut self, n: u64) {
        self.next += n;
    }

    /// Waits for the next cycle's instant and returns it: sleeps until
    /// shortly before, then spins the rest, so wake-ups are on time within
    /// microseconds. A loop that is behind returns at once, but at most
    /// twice a period, so its catching up is spread out (and runs as many
    /// cycles per wake-up as the caller allows).
    ///
    /// How long before is learnt: the sleep ends late by some tens of µs
    /// (the timer, the scheduler), so it is asked to end that much early
    /// and the rest is spun. The margin follows the 90th percentile of that
    /// lateness (a step of up to 1 µs per wake-up, up to [`MAX_SPIN`];
    /// [`next_margin`]), so nine
    /// sleeps in ten end before the instant and spin only the difference
    /// (a few µs, not a fixed 150 µs: most of a 1 kHz loop's CPU time was
    /// that spin), and a rare stall moves it by a microsecond only.
    pub fn wait(&mut self) -> Instant {
        self.wait_for(self.next)
    }

    /// Waits for the instant of cycle `n` (the next one or a later one: a
    /// loop at rest that runs the cycles in between at once, see
    /// [`Pace::next_due`]) and returns it, as [`Grid::wait`]. A grid
    /// running early ([`Grid::running_early`]) returns when its sleep ends,
    /// which may be up to its margin (at most a quarter period) before
    /// that instant.
    pub fn wait_for(&mut self, n: u64) -> Instant {
        let deadline = self.at(n.max(self.next));
        let mut until = deadline;
        if let Some(w) = self.last_wake {
            until = until.max(w + Duration::from_secs_f64(0.5 * self.dt));
        }
        let margin = Duration::from_nanos(self.margin_ns as u64);
        let now = Instant::now();
        if now + margin < until {
            let wake = until - margin;
            std::thread::sleep(wake - now);
            let late = Instant::now().saturating_duration_since(wake).as_nanos() as f64;
            self.margin_ns = next_margin(self.margin_ns, late, self.on_time, self.max_spin_ns);
        }
        while Instant::now() + self.early < until {
            std::hint::spin_loop();
        }
        self.last_wake = Some(Instant::now());
        deadline
    }

    /// How long before an instant the sleep ends now (the spin's bound).
    pub fn margin(&self) -> Duration {
        Duration::from_nanos(self.margin_ns as u64)
    }

    /// How long before its instant a wait returns now, when the sleep
    /// ends on time: the margin, up to how early the grid may run
    /// ([`Grid::running_early`]; zero for a grid that spins to each
    /// instant).
    pub fn runs_early_by(&self) -> Duration {
        self.margin().min(self.early)
    }
}

/// The CPU time the calling thread has used (`CLOCK_THREAD_CPUTIME_ID`:
/// user and kernel, its sleeps' switches included): a real-time loop
/// checks with it that it leaves its CPU to the threads below it. A
/// system call, so for a check now and then, not every cycle.
pub fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec, which `ts` is; the clock
    // is the calling thread's own and always there on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return Duration::ZERO;
    }
    Duration::new(
        ts.tv_sec.max(0) as u64,
        ts.tv_nsec.clamp(0, 999_999_999) as u32,
    )
}

/// Maps instants of the monotonic clock to the system (wall) clock, the
/// clock ROS stamps are in. Loops stamp their cycles with their grid
/// instants this way, so stamps are exactly a period apart whatever the
/// wake-up jitter, and in the clock every node on the host stamps with.
///
/// The offset between the clocks is measured by reading the wall clock
/// between two reads of the monotonic one: the true offset is within half
/// their distance (the bracket) of the measurement. A measurement the
/// thread was interrupted in (the two more than
/// [`WallClock::MAX_BRACKET`] apart) keeps the previous offset, so a
/// preemption between the reads never shifts a stamp; any other moves
/// the offset only when it proves it wrong, and then only to the nearest
/// offset it allows ([`consistent_offset`]). So the offset changes only
/// when the system clock is slewed or stepped; [`WallClock::update`] once
/// a cycle follows that. (Taking each measurement's midpoint moved every
/// stamp by up to half a bracket, up to 10 µs, whenever a wide one came:
/// a live test once saw a 500 Hz setpoint 2 µs off its grid.)
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    anchor: Instant,
    /// wall clock (ns since the epoch) minus monotonic (ns since anchor)
    offset_ns: i128,
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl WallClock {
    /// The widest bracket a measurement of the offset may have.
    pub const MAX_BRACKET: Duration = Duration::from_micros(20);

    pub fn new() -> Self {
        let mut c = WallClock {
            anchor: Instant::now(),
            offset_ns: 0,
        };
        // the first measurement is taken whatever its bracket (a narrow
        // one is very likely within a few tries)
        let mut best: Option<(Duration, i128)> = None;
        for _ in 0..10 {
            if let Some((w, off)) = c.measure() {
                if best.is_none_or(|(bw, _)| w < bw) {
                    best = Some((w, off));
                }
                if w <= Self::MAX_BRACKET {
                    break;
                }
            }
        }
        if let Some((_, off)) = best {
            c.offset_ns = off;
        }
        c
    }

    /// (bracket, offset) of one measurement.
    fn measure(&self) -> Option<(Duration, i128)> {
        let m1 = Instant::now();
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .ok()?;
        let m2 = Instant::now();
        let mid =
            m1.duration_since(self.anchor).as_nanos() as i128 + (m2 - m1).as_nanos() as i128 / 2;
        Some((m2 - m1, wall.as_nanos() as i128 - mid))
    }

    /// Measures the offset again (kept when the measurement was
    /// interrupted, or when it agrees with the offset there); how far it
    /// moved, ns (0: kept), which is how far the system clock was slewed
    /// or stepped against the monotonic one since the last that moved it.
    pub fn update(&mut self) -> i128 {
        let before = self.offset_ns;
        if let Some((w, off)) = self.measure() {
            if w <= Self::MAX_BRACKET {
                self.offset_ns = consistent_offset(self.offset_ns, off, w.as_nanos() as i128);
            }
        }
        self.offset_ns - before
    }

    /// The wall clock's time at `at`, ns since the epoch.
    pub fn ns_at(&self, at: Instant) -> i128 {
        let mono = match at.checked_duration_since(self.anchor) {
            Some(d) => d.as_nanos() as i128,
            None => -(self.anchor.duration_since(at).as_nanos() as i128),
        };
        mono + self.offset_ns
    }

    /// The wall clock's time at `at`, as a ROS stamp.
    pub fn stamp(&self, at: Instant) -> crate::Time {
        let ns = self.ns_at(at).max(0);
        crate::Time {
            sec: (ns / 1_000_000_000).min(i32::MAX as i128) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// The clocks' offset (ns) to keep after a measurement `off` with a
/// bracket of `bracket` ns: `current` while the true offset may still be
/// it (within half the bracket, rounded up, of `off`), else the nearest
/// offset the measurement allows.
fn consistent_offset(current: i128, off: i128, bracket: i128) -> i128 {
    let half = (bracket.max(0) + 1) / 2;
    current.clamp(off - half, off + half)
}

/// Wake-up lateness of a loop, in 1 µs bins up to 20 ms (one overflow bin):
/// fixed memory, no allocation per record.
pub struct Lateness {
    bins: Vec<u64>,
    n: u64,
    max_us: f64,
    /// the record number of the worst one
    max_at: u64,
}

impl Default for Lateness {
    fn default() -> Self {
        Self::new()
    }
}

impl Lateness {
    const BINS: usize = 20_001;

    pub fn new() -> Self {
        Lateness {
            bins: vec![0; Self::BINS],
            n: 0,
            max_us: 0.0,
            max_at: 0,
        }
    }

    pub fn record(&mut self, late: Duration) {
        let us = late.as_secs_f64() * 1e6;
        let b = (us as usize).min(Self::BINS - 1);
        self.bins[b] += 1;
        self.n += 1;
        if us > self.max_us {
            self.max_us = us;
            self.max_at = self.n;
        }
    }

    /// The `p`-th percentile in µs (bin upper edge).
    pub fn percentile(&self, p: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let want = ((p / 100.0) * self.n as f64).ceil().max(1.0) as u64;
        let mut acc = 0;
        for (i, &c) in self.bins.iter().enumerate() {
            acc += c;
            if acc >= want {
                return (i + 1) as f64;
            }
        }
        self.max_us
    }

    pub fn count(&self) -> u64 {
        self.n
    }

    /// How many were later than `us` (whole µs, up to 20,000).
    pub fn over(&self, us: usize) -> u64 {
        self.bins[us.min(Self::BINS - 1)..].iter().sum()
    }

    /// `n=…, p50 … µs, p99 …, p99.9 …, max …, over 1 ms: …` (the counts
    /// are cumulative: two summaries give the wake-ups over 1 ms between)
    pub fn summary(&self) -> String {
        format!(
            "n={} p50<={:.0} us p99<={:.0} us p99.9<={:.0} us max={:.1} us (cycle {}) over_1ms={}",
            self.n,
            self.percentile(50.0),
            self.percentile(99.0),
            self.percentile(99.9),
            self.max_us,
            self.max_at,
            self.over(1000)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lateness_percentiles() {
        let mut l = Lateness::new();
        for i in 0..1000u64 {
            l.record(Duration::from_nanos(i * 1000 + 500));
        }
        assert_eq!(l.count(), 1000);
        assert_eq!(l.percentile(50.0), 500.0);
        assert_eq!(l.percentile(99.0), 990.0);
        assert!((l.max_us - 999.5).abs() < 1e-6);
        assert_eq!(l.over(990), 10);
        l.record(Duration::from_millis(30));
        assert_eq!(l.over(1000), 1);
        assert!(l.summary().ends_with("over_1ms=1"), "{}", l.summary());
    }

    #[test]
    fn grid_counts_missed_cycles_and_keeps_its_instants() {
        let o = Instant::now();
        let mut g = Grid::new(o, 0.001);
        assert_eq!(g.due(o), 1);
        assert_eq!(g.advance(), 0);
        assert_eq!(g.due(o), 0);
        assert_eq!(g.due(o + Duration::from_micros(999)), 0);
        assert_eq!(g.due(o + Duration::from_micros(1000)), 1);
        // woke 3.5 cycles late: cycles 1..=4 are due
        assert_eq!(g.due(o + Duration::from_micros(4500)), 4);
        g.skip(2);
        assert_eq!(g.next(), 3);
        assert_eq!(g.due(o + Duration::from_micros(4500)), 2);
        assert_eq!(g.due(o + Duration::from_micros(2999)), 0);
        // no drift: the instant of cycle n is n·dt from the origin
        let dt = 1.0 / 3000.0;
        let g = Grid::new(o, dt);
        let n = 3_000_000 * 3600;
        assert_eq!(g.at(n) - o, Duration::from_secs(3_600_000));
    }

    #[test]
    fn a_delayed_grid_keeps_its_count_and_moves_its_instants() {
        let o = Instant::now();
        let mut g = Grid::new(o, 0.001);
        g.advance();
        g.advance();
        g.delay(Duration::from_micros(231));
        assert_eq!(g.next(), 2);
        assert_eq!(g.at(2) - o, Duration::from_micros(2231));
        // cycle 2 is not due until its moved instant
        assert_eq!(g.due(o + Duration::from_micros(2230)), 0);
        assert_eq!(g.due(o + Duration::from_micros(2231)), 1);
        assert_eq!(g.due(o + Duration::from_micros(3231)), 2);
    }

    #[test]
    fn grid_waits_for_its_instants_and_spreads_a_catch_up() {
        let o = Instant::now() + Duration::from_millis(2);
        let mut g = Grid::new(o, 0.001);
        assert_eq!(g.wait(), o);
        assert!(Instant::now() >= o);
        g.advance();
        assert_eq!(g.wait(), g.at(1));
        assert!(Instant::now() >= g.at(1));
        // behind: the cycles are due at once, the wake-ups half a period apart
        std::thread::sleep(Duration::from_millis(5));
        g.advance();
        let w0 = Instant::now();
        g.wait();
        g.advance();
        g.wait();
        assert!(Instant::now() - w0 >= Duration::from_micros(500));
        assert!(g.due(Instant::now()) >= 2);
        // a later cycle: its instant, and the ones before are due then
        let n = g.next() + 10;
        assert_eq!(g.wait_for(n), g.at(n));
        assert!(Instant::now() >= g.at(n));
        assert!(g.due(Instant::now()) > n - g.next());
    }

    #[test]
    fn a_thread_s_cpu_time_counts_its_work_not_its_sleep() {
        let c0 = thread_cpu_time();
        let t0 = Instant::now();
        std::thread::sleep(Duration::from_millis(100));
        let slept = thread_cpu_time() - c0;
        // a sleep of 100 ms costs the thread its two switches, not 100 ms
        assert!(slept < Duration::from_millis(20), "{slept:?}");
        // spinning 50 ms of wall time: the thread ran for at least a
        // part of it (all of it unless the host took its CPU)
        let c1 = thread_cpu_time();
        let t1 = Instant::now();
        while t1.elapsed() < Duration::from_millis(50) {
            std::hint::spin_loop();
        }
        let spun = thread_cpu_time() - c1;
        assert!(spun > Duration::from_millis(5), "{spun:?}");
        assert!(spun <= t0.elapsed(), "{spun:?}");
    }

    #[test]
    fn the_margin_settles_at_its_share_of_the_sleeps_lateness() {
        // sleeps late by 0..199 µs, each as often, in a scrambled order
        // (a linear congruential sequence): the margin settles near the
        // 90th percentile (180 µs) or the 99th (198 µs), within a step
        let settle = |share: f64| {
            let mut m = 50_000.0;
            let mut x = 1u64;
            for _ in 0..2_000_000 {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let late_us = (x >> 33) % 200;
                m = next_margin(m, late_us as f64 * 1000.0, share, 1e9);
            }
            m / 1000.0
        };
        let m90 = settle(ON_TIME_SHARE);
        assert!((178.0..=182.0).contains(&m90), "{m90}");
        let m99 = settle(EARLY_ON_TIME_SHARE);
        assert!((196.0..=200.0).contains(&m99), "{m99}");
        // a grid that runs early with all of its margin takes 0.99; one
        // that spins a part of it (10 kHz: 25 µs early, up to 50 µs of
        // margin) and one that spins all of it keep 0.9
        let o = Instant::now();
        assert_eq!(
            Grid::new(o, 0.001).running_early().on_time,
            EARLY_ON_TIME_SHARE
        );
        assert_eq!(Grid::new(o, 0.0001).running_early().on_time, ON_TIME_SHARE);
        assert_eq!(Grid::new(o, 0.001).on_time, ON_TIME_SHARE);
        // within its bounds
        assert_eq!(next_margin(149_500.0, 1e6, 0.99, 150_000.0), 150_000.0);
        assert_eq!(next_margin(5.0, 0.0, 0.9, 150_000.0), 0.0);
    }

    #[test]
    fn grid_learns_its_sleeps_lateness_within_bounds() {
        let o = Instant::now();
        let mut g = Grid::new(o, 0.001);
        for _ in 0..200 {
            assert!(g.wait() <= Instant::now());
            g.advance();
            assert!(g.margin() <= MAX_SPIN);
        }
    }

    #[test]
    fn both_nodes_dds_threads_share_one_priority_below_their_loops() {
        use crate::ros::dds_priority;
        // the defaults: controller 80, simulator 70
        assert_eq!(dds_priority(80), 60);
        assert_eq!(dds_priority(70), 60);
        assert_eq!(dds_priority(99), 60);
        // a loop set lower keeps its DDS threads below it
        assert_eq!(dds_priority(50), 49);
        assert_eq!(dds_priority(0), 0);
    }

    #[test]
    fn a_grid_running_early_returns_within_its_margin_of_the_instant() {
        let o = Instant::now() + Duration::from_millis(1);
        // at most a quarter period early: at 10 kHz 25 µs (the rest of the
        // margin is spun), at 1 kHz the whole margin (at most 150 µs)
        let mut g = Grid::new(o, 0.0001).running_early();
        assert_eq!(g.early(), Duration::from_micros(25));
        for n in 0..100 {
            assert_eq!(g.wait(), g.at(n));
            assert!(Instant::now() + g.early() >= g.at(n));
            g.advance();
            // (the margin within half a period)
            assert!(g.margin() <= Duration::from_micros(50));
        }
        assert_eq!(Grid::new(o, 0.001).early(), Duration::ZERO);
        let mut g = Grid::new(o, 0.001).running_early();
        assert_eq!(g.early(), MAX_SPIN);
        // (it starts with a margin of 50 µs, all of it run early; a grid
        // that spins runs none of it early)
        assert_eq!(g.runs_early_by(), Duration::from_micros(50));
        assert_eq!(Grid::new(o, 0.001).runs_early_by(), Duration::ZERO);
        // woken before its instant, the cycle is not due yet by the clock:
        // the loop asks at the instant it woke for
        let at = g.at(0);
        assert_eq!(g.due(at - Duration::from_micros(20)), 0);
        assert_eq!(g.due(at), 1);
        for n in 0..100 {
            let margin = g.margin();
            assert_eq!(g.wait(), g.at(n));
            let now = Instant::now();
            // never before the sleep's end, the margin before the instant
            assert!(
                now + margin >= g.at(n),
                "cycle {n}: {:?} early",
                g.at(n) - now
            );
            assert!(g.due(now.max(g.at(n))) >= 1);
            g.advance();
            assert!(g.margin() <= MAX_SPIN);
        }
    }

    #[test]
    fn a_grid_without_spin_never_wakes_early_and_keeps_no_margin() {
        let o = Instant::now() + Duration::from_millis(1);
        let mut g = Grid::new(o, 0.001).without_spin();
        assert_eq!(g.margin(), Duration::ZERO);
        for n in 0..50 {
            assert_eq!(g.wait(), g.at(n));
            assert!(Instant::now() >= g.at(n));
            g.advance();
            assert_eq!(g.margin(), Duration::ZERO);
        }
    }

    #[test]
    fn wall_clock_stamps_an_instant_with_the_wall_clock_then() {
        let mut c = WallClock::new();
        c.update();
        let now = Instant::now();
        let a = c.stamp(now - Duration::from_millis(20)).as_secs_f64();
        let w = crate::ros::wall_stamp().as_secs_f64();
        assert!((w - a - 0.020).abs() < 0.005, "{}", w - a);
        // instants a period apart are stamped a period apart, to the ns
        let d = c.ns_at(now + Duration::from_micros(1000)) - c.ns_at(now);
        assert_eq!(d, 1_000_000);
    }

    /// A measurement that agrees with the offset (the offset within half
    /// its bracket) leaves it as it is, whatever its midpoint; one that
    /// does not moves it only as far as it must.
    #[test]
    fn the_clocks_offset_moves_only_when_a_measurement_proves_it_wrong() {
        // a 20 µs bracket whose midpoint is 9 µs off: kept, to the ns
        assert_eq!(consistent_offset(1_000_000, 1_009_000, 20_000), 1_000_000);
        assert_eq!(consistent_offset(1_000_000, 990_000, 20_000), 1_000_000);
        // a clock slewed 3 µs past a 1 µs bracket: moved 2.5 µs, to its edge
        assert_eq!(consistent_offset(1_000_000, 1_003_000, 1_000), 1_002_500);
        assert_eq!(consistent_offset(1_000_000, 997_000, 1_000), 997_500);
        // a stepped clock: moved by the step less half the bracket
        assert_eq!(consistent_offset(0, 5_000_000_000, 100), 4_999_999_950);
        // an odd bracket's half rounds up; an empty bracket is exact
        assert_eq!(consistent_offset(0, 10, 3), 8);
        assert_eq!(consistent_offset(0, 10, 0), 10);
    }

    /// `update` says how far it moved the offset: by a step of the system
    /// clock (here the offset made 1 ms off, as if the clock had been
    /// stepped back by 1 ms since), to within half a measurement's
    /// bracket; nothing when the offset agrees.
    #[test]
    fn an_update_says_how_far_the_system_clock_moved() {
        let mut c = WallClock::new();
        c.offset_ns += 1_000_000;
        // (a measurement interrupted for over 20 µs is skipped: a few tries)
        let moved = (0..100)
            .map(|_| c.update())
            .find(|m| *m != 0)
            .expect("no measurement within 20 µs in 100 tries");
        let half = WallClock::MAX_BRACKET.as_nanos() as i128 / 2 + 1;
        assert!(
            (moved + 1_000_000).abs() <= half,
            "moved {moved} ns, not -1 ms"
        );
        let again: i128 = (0..10).map(|_| c.update()).sum();
        assert!(again.abs() <= 2 * half, "{again} ns");
    }
}
