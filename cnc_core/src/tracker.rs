//! The spindle tracker that G33 and G95 follow: the measured spindle
//! angle predicted for the instant a setpoint is meant for, from a
//! weighted least-squares polynomial through the encoder's recent
//! readings.

/// How many of the most recent readings the tracker keeps: the whole
/// [`WINDOW_S`] up to 10 kHz (32 before G33 led by the setpoint delay: at
/// 10 kHz they spanned 3.2 ms, too short to predict the angle 3 ms ahead).
const HISTORY: usize = 256;
/// Degree of the polynomial fitted to the readings: a parabola follows
/// the speed ripple of a real spindle; a cubic (or a longer window) trades
/// that for more of the counts' quantization noise. Measured with the
/// simulated spindle at 200, 800 and 2000 rpm, steady and with ±2 %
/// ripple at 5 Hz, the thread starting at 8 phases of the ripple
/// (`cnc_node/tests/thread.rs`): the predicted angle stays within 0.32,
/// 0.27 and 0.39 counts of the true one on the steady spindle, and within
/// 0.66, 0.86 and 1.28 under the ripple (with [`weight`]; equal weights:
/// 0.32, 0.25, 0.32 and 0.62, 0.70, 1.05). A 16 ms window (equal
/// weights) got 0.95 counts at every speed but lost a steady spindle's
/// half count and the two counts behind 8 ms stalls of the readings
/// (`controller_thread.rs`); 12 ms was worse (1.12). A cubic through 48
/// ms with the same kind of weights gained at most 0.13 counts on any of
/// these figures and 64 m/s³ of jerk instead of 78, for twice the work.
const DEGREE: usize = 2;
/// The fit's coefficients: [`DEGREE`] + 1.
const TERMS: usize = DEGREE + 1;
/// The readings the tracker fits span at most this long, s, where the
/// oldest's weight is about 0.03 ([`weight`]).
const WINDOW_S: f64 = 0.024;
/// The oldest reading the fit takes (s before the newest): its weight
/// ramps down to 0 there, so a reading leaves the fit without a step.
/// (Leaving at [`WINDOW_S`], with 0.03, it stepped the fit by up to a
/// count when a gap of lost readings put the few old ones it leant on
/// near there: 725 m/s³ after 12 lost readings.)
const REACH_S: f64 = WINDOW_S + 1.0e-3;

/// How many ms the weights of the oldest and of the newest readings in the
/// tracker's window ramp over (see [`weight`]).
const TAPER_OLD_MS: f64 = 8.0;
const TAPER_NEW_MS: f64 = 3.0;

/// The weight of a reading `x` ms before the newest (x ≤ 0) in the
/// tracker's least-squares fit: 1 inside the window, ramping smoothly
/// (sin², zero slope at both ends) down towards the window's oldest end
/// and towards the newest reading (which gets 0.15, the one before it
/// 0.5). With equal weights each new reading entered the fit, and each old
/// one left it, at full weight, so the predicted angle jumped by a
/// fraction of a count every cycle: on `examples/lathe_thread.nc` (a 1.5
/// mm pitch at S800, the bundled 4096-count encoder) the lead's sampled
/// jerk was 368 m/s³ on the thread line, over the bundled lathe's 200.
/// With these weights it is 78 m/s³ at most, 51 m/s³ of it the tracker's
/// angle and the rest its acceleration (the lead for the servo's lag
/// under acceleration, `thread_accel_lead`). The price is the rippling
/// spindle's worst above (1.28 counts where it was 1.05, 0.11° at 4096
/// counts): a longer ramp at the new end smooths more and predicts a
/// rippling spindle worse still (4 ms: 70 m/s³ and 1.37 counts).
fn weight(x: f64, x_new: f64) -> f64 {
    let ramp = |r: f64| {
        let s = (core::f64::consts::FRAC_PI_2 * r.clamp(0.0, 1.0)).sin();
        s * s
    };
    let window = WINDOW_S * 1000.0;
    ramp((x + window + 1.0) / (TAPER_OLD_MS + 1.0)) * ramp((1.0 - x_new) / (TAPER_NEW_MS + 1.0))
}

/// A spindle encoder's count may move at most this many times the
/// spindle's top speed (`spindle.max_rpm`) between two readings, plus two
/// counts; more is an encoder fault ([`SpindleTracker::implausible`]).
pub const IMPLAUSIBLE_SPEED: f64 = 1.5;

/// At most this long after the newest reading (s) do the fit's weights
/// count back from ([`SpindleTracker::origin`]): the newest end's ramp
/// and a millisecond, beyond which every reading present weighs fully.
const MISSING_MOST: f64 = (TAPER_NEW_MS + 1.0) * 1.0e-3;
/// A reading up to this share of a reading period older than a cycle
/// counts as that cycle's newest ([`SpindleTracker::origin`]): stamps
/// may jitter by that much.
const STAMP_TOLERANCE: f64 = 0.05;
/// At most this many readings lost in a row are filled in
/// ([`SpindleTracker::fill_in`]): as many as the fit's window spans at 1
/// kHz (a gap any longer leaves no measured reading in it but its two
/// ends), and at the default encoder timeout of 25 ms every gap that does
/// not stop the job. Up to 8, more than 16 lost left the fits after the
/// gap thin and the lead of a 1.5 mm thread at 4096 counts over the
/// bundled lathe's 200 m/s³: 271 m/s³ after 20 lost on a steady spindle,
/// 349 on one rippling ±2 % (`lost_readings_scan`); filled in, 134 and
/// 270.
const FILL_MOST: usize = 24;

/// `b − a` counts, exact for any two i64 counts (no overflow).
fn counts_between(a: i64, b: i64) -> f64 {
    (i128::from(b) - i128::from(a)) as f64
}

/// One reading of the spindle encoder, in the executor's time base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderReading {
    /// when it was measured, s since the job started (the executor's t)
    pub t: f64,
    /// accumulated counts, signed
    pub count: i64,
    pub counts_per_rev: u32,
    /// index pulses seen (0: none yet)
    pub index_count: i64,
    /// the count at the last index pulse
    pub count_at_index: i64,
}

/// The spindle's predicted motion at an instant, in encoder counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Predicted {
    /// angle, counts (the centre of the count)
    pub counts: f64,
    /// speed, counts/s
    pub per_s: f64,
    /// acceleration, counts/s²
    pub per_s2: f64,
}

/// A fitted parabola: counts ≈ count₀ + 0.5 + Σ cᵢ xⁱ, x = (t − t₀) in ms.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fit {
    t0: f64,
    count0: i64,
    c: [f64; TERMS],
}

impl Fit {
    /// The angle (counts), its slope (counts/ms) and curvature
    /// (counts/ms²) at `t`.
    fn at(&self, t: f64) -> [f64; 3] {
        let x = (t - self.t0) * 1000.0;
        // the polynomial and its first two derivatives at x (Horner)
        let (mut f, mut f1, mut f2) = (0.0, 0.0, 0.0);
        for &ci in self.c.iter().rev() {
            f2 = f2 * x + 2.0 * f1;
            f1 = f1 * x + f;
            f = f * x + ci;
        }
        [self.count0 as f64 + 0.5 + f, f1, f2]
    }
}

/// How long a step between two fits is eased over, ms ([`Blend`]): a step
/// of a count (0.37 µm of a 1.5 mm lead at 4096 counts) eased over 8 ms
/// has a jerk of at most 60·0.37 µm / (8 ms)³ = 43 m/s³. Every ms of
/// ease keeps the old fit's prediction longer: with readings up to 8
/// cycles late now and then, the lead error's spread widens by up to 0.6
/// counts (`cnc_node/tests/encoder_timing.rs`); eased over 4 ms, the
/// jerk reached 281 m/s³ there.
const BLEND_MS: f64 = 8.0;
/// The most jerk an ease of a step between two fits gives the predicted
/// angle, counts/ms³: a step of 1.5 counts over [`BLEND_MS`] (64 m/s³ on
/// a 1.5 mm lead at 4096 counts); a larger step, or a larger difference
/// of the slopes, is eased over longer ([`Blend::new`]). Before, every
/// step was eased over [`BLEND_MS`] and [`BLEND_RATE_GAP_MS`], and a new
/// fit after 20 ms without a reading took over at once: that lead's Z
/// went to 1.6 km/s³ after readings held up 20 ms
/// (`cnc_node/tests/controller_thread.rs`), and to 0.2–13 km/s³ after 16
/// to 20 readings lost (`cnc_node/tests/encoder_timing.rs`,
/// `lost_readings_scan`). With a count over 8 ms the losses gave less
/// still, but readings held up 8 ms widened the lead's spread (1.68 →
/// 1.99 counts at S2000); with 2 counts, more of the jerk was left.
const EASE_JERK: f64 = 1.5 * 60.0 / (BLEND_MS * BLEND_MS * BLEND_MS);
/// How long the two fits' slopes' and curvatures' difference is eased
/// over, ms: the old fit's slope carried on moves its prediction away
/// from the new fit's as it goes (by the difference times the time), so
/// it goes sooner (the spread of a thread with readings 8 cycles late:
/// 3.05 counts at S200, 3.11 with 8 ms); 3 ms stepped the lead after
/// readings lost for 16 cycles (306 m/s³).
const BLEND_RATE_MS: f64 = 5.0;
/// [`BLEND_RATE_MS`] for a new fit whose window, or the one before it,
/// is thin from lost readings ([`SpindleTracker::thin_window`]): the fit
/// extrapolated across the gap and the one after it differ in slope by
/// more than late readings make them, and eased over 5 ms that difference
/// alone put up to 320 m/s³ on the lead of a 1.5 mm thread at 4096 counts
/// (16 readings lost at S800 and S2000); over 8 ms it stays under the
/// thread's own. Late readings (which arrive, so the window is not thin)
/// keep the shorter ease, which holds the lead closer (2.32 counts of
/// spread at S200 with 8 ms stalls, 2.51 eased over 8 ms).
const BLEND_RATE_GAP_MS: f64 = 8.0;
/// The cycles over which the transport's usual lateness is learned.
const LATENESS_CYCLES: usize = 64;
/// The share of each on-time cycle's move that the tracker's average of
/// them (`usual_move`) takes on: about the last four cycles.
///
/// On a rippling spindle the fits lag its acceleration, so each on-time
/// cycle's new fit moves the prediction by about the same amount as the
/// one before (a third of a count a cycle at S2000 under ±2 % at 5 Hz).
/// Where a cycle's fit is made anew after a late reading (not at the end
/// of a hold, which goes on by the last move already), the old fit's
/// course it eases from lacked that move: the lead's speed stepped by
/// about a third of a count in one cycle and the ease gave it back over
/// 8 ms. Two cycles late in a row every 23 to 53 cycles put a 1.5 mm
/// thread's Z at 301.9 m/s³ at S2000
/// (`two_late_cycles_in_a_row_on_a_rippling_spindle`), readings late at
/// random at 256–283 (`jittery_readings_scan`). That fit's old course
/// now goes on by [`USUAL_MOVE_SHARE`] of the average: 202.2 and 203–217.
/// The last move alone (not averaged) is the counts' noise at S200 and
/// stepped the lead there instead (176 → 224 m/s³); the whole average
/// gave the pairs 192.3 but one S800 run at random 201.5 near the
/// thread's start (BENCHMARKS.md, "Where S2000's late readings still go
/// over").
const MOVE_AVERAGE: f64 = 0.25;
/// The share of the usual move a fit made anew after a late reading goes
/// on by ([`MOVE_AVERAGE`]).
const USUAL_MOVE_SHARE: f64 = 0.75;
/// At most this many steps are being eased at once.
const BLENDS: usize = 16;

/// A step between the fit a cycle used and the next one's, eased out: the
/// prediction goes on from the old fit's (its angle, slope and curvature
/// at the step, as a parabola `e` in ms after `start`) and moves to the
/// new fit's over [`BLEND_MS`] (a quintic smoothstep, zero slope and
/// curvature at both ends); the part the two fits' slopes and curvatures
/// differ by, over [`BLEND_RATE_MS`]; a larger step over longer
/// ([`Blend::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Blend {
    /// the cycle it starts at, s
    start: f64,
    e: [f64; 3],
    /// how long the angles' difference is eased over, ms
    over_ms: f64,
    /// how long the slopes' and curvatures' difference is eased over, ms
    rate_ms: f64,
}

impl Blend {
    /// The ease of the step `e` from `start`, over [`BLEND_MS`] and
    /// `rate_ms` at the least, and longer for a step whose ease would
    /// otherwise have more jerk than [`EASE_JERK`]: a quintic
    /// smoothstep's third derivative peaks at 60·e/T³ for the angle's part
    /// and at about 60·e'/T² for the slope's (e' times the time, eased).
    fn new(start: f64, e: [f64; 3], rate_ms: f64) -> Blend {
        Blend {
            start,
            e,
            over_ms: BLEND_MS.max((60.0 * e[0].abs() / EASE_JERK).cbrt()),
            rate_ms: rate_ms.max((60.0 * e[1].abs() / EASE_JERK).sqrt()),
        }
    }

    /// Takes on the step `e` of a cycle `now` (at or after its start) too:
    /// the parabola `e` shifted to this ease's start, so that the two
    /// ease out together.
    fn absorb(&mut self, now: f64, e: [f64; 3]) {
        let d = ((now - self.start) * 1000.0).max(0.0);
        self.e[0] += e[0] - e[1] * d + 0.5 * e[2] * d * d;
        self.e[1] += e[1] - e[2] * d;
        self.e[2] += e[2];
    }

    /// The offset (counts, counts/ms, counts/ms²) at the cycle `now`;
    /// None once it has run out. Each of the three is eased out on its
    /// own: the ease's own slope and curvature are left out of the speed
    /// and acceleration, which the lead for the servo's lag under
    /// acceleration multiplies (a fraction of a count eased over 8 ms has
    /// a curvature of thousands of counts/s², which no spindle has).
    fn at(&self, now: f64) -> Option<[f64; 3]> {
        let tau = (now - self.start) * 1000.0;
        if !(0.0..self.over_ms.max(self.rate_ms)).contains(&tau) {
            return None;
        }
        // the quintic smoothstep down from 1 to 0 over `over` ms
        let ease = |over: f64| {
            let u = (tau / over).min(1.0);
            1.0 - u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
        };
        let (g, h) = (ease(self.over_ms), ease(self.rate_ms));
        let [e0, e1, e2] = self.e;
        Some([
            g * e0 + h * (e1 * tau + 0.5 * e2 * tau * tau),
            h * (e1 + e2 * tau),
            h * e2,
        ])
    }
}

/// Follows the measured spindle: a weighted least-squares parabola
/// ([`weight`]) through the readings of the last [`WINDOW_S`] predicts
/// the angle at the instant a setpoint is meant for. A count stands for
/// the interval `[count, count + 1)` of the angle, so its centre is used.
#[derive(Clone, Debug)]
pub struct SpindleTracker {
    ring: [(f64, i64); HISTORY],
    /// The fraction of a count a reading the tracker filled in for a lost
    /// one has beyond its count ([`SpindleTracker::fill_in`]); 0.0 for a
    /// measured one.
    frac: [f64; HISTORY],
    /// The newest reading after more readings were filled in than a fit
    /// is held for ([`MISSING_MOST`]; −∞: none).
    filled_at: f64,
    head: usize,
    len: usize,
    pub last: Option<EncoderReading>,
    /// The cycle the last prediction was for, and its fit: a second
    /// prediction for the same cycle uses them again.
    cycle: f64,
    current: Option<Fit>,
    /// The cycle of the last fit made (not held), and the time of the
    /// newest reading then.
    fitted_at: f64,
    newest_then: f64,
    /// How many readings the last cycle's fit missed beyond the usual
    /// lateness.
    excess: i32,
    /// Whether the last fit's window had readings lost in it.
    gap: bool,
    /// How far the last new fit of an on-time cycle moved the prediction
    /// for its cycle from the fit before it, counts; what a held fit adds
    /// to its prediction; how many cycles in a row up to the last have
    /// held their fit (0: the last made a new one)
    /// ([`SpindleTracker::next_cycle`]).
    last_move: f64,
    /// The on-time cycles' moves, averaged ([`MOVE_AVERAGE`]) and kept
    /// through late cycles.
    usual_move: f64,
    hold_offset: f64,
    held_cycles: u32,
    /// How many readings each of the last cycles missed (a ring).
    lateness: [u8; LATENESS_CYCLES],
    lateness_at: usize,
    lateness_n: usize,
    /// Steps between fits being eased out ([`Blend`]).
    blends: [Option<Blend>; BLENDS],
}

impl Default for SpindleTracker {
    fn default() -> Self {
        SpindleTracker {
            ring: [(0.0, 0); HISTORY],
            frac: [0.0; HISTORY],
            filled_at: f64::NEG_INFINITY,
            head: 0,
            len: 0,
            last: None,
            cycle: f64::NEG_INFINITY,
            current: None,
            fitted_at: f64::NEG_INFINITY,
            newest_then: f64::NEG_INFINITY,
            excess: 0,
            gap: false,
            last_move: 0.0,
            usual_move: 0.0,
            hold_offset: 0.0,
            held_cycles: 0,
            lateness: [0; LATENESS_CYCLES],
            lateness_at: 0,
            lateness_n: 0,
            blends: [None; BLENDS],
        }
    }
}

impl SpindleTracker {
    /// Takes a reading (older or equal times than the last are ignored).
    pub fn push(&mut self, r: EncoderReading) {
        if !r.t.is_finite() || r.counts_per_rev == 0 {
            return;
        }
        if let Some(l) = self.last {
            if r.t <= l.t {
                return;
            }
            self.fill_in(&l, &r);
        }
        self.put(r.t, r.count, 0.0);
        self.last = Some(r);
    }

    /// Fills in the readings lost between `l` and `r` (at most
    /// [`FILL_MOST`], on the readings' grid): on the parabola from the one
    /// to the other with the current fit's curvature.
    fn fill_in(&mut self, l: &EncoderReading, r: &EncoderReading) {
        let Some(p) = self.period() else {
            return;
        };
        let periods = (r.t - l.t) / p;
        let n = periods.round();
        if !(2.0..=(FILL_MOST + 1) as f64).contains(&n) || (periods - n).abs() > STAMP_TOLERANCE {
            return;
        }
        let d = counts_between(l.count, r.count);
        let curv = self.current.map_or(0.0, |f| f.c[2]);
        let span = (r.t - l.t) * 1000.0;
        // (all of them or none: a count out of an i64's range, near ±2⁶³,
        // leaves the gap as lost)
        let mut fills = [(0.0, 0, 0.0); FILL_MOST];
        for (i, slot) in (1..n as usize).zip(fills.iter_mut()) {
            let f = i as f64 / n;
            let x = f * span;
            let y = d * f + curv * x * (x - span);
            let whole = y.floor();
            let Ok(c) = i64::try_from(i128::from(l.count) + whole as i128) else {
                return;
            };
            *slot = (l.t + f * (r.t - l.t), c, y - whole);
        }
        for &(t, c, frac) in &fills[..n as usize - 1] {
            self.put(t, c, frac);
        }
        // (more lost than the cycles a fit is held for: the fits in between
        // weighed them as missing, and the fits after are eased in while
        // the filled-in readings are in the window)
        if (n - 1.0) * p > MISSING_MOST * (1.0 + STAMP_TOLERANCE) {
            self.filled_at = r.t;
        }
    }

    /// Adds a reading to the ring (`frac`: see [`SpindleTracker::frac`]).
    fn put(&mut self, t: f64, count: i64, frac: f64) {
        self.head = (self.head + 1) % HISTORY;
        self.ring[self.head] = (t, count);
        self.frac[self.head] = frac;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// The fraction of a count a filled-in reading `k` readings before the
    /// newest has beyond its count (0 for a measured one).
    fn frac_at(&self, k: usize) -> f64 {
        self.frac[(self.head + HISTORY - k) % HISTORY]
    }

    /// Why `r`, after the last reading, is one no encoder on a spindle of
    /// at most `max_rps` rev/s can give (None: it can, or it is not newer
    /// and [`push`](Self::push) ignores it): its counts per revolution
    /// changed, or its count moved more than [`IMPLAUSIBLE_SPEED`] times
    /// that speed allows, plus two counts.
    pub fn implausible(&self, r: &EncoderReading, max_rps: f64) -> Option<String> {
        let l = self.last.filter(|l| r.t > l.t)?;
        if r.counts_per_rev != l.counts_per_rev {
            return Some(format!(
                "spindle encoder fault: its counts per revolution changed from {} to {}",
                l.counts_per_rev, r.counts_per_rev
            ));
        }
        let jump = counts_between(l.count, r.count);
        let most = IMPLAUSIBLE_SPEED * max_rps * f64::from(l.counts_per_rev) * (r.t - l.t) + 2.0;
        (jump.abs() > most).then(|| {
            format!(
                "spindle encoder fault: its count jumped by {jump:.0} in {:.1} ms, \
                 faster than the spindle can turn",
                (r.t - l.t) * 1000.0
            )
        })
    }

    /// The cycle (executor time, s) the last prediction was for: −∞ before
    /// the first.
    pub fn followed_at(&self) -> f64 {
        self.cycle
    }

    /// Counts per revolution of the encoder (0 before the first reading).
    pub fn cpr(&self) -> f64 {
        self.last.map_or(0.0, |l| f64::from(l.counts_per_rev))
    }

    /// The reading `k` readings before the newest: (t, count).
    fn at(&self, k: usize) -> (f64, i64) {
        self.ring[(self.head + HISTORY - k) % HISTORY]
    }

    /// The reading period: the shortest spacing of the newest readings, s.
    fn period(&self) -> Option<f64> {
        (1..self.len.min(9))
            .map(|k| self.at(k - 1).0 - self.at(k).0)
            .filter(|d| *d > 0.0)
            .min_by(f64::total_cmp)
    }

    /// What the fit for the cycle at `now` counts from: the newest reading
    /// measured before that cycle (`k` readings before the newest there,
    /// so readings measured after it, which a control loop that runs late
    /// and catches up finds already there, are left out), how many
    /// readings measured before the cycle have not come (late ones), and
    /// the reading period (s; 0 while there are too few readings to tell).
    ///
    /// A reading up to [`STAMP_TOLERANCE`] of a period older than a cycle
    /// counts as that cycle's newest; one measured in the last
    /// [`STAMP_TOLERANCE`] before it as not yet there.
    fn origin(&self, now: f64) -> (usize, u8, f64) {
        let Some(p) = self.period() else {
            return (0, 0, 0.0);
        };
        let before = now - STAMP_TOLERANCE * p;
        let Some(k) = (0..self.len).find(|&k| self.at(k).0 < before) else {
            return (0, 0, p);
        };
        // whole periods from that reading to the newest before `now`
        let n = ((now - self.at(k).0) / p - STAMP_TOLERANCE).ceil() - 1.0;
        if !n.is_finite() || n <= 0.0 {
            return (k, 0, p);
        }
        (k, n.min(f64::from(u8::MAX)) as u8, p)
    }

    /// Whether readings are lost in the fit's window (from the reading `k0`
    /// before the newest back, where the fit found `there`): fewer there
    /// than its span holds at the period `p`, with older readings beyond
    /// it. Such a fit leans on a few readings, and each new one, or each
    /// old one that leaves, moves it by more than usual.
    fn thin_window(&self, k0: usize, there: usize, p: f64) -> bool {
        // (a window still filling, at the first readings, is not thin)
        k0 + there < self.len && (there as f64) < (REACH_S / p).floor()
    }

    /// How many readings the last [`LATENESS_CYCLES`] cycles missed at the
    /// least: the transport's steady lateness, which the weights count
    /// back from as if it were none.
    fn usual_lateness(&self) -> u8 {
        self.lateness[..self.lateness_n]
            .iter()
            .copied()
            .min()
            .unwrap_or(0)
    }

    /// Coefficients (c0 … c_DEGREE) of count − count₀ ≈ Σ cᵢ τⁱ, τ = t −
    /// t₀ in ms (well scaled for the normal equations), where (t₀, count₀)
    /// is the reading `k0` readings before the newest; each reading from
    /// there back weighted by its age ([`weight`]), the newest end's ramp
    /// counted from `missing` ms after t₀; and how many readings it took.
    fn fit(&self, k0: usize, missing: f64) -> ([f64; TERMS], usize) {
        let (t1, c1) = self.at(k0);
        let h1 = self.frac_at(k0);
        let mut a = nalgebra::SMatrix::<f64, TERMS, TERMS>::zeros();
        let mut b = nalgebra::SVector::<f64, TERMS>::zeros();
        let mut n: usize = 0;
        for k in k0..self.len {
            let (t, c) = self.at(k);
            let tau = t - t1;
            if tau < -REACH_S {
                break;
            }
            let x = tau * 1000.0;
            let y = counts_between(c1, c) + (self.frac_at(k) - h1);
            let w = weight(x, x - missing);
            let mut p = [1.0; TERMS];
            for i in 1..TERMS {
                p[i] = p[i - 1] * x;
            }
            for r in 0..TERMS {
                for q in 0..TERMS {
                    a[(r, q)] += w * p[r] * p[q];
                }
                b[r] += w * p[r] * y;
            }
            n += 1;
        }
        // the full degree (a lower one while there are few readings)
        let d = DEGREE.min(n.saturating_sub(2));
        for deg in (0..=d).rev() {
            let m = deg + 1;
            let sub = a.view((0, 0), (m, m)).clone_owned();
            let rhs = b.rows(0, m).clone_owned();
            if let Some(x) = sub.lu().solve(&rhs) {
                if x.iter().all(|v| v.is_finite()) {
                    let mut out = [0.0; TERMS];
                    out[..m].copy_from_slice(x.as_slice());
                    // (relative to the count of the reading at k0)
                    out[0] += h1;
                    return (out, n);
                }
            }
        }
        let mut out = [0.0; TERMS];
        out[0] = h1;
        (out, n)
    }

    /// The predicted angle at time `t`, in counts (the centre of the
    /// count), and the speed then, counts per second: one fit for both,
    /// by the cycle at `now` (the executor's time).
    pub fn predict(&mut self, t: f64, now: f64) -> Option<(f64, f64)> {
        self.predict_motion(t, now).map(|p| (p.counts, p.per_s))
    }

    /// [`predict`](Self::predict) with the acceleration too (the fitted
    /// parabola's, constant over the window).
    ///
    /// When the readings come decides nothing but which readings there
    /// are, so that a late one does not step the lead (over DDS, readings
    /// a few ms late had put single-cycle steps of about a count on it, up
    /// to 1 km/s³ of sampled jerk on a 1.5 mm lead):
    ///
    /// - the fit leaves out readings measured after the cycle
    ///   ([`origin`](Self::origin)): a loop that runs late predicts what an
    ///   on-time one does, bit for bit;
    /// - the transport's usual lateness (the fewest readings missing in the
    ///   last [`LATENESS_CYCLES`] cycles) counts as none: with readings a
    ///   cycle late all the time, each cycle fits them as on time;
    /// - beyond it, a cycle that finds no new reading keeps the last fit
    ///   (for at most [`MISSING_MOST`]; its first cycle going on by the
    ///   move the last on-time fit made), and a fit with readings missing
    ///   weighs them as missing ([`weight`] counts from where the newest
    ///   should be, so the readings there keep their weights; at most
    ///   [`MISSING_MOST`] is counted missing, beyond it every reading
    ///   there weighs fully);
    /// - up to [`FILL_MOST`] readings lost in a row are filled in when the
    ///   next one comes ([`fill_in`](Self::fill_in)): with one lost reading
    ///   the window lacked, each new fit on a 1.5 mm lead at S2000 moved
    ///   the lead enough for 226 m/s³;
    /// - and a new fit while readings are missing, or right after, or while
    ///   lost readings leave the window thin ([`thin_window`](Self::thin_window))
    ///   or more filled-in ones than a fit is held for are in it,
    ///   does not step the prediction: the old fit's goes on and eases
    ///   into it ([`Blend`]), over longer for a larger step: after
    ///   readings held up or lost for 20 ms too, where the new fit once
    ///   took over at once and stepped a 1.5 mm thread's Z by 1.6 km/s³.
    ///
    /// A second prediction for the same cycle uses the same fit.
    pub fn predict_motion(&mut self, t: f64, now: f64) -> Option<Predicted> {
        self.last?;
        if now != self.cycle || self.current.is_none() {
            self.next_cycle(t, now);
        }
        let base = self.current?;
        let mut p = base.at(t);
        p[0] += self.hold_offset;
        for b in self.blends.iter().flatten() {
            if let Some(o) = b.at(now) {
                for (v, o) in p.iter_mut().zip(o) {
                    *v += o;
                }
            }
        }
        Some(Predicted {
            counts: p[0],
            per_s: p[1] * 1000.0,
            per_s2: p[2] * 1.0e6,
        })
    }

    /// The fit for a new cycle at `now` (see [`predict_motion`](Self::predict_motion)).
    fn next_cycle(&mut self, t: f64, now: f64) {
        let (k0, missed, p) = self.origin(now);
        self.lateness[self.lateness_at] = missed;
        self.lateness_at = (self.lateness_at + 1) % LATENESS_CYCLES;
        self.lateness_n = (self.lateness_n + 1).min(LATENESS_CYCLES);
        // readings missing beyond the usual (fewer: newer ones, left out)
        let excess = i32::from(missed) - i32::from(self.usual_lateness());
        let missing = (f64::from(excess) * p).min(MISSING_MOST) * 1000.0;
        // (the fit of the cycle before: a prediction resumed after a pause,
        // say the next pass of a thread, starts afresh)
        let prev = self.current.filter(|_| now - self.cycle < 1.5 * p);
        let (newest, count0) = self.at(k0);
        let hold =
            prev.is_some() && newest == self.newest_then && now - self.fitted_at <= MISSING_MOST;
        let mut gap = self.gap;
        // (whether the last cycle held its fit)
        let held = self.held_cycles > 0;
        if !hold {
            let (c, there) = self.fit(k0, missing);
            let fit = Fit {
                t0: newest,
                count0,
                c,
            };
            gap = self.thin_window(k0, there, p) || newest - self.filled_at <= REACH_S;
            // (a hold of one cycle ends: the old fit goes on by this
            // cycle's move too, as the hold's own cycle did)
            if self.held_cycles == 1 {
                self.hold_offset += self.last_move;
            }
            // (in a run of on-time cycles: how far the new fit moved the
            // prediction, which the next one moves it by much alike)
            let on_time = !(held || excess != 0 || self.excess != 0 || gap || self.gap);
            match prev {
                Some(old) if on_time => {
                    self.last_move = fit.at(t)[0] - old.at(t)[0];
                    self.usual_move += (self.last_move - self.usual_move) * MOVE_AVERAGE;
                }
                Some(_) => self.last_move = 0.0,
                None => (self.last_move, self.usual_move) = (0.0, 0.0),
            }
            if let (Some(old), true) = (
                prev,
                held || excess > 0 || excess != self.excess || gap || self.gap,
            ) {
                // (a fit made anew, not at the end of a hold, where at most
                // one reading is missing now and was in the cycle before:
                // the old fit goes on by most of the usual move, as an
                // on-time fit would have moved it; see MOVE_AVERAGE)
                if self.held_cycles == 0 && excess <= 1 && self.excess <= 1 && !(gap || self.gap) {
                    self.hold_offset += USUAL_MOVE_SHARE * self.usual_move;
                }
                // the old fit's prediction goes on and eases into the new
                let (a, b) = (old.at(t), fit.at(t));
                let e = [a[0] + self.hold_offset - b[0], a[1] - b[1], a[2] - b[2]];
                for slot in self.blends.iter_mut() {
                    if slot.is_some_and(|b| b.at(now).is_none()) {
                        *slot = None;
                    }
                }
                let rate_ms = if gap || self.gap {
                    BLEND_RATE_GAP_MS
                } else {
                    BLEND_RATE_MS
                };
                if let Some(slot) = self.blends.iter_mut().find(|b| b.is_none()) {
                    *slot = Some(Blend::new(now, e, rate_ms));
                } else if let Some(young) = self
                    .blends
                    .iter_mut()
                    .flatten()
                    .max_by(|a, b| a.start.total_cmp(&b.start))
                {
                    // (every slot busy, which no scan of late or lost
                    // readings has reached: at most 10 of them were; the
                    // step joins the youngest ease rather than going
                    // uneased)
                    young.absorb(now, e);
                }
            }
            self.current = Some(fit);
            self.fitted_at = now;
            self.newest_then = newest;
            self.hold_offset = 0.0;
            self.held_cycles = 0;
        } else {
            // a fit held for a missing reading lacks the move the cycle's
            // new fit would have made (up to half a count; on-time fits
            // move the prediction much as the one before did): its first
            // cycle goes on by the last move (more held cycles go on
            // without: the moves' errors would add up)
            if self.held_cycles == 0 {
                self.hold_offset = self.last_move;
            }
            self.held_cycles += 1;
        }
        self.excess = excess;
        self.gap = gap;
        self.cycle = now;
    }
}

#[cfg(test)]
mod tests;
