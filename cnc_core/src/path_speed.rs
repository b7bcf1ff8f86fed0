//! Jerk-limited speed along a smooth path, one sample at a time.
//!
//! This is the speed stage of the path planner (`crate::path_run`, a
//! machine's `[planner] method = "path"`; `bench/motion/g2_bound.py`
//! prototypes it with linear programs, and the bench binary
//! `cnc_core/examples/path_plan.rs` runs it on the prototype's geometry).
//!
//! The path is given at stations a fixed arc length apart: the unit tangent
//! `T`, its derivative along the path `K = dT/ds` (the curvature vector) and
//! that one's derivative `K' = dK/ds`, and the programmed feed. Between
//! stations they are interpolated linearly. For a path speed `v = ds/dt`,
//! acceleration `a` and jerk `σ`, every axis moves with
//!
//! ```text
//! velocity      T v
//! acceleration  T a + K v²
//! jerk          T σ + 3 K v a + K' v³
//! ```
//!
//! and each of these stays within that axis's limit at every sample.
//!
//! **How the speed is chosen.** The state is `(s, v, a)`; each sample holds
//! one jerk `σ` for `dt`. A state is *viable* when braking from it, by a
//! fixed rule (`brake`: the acceleration down to the lowest the axes allow
//! as fast as the jerk allows, then a landing that brings speed and
//! acceleration to zero on the same sample), keeps every limit and comes to
//! rest before the run's end. Each sample takes the largest jerk whose next
//! state is viable (bisection between the braking rule's jerk, which is
//! always viable from a viable state, and the largest the axes allow, or
//! than the approach onto the speed cap ahead allows: `approach.rs`). So
//! the run never meets a state it cannot leave within the limits, and it
//! brakes only as late as it must: on a curve the speed is what the axes'
//! acceleration and jerk leave, on a line what the feed allows; it comes
//! up to a cap as the acceleration comes down to zero, and stays there.
//!
//! Each station's speed cap is the feed, every axis's velocity over its
//! share of the tangent, and the speed at which the curvature alone takes
//! an axis's whole acceleration (or a machine's normal acceleration for
//! its drives' contour error: `caps.rs`); a sample keeps the caps of
//! every station it passes, so a curvature peak between two samples is
//! kept too.
//! Likewise the jerk is bounded with every `K'` of the stations a sample
//! may pass (`envelope.rs`): a blend's curvature ramp passed in two
//! samples has its peak change of curvature between them.
//!
//! The run ends at rest exactly on the path's end: the little it stops
//! short (under 0.1 µm) is added over the last braking by a smooth step.
//!
//! **As the path comes.** The stations may be given all at once
//! (`Path::new`) or one by one (`push`, then `finish` with the run's end);
//! `next_sample` decides a sample only once every braking it tries stays
//! within the stations given, so the samples are those of the whole run
//! bit for bit, and it forgets the stations behind. Samples come
//! `STRETCH_MIN` behind the planning: the end's smooth step may move them.
//!
//! **What it costs.** About two braking simulations a sample (on
//! bench/motion's CAM program at 50 m/s³: 0.8 that succeed, about 85
//! samples long, and 1.0 that fail, after about 25); most samples need
//! one: the approach's jerk, viable. Two things cut it without
//! changing a bit of the result: on a straight stretch with no lower cap
//! ahead, a braking that certainly ends within it is not simulated
//! (`clearly_viable`), and the last few bounds are remembered by their
//! state's bits.

/// The point at a path position, for the samples' own check.
pub type Point<'a> = &'a dyn Fn(f64) -> [f64; 3];

/// Lower jerks tried where the planner's does not keep the samples' own
/// check (`check_samples`): these shares of the way down to the braking
/// rule's.
const SAMPLED_TRIES: [f64; 10] = [
    0.004, 0.016, 0.031, 0.063, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0,
];

/// Per-axis limits (X, Y, Z): velocity mm/s, acceleration mm/s², jerk mm/s³.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLimits {
    pub v: [f64; 3],
    pub a: [f64; 3],
    pub j: [f64; 3],
}

mod approach;
mod envelope;
use envelope::Range;
mod path;
pub use path::{Path, SpeedError, Station};
use std::collections::VecDeque;

/// A run's start: at rest at its first point.
const AT_REST: State = State {
    s: 0.0,
    v: 0.0,
    a: 0.0,
};

/// Where along the path, how fast, how hard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    pub s: f64,
    pub v: f64,
    pub a: f64,
}

impl State {
    /// One sample with jerk `sig` held.
    fn step(self, sig: f64, dt: f64) -> State {
        State {
            s: self.s + self.v * dt + self.a * dt * dt / 2.0 + sig * dt * dt * dt / 6.0,
            v: self.v + self.a * dt + sig * dt * dt / 2.0,
            a: self.a + sig * dt,
        }
    }
}

/// Speed under this counts as rest, mm/s.
const REST_V: f64 = 1e-9;
/// A run that comes to rest this close to its end has reached it, mm.
const END_TOL: f64 = 1e-4;
/// How many `bounds_at` answers are remembered.
const MEMO: usize = 4;
/// The samples the last shortfall is spread over, and so how many the
/// planner holds back.
const STRETCH_MIN: usize = 50;
/// The share of each axis's jerk the path acceleration may take up
/// through the curvature (`3 K v a`); the rest is for changing it.
const JERK_FOR_A: f64 = 0.9;
/// The share of the jerk a landing is planned with (the rest absorbs how
/// the axes' jerk bounds move as the speed falls), and the share whose
/// landing decides when to start one (less, so that one always fits).
const LAND_SHARE: f64 = 0.9;
const TRIGGER_SHARE: f64 = 0.8;
/// How many landings longer than the shortest conceivable are tried.
const LAND_MAX: usize = 40;
/// How far above the lowest acceleration allowed braking aims, as a share
/// of it (the bound moves as the path turns and the speed falls).
const A_MARGIN: f64 = 1e-3;
/// Bisection steps for the largest viable jerk, at most; it stops once the
/// bracket is `TOL` of the jerk's range wide (a hundredth: each sample's
/// jerk within about 1 % of the limit of the largest viable, which costs
/// the cycle time nothing measurable and the planner a quarter of its
/// probes, each a braking simulated to rest).
const BISECT: usize = 24;
const TOL: f64 = 1e-2;
/// The first bracket about the last sample's jerk, as a share of its range.
const WARM: f64 = 0.01;
/// How far a braking simulation may go, in samples.
const MAX_BRAKE: usize = 20_000;

/// The speed stage for one run under one set of limits: it owns the run's
/// path, which may still be growing (`push`, `finish`), and gives one
/// sample at a time (`next`).
pub struct Planner {
    path: Path,
    lim: AxisLimits,
    dt: f64,
    /// Each kept station's speed cap but the feed's (`hard_cap`), and its
    /// feed: the cap is the lower of it and the feed times the override.
    caps: VecDeque<(f64, f64)>,
    /// Per kept station, how far on (mm) the path stays straight, and the
    /// lowest speed cap until there: a braking that ends before there
    /// under that cap keeps every limit. `(0, 0)` while unknown.
    clear: VecDeque<(f64, f64)>,
    /// The first station of the straight stretch not closed yet, and its
    /// cap.
    open: Option<(usize, f64)>,
    /// What has been decided and handed out (`hold::Snapshot`: a
    /// snapshot is a copy of it).
    d: Snapshot,
    /// Stations kept from here on too (`keep_from`).
    keep: Option<f64>,
    /// The feed override: the programmed feed's share in the caps
    /// (`set_scale`).
    scale: f64,
    /// The largest normal acceleration (`limit_normal_accel`), mm/s².
    a_normal: f64,
    /// The samples' own check (`check_samples`): the axes' limits.
    sampled: Option<AxisLimits>,
    /// The last few `bounds_at` answers.
    memo: std::cell::RefCell<[([u64; 3], Option<Bounds>); MEMO]>,
}

/// What a braking simulation found.
#[derive(Clone, Copy, PartialEq)]
enum Verdict {
    Yes,
    No,
    /// It needs stations that have not come yet: this many in all.
    Unknown(usize),
}

/// The limits at one state: the allowed path acceleration and jerk.
#[derive(Clone, Copy)]
struct Bounds {
    a_lo: f64,
    a_hi: f64,
    s_lo: f64,
    s_hi: f64,
}

impl Planner {
    pub fn new(path: Path, lim: AxisLimits, dt: f64) -> Result<Planner, SpeedError> {
        let ok = |x: &[f64; 3]| x.iter().all(|c| *c > 0.0 && c.is_finite());
        if !(ok(&lim.v) && ok(&lim.a) && ok(&lim.j) && dt > 0.0 && dt.is_finite()) {
            return Err(SpeedError::BadLimits);
        }
        // (a sample's span: at most the axes' top speeds together)
        let top = lim.v.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut own = Path::open(path.h)?;
        own.set_window((top * dt / path.h).ceil() as usize + 1);
        let mut p = Planner {
            path: own,
            lim,
            dt,
            caps: VecDeque::new(),
            clear: VecDeque::new(),
            open: None,
            d: Snapshot {
                x: AT_REST,
                last: 0.0,
                arrived: false,
                out: VecDeque::from([0.0]),
                states: VecDeque::from([AT_REST]),
                handed: [AT_REST; 3],
                halting: false,
                need: 0,
                sampled: None,
                ceiling: 0.0,
            },
            keep: None,
            scale: 1.0,
            a_normal: f64::INFINITY,
            memo: std::cell::RefCell::new([([u64::MAX; 3], None); MEMO]),
            sampled: None,
        };
        for st in path.st {
            p.push(st)?;
        }
        if path.finished {
            p.finish(path.len)?;
        }
        Ok(p)
    }

    /// The path as far as it has come.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The next station of the run.
    pub fn push(&mut self, st: Station) -> Result<(), SpeedError> {
        self.path.push(st)?;
        self.caps.push_back((self.hard_cap(&st), st.feed));
        let c = self.cap(self.path.count() - 1);
        self.clear.push_back((0.0, 0.0));
        self.group(self.path.count() - 1, &st, c);
        Ok(())
    }

    /// The run ends at `len` (the last station's place).
    pub fn finish(&mut self, len: f64) -> Result<(), SpeedError> {
        self.path.finish(len)?;
        if let Some((f, _)) = self.open.take() {
            self.close(f, self.path.count());
        }
        Ok(())
    }

    /// `bounds` at arc length `s`, remembered for the last few states it
    /// was asked for: the braking rule asks for the bounds where its sample
    /// ends, and the next step of the braking asks again for the same
    /// state (the same bits, so the same answer).
    fn bounds_at(&self, s: f64, v: f64, a: f64) -> Option<Bounds> {
        let key = [s.to_bits(), v.to_bits(), a.to_bits()];
        let mut memo = self.memo.borrow_mut();
        if let Some((_, b)) = memo.iter().find(|(k, _)| *k == key) {
            return *b;
        }
        let b = self.bounds_on(&self.path.at(s), s, v, a);
        memo.rotate_right(1);
        memo[0] = (key, b);
        b
    }

    /// `bounds` with the shape `g` at `s` and the `K'` a sample from there
    /// may pass. A moving state's window has always come (`viable` waits
    /// for the stations two windows past where it brakes); at rest, where
    /// no `K'` counts, it may not have, and `g`'s own stands in.
    fn bounds_on(&self, g: &Station, s: f64, v: f64, a: f64) -> Option<Bounds> {
        let kd = self.path.kd_range(s);
        debug_assert!(
            kd.is_some() || v == 0.0,
            "K' range at {s} asked before its window came"
        );
        self.bounds(g, &kd.unwrap_or(Range::of(g.kd)), v, a)
    }

    /// The path accelerations and jerks every axis allows at `(v, a)`,
    /// with every `K'` of `kd` (`envelope.rs`); `None` where no jerk does
    /// (the curvature terms alone are over).
    fn bounds(&self, g: &Station, kd: &Range, v: f64, a: f64) -> Option<Bounds> {
        let mut b = Bounds {
            a_lo: f64::NEG_INFINITY,
            a_hi: f64::INFINITY,
            s_lo: f64::NEG_INFINITY,
            s_hi: f64::INFINITY,
        };
        let v3 = v * v * v;
        for i in 0..3 {
            let t = g.t[i];
            let ca = g.k[i] * v * v;
            let cj = 3.0 * g.k[i] * v * a;
            let (am, jm) = (self.lim.a[i], self.lim.j[i]);
            // T σ within the limit less the curvature's terms, for every K'
            let (e0, e1) = (-jm - cj - kd.lo[i] * v3, jm - cj - kd.hi[i] * v3);
            if e0 > e1 {
                return None;
            }
            if t.abs() > 1e-12 {
                let r = 1.0 / t;
                let (x, y) = ((-am - ca) * r, (am - ca) * r);
                b.a_lo = b.a_lo.max(x.min(y));
                b.a_hi = b.a_hi.min(x.max(y));
                let (x, y) = (e0 * r, e1 * r);
                b.s_lo = b.s_lo.max(x.min(y));
                b.s_hi = b.s_hi.min(x.max(y));
            } else if ca.abs() > am || e0 > 0.0 || e1 < 0.0 {
                return None;
            }
        }
        if v * (g.k[0].abs() + g.k[1].abs() + g.k[2].abs()) > 1e-12 {
            let (lo, hi) = self.a_for_jerk(g, kd, v);
            b.a_lo = b.a_lo.max(lo);
            b.a_hi = b.a_hi.min(hi);
        }
        (b.s_lo <= b.s_hi && b.a_lo <= b.a_hi).then_some(b)
    }

    /// The path accelerations at speed `v` for which some path jerk keeps
    /// every axis's jerk within `JERK_FOR_A` of its limit (the rest is
    /// left for changing the acceleration): every axis gives the jerk an
    /// interval whose ends move with `a` (the `3 K v a` term), and each
    /// pair of a lower and an upper end bounds `a` (Fourier–Motzkin).
    fn a_for_jerk(&self, g: &Station, kd: &Range, v: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        // each end of a jerk interval as p + q a
        let mut lower: [(f64, f64); 3] = [(0.0, 0.0); 3];
        let mut upper: [(f64, f64); 3] = [(0.0, 0.0); 3];
        let mut n = 0;
        for i in 0..3 {
            let (t, c, v3) = (g.t[i], 3.0 * g.k[i] * v, v * v * v);
            let jm = JERK_FOR_A * self.lim.j[i];
            let (e0, e1) = (-jm - kd.lo[i] * v3, jm - kd.hi[i] * v3);
            if t.abs() > 1e-12 {
                let r = 1.0 / t;
                let (a0, a1) = ((e0 * r, -c * r), (e1 * r, -c * r));
                let (l, u) = if t > 0.0 { (a0, a1) } else { (a1, a0) };
                lower[n] = l;
                upper[n] = u;
                n += 1;
            } else {
                // e0 <= c a <= e1
                bound(&mut lo, &mut hi, c, e0, e1);
            }
        }
        for l in &lower[..n] {
            for u in &upper[..n] {
                // (an axis's own pair: whether every K' leaves it room)
                // l.0 + l.1 a <= u.0 + u.1 a  <=>  (l.1 - u.1) a <= u.0 - l.0
                let (c, e) = (l.1 - u.1, u.0 - l.0);
                if c > 1e-12 {
                    hi = hi.min(e / c);
                } else if c < -1e-12 {
                    lo = lo.max(e / c);
                } else if e < 0.0 {
                    return (f64::INFINITY, f64::NEG_INFINITY);
                }
            }
        }
        (lo, hi)
    }

    /// The braking rule's jerk at `x`: down to the lowest acceleration the
    /// axes allow, then, once the speed left is what bringing the
    /// acceleration back to zero takes, the landing. `None` where the axes
    /// allow no jerk.
    fn brake(&self, g: &Station, x: State, b: &Bounds) -> Option<f64> {
        let dt = self.dt;
        // the lowest acceleration allowed here, a hair above it; then, with
        // the bounds where the sample ends (the path turns under the axes,
        // the speed changes), the lowest allowed at both ends
        let aim = |a_lo: f64| a_lo + A_MARGIN * a_lo.abs();
        let mut down = ((aim(b.a_lo) - x.a) / dt).clamp(b.s_lo, b.s_hi);
        let y = x.step(down, dt);
        if let Some(e) = self.bounds_at(y.s, y.v.max(0.0), y.a) {
            let lo = e.s_lo.max(b.s_lo);
            let hi = e.s_hi.min(b.s_hi).max(lo);
            down = ((aim(b.a_lo.max(e.a_lo)) - x.a) / dt).clamp(lo, hi);
        }
        let down = self.within_both(x, down, b);
        if b.s_hi > 0.0 && b.s_lo < 0.0 {
            // the jerk a landing may use: within the bounds here and at
            // rest here (the curvature's share of them fades as it lands)
            let rest = self.rest_jerk(g);
            let (lo, hi) = (b.s_lo.max(-rest), b.s_hi.min(rest));
            // land now if, after one more sample of braking, bringing the
            // acceleration back to zero with a share of the jerk would
            // take more speed than is left
            let y = x.step(down, dt);
            let up = TRIGGER_SHARE * hi;
            if y.v <= 0.0 || (y.a < 0.0 && y.v <= y.a * y.a / (2.0 * up)) {
                let land = landing(x.v, x.a, LAND_SHARE * lo, LAND_SHARE * hi, dt)?;
                return Some(self.within_both(x, land.clamp(b.s_lo, b.s_hi), b));
            }
        }
        Some(down)
    }

    /// The largest path jerk at rest at `g`: each axis's limit over its
    /// share of the tangent.
    fn rest_jerk(&self, g: &Station) -> f64 {
        (0..3)
            .filter(|i| g.t[*i].abs() > 1e-12)
            .map(|i| self.lim.j[i] / g.t[i].abs())
            .fold(f64::INFINITY, f64::min)
    }

    /// `sig` (within `b`, the bounds at `x`) also within the bounds at the
    /// end of the sample it is held for, as far as one more look gets.
    fn within_both(&self, x: State, sig: f64, b: &Bounds) -> f64 {
        let mut sig = sig;
        for _ in 0..2 {
            let y = x.step(sig, self.dt);
            if let Some(e) = self.bounds_at(y.s, y.v.max(0.0), y.a) {
                let lo = e.s_lo.max(b.s_lo);
                sig = sig.clamp(lo, e.s_hi.min(b.s_hi).max(lo));
            }
        }
        sig
    }

    /// How many stations a decision at `s` needs before the run's end is
    /// known: those a sample from there may pass, and each one's window
    /// of `K'` (the braking rule asks for the bounds where its sample
    /// ends, up to a window ahead, and those take in a window more).
    fn needs(&self, s: f64) -> usize {
        (s.max(0.0) / self.path.h) as usize + 2 + 2 * self.path.window()
    }

    /// Whether `x`, reached from `from` with jerk `sig`, keeps every limit
    /// (`sig` too, at the sample's end as at its start; the speed cap of
    /// every station passed) and braking from it by `brake` does too,
    /// coming to rest by `end`.
    fn viable(&self, mut from: f64, mut x: State, mut sig: f64) -> Verdict {
        use Verdict::{No, Unknown, Yes};
        let end = self.path.len().unwrap_or(f64::INFINITY);
        for _ in 0..MAX_BRAKE {
            if x.s > end + 1e-9 || x.v < -1e-6 {
                return No;
            }
            let n = self.needs(x.s);
            if !self.path.finished && n > self.path.count() {
                return Unknown(n);
            }
            // the speed at the sample and over it (the setpoints' difference)
            let cap = self.cap_over_at(from, x.s, self.soft_scale()) * (1.0 + 1e-12) + 1e-12;
            if x.v > cap || x.s - from > cap * self.dt {
                return No;
            }
            let Some(b) = self.bounds_at(x.s, x.v.max(0.0), x.a) else {
                return No;
            };
            let slack = 1e-9 * (1.0 + x.a.abs());
            if x.a < b.a_lo - slack || x.a > b.a_hi + slack {
                return No;
            }
            let slack = 1e-4 * (1.0 + sig.abs());
            if sig < b.s_lo - slack || sig > b.s_hi + slack {
                return No;
            }
            if x.v <= REST_V && x.a.abs() <= 1e-6 {
                return Yes;
            }
            if self.clearly_viable(x, &b, end) {
                return Yes;
            }
            let Some(next) = self.brake(&self.path.at(x.s), x, &b) else {
                return No;
            };
            sig = next;
            from = x.s;
            x = x.step(sig, self.dt);
        }
        No
    }

    /// One sample: the largest jerk whose next state is viable. `None`
    /// while that needs stations that have not come yet (nothing moves).
    fn tick(&mut self, point: Option<Point>) -> Result<Option<()>, SpeedError> {
        let x = self.d.x;
        let need = self.d.need.max(self.needs(x.s));
        if self.path.count() < 2 || (!self.path.finished && self.path.count() < need) {
            return Ok(None);
        }
        let g = self.path.at(x.s);
        let Some(b) = self.bounds_on(&g, x.s, x.v, x.a) else {
            return Err(SpeedError::Stuck { s: x.s, v: x.v });
        };
        // staying at rest is always viable, braking from a viable state too
        let rest = x.v == 0.0 && x.a == 0.0;
        let safe = if rest {
            0.0
        } else {
            self.brake(&g, x, &b).unwrap_or(b.s_lo)
        };
        if self.d.halting {
            // a feed hold: the braking rule to rest, then rest
            self.commit(x, safe, point);
            return Ok(Some(()));
        }
        // a probe that needs stations still to come ends the try: the
        // sample is tried again, from the start, once they have come
        let ok = |sig: f64| match self.viable(x.s, x.step(sig, self.dt), sig) {
            Verdict::Yes => Ok(true),
            Verdict::No => Ok(false),
            Verdict::Unknown(n) => Err(n),
        };
        let onto = match self.approach(x, &b) {
            Ok(sig) => sig,
            Err(n) => {
                self.d.need = n;
                return Ok(None);
            }
        };
        let top = self.within_both(x, b.s_hi.min(onto.max(b.s_lo)), &b);
        let choose = || -> Result<f64, usize> {
            if top <= safe {
                return Ok(safe);
            }
            if ok(top)? {
                return Ok(top);
            }
            // bisection, first about the last sample's jerk (the
            // boundary often moves little from one sample to the next)
            let (mut lo, mut hi) = (safe, top.max(safe));
            let width = b.s_hi - b.s_lo;
            let near = self.d.last.clamp(lo, hi);
            for probe in [near + WARM * width, near - WARM * width] {
                if probe > lo && probe < hi {
                    if ok(probe)? {
                        lo = probe;
                    } else {
                        hi = probe;
                    }
                }
            }
            for _ in 0..BISECT {
                if hi - lo <= TOL * width {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                if ok(mid)? {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Ok(lo)
        };
        let sig = match choose() {
            Ok(sig) => sig,
            Err(n) => {
                self.d.need = n;
                return Ok(None);
            }
        };
        let sig = match point {
            Some(pt) => self.sampled_choice(x, sig, safe, pt),
            None => sig,
        };
        self.commit(x, sig, point);
        Ok(Some(()))
    }

    /// Takes jerk `sig` from `x` for the next sample.
    fn commit(&mut self, x: State, sig: f64, point: Option<Point>) {
        self.d.last = sig;
        let mut x = x.step(sig, self.dt);
        if x.v <= REST_V && x.a.abs() <= 1e-6 {
            x.v = 0.0;
            x.a = 0.0;
        }
        // (over the caps of a lower override, it comes down onto them from
        // the one it was decided under: the feed is not a limit of the axes)
        self.d.ceiling = if x.v > self.cap_over(x.s, x.s) {
            self.soft_scale()
        } else {
            self.scale
        };
        self.d.x = x;
        self.d.out.push_back(x.s);
        self.d.states.push_back(x);
        if let (Some(pt), Some(_), Some(h)) = (point, self.sampled, self.d.sampled.as_mut()) {
            *h = [h[1], h[2], pt(x.s)];
        }
        // (behind the samples handed out: a feed hold brakes from there)
        let behind = self.d.handed[0].s.min(self.keep.unwrap_or(f64::INFINITY));
        let gone = self.path.forget_before(behind.min(self.path.known()));
        self.caps.drain(..gone);
        self.clear.drain(..gone);
        if let Some(end) = self.path.len() {
            if x.v == 0.0 && x.s >= end - END_TOL {
                stretch(self.d.out.make_contiguous(), end);
                self.d.arrived = true;
            }
        }
    }

    /// The path position at the next sample (the first is 0, the last
    /// exactly the run's end); `None` when the run is over or, before
    /// `finish`, when it needs more stations. Samples come about
    /// `STRETCH_MIN` behind the planning (the end's smooth step may
    /// still move them).
    pub fn next_sample(&mut self) -> Result<Option<f64>, SpeedError> {
        self.next_sample_of(None)
    }

    /// `next_sample`, each sample also checked on the path's points
    /// (`check_samples`): `point` gives the point at a path position.
    pub fn next_sample_on(&mut self, point: Point) -> Result<Option<f64>, SpeedError> {
        self.next_sample_of(Some(point))
    }

    fn next_sample_of(&mut self, point: Option<Point>) -> Result<Option<f64>, SpeedError> {
        if let (Some(pt), Some(_), None) = (point, self.sampled, self.d.sampled) {
            self.d.sampled = Some([pt(0.0); 3]);
        }
        loop {
            if self.d.arrived || self.d.out.len() > STRETCH_MIN + 1 {
                if let Some(x) = self.d.states.pop_front() {
                    self.d.handed = [self.d.handed[1], self.d.handed[2], x];
                }
                return Ok(self.d.out.pop_front());
            }
            if self.tick(point)?.is_none() {
                return Ok(None);
            }
        }
    }

    /// Whether the run has come to rest on its end.
    pub fn arrived(&self) -> bool {
        self.d.arrived
    }

    /// Whether every sample of the run has been handed out (the last one
    /// at rest on its end).
    pub fn over(&self) -> bool {
        self.d.arrived && self.d.out.is_empty()
    }

    /// The whole run of a finished path: the path position at every
    /// sample, at most `max_ticks` of them.
    pub fn run(mut self, max_ticks: usize) -> Result<Vec<f64>, SpeedError> {
        let mut out = Vec::new();
        while out.len() <= max_ticks {
            match self.next_sample()? {
                Some(s) => out.push(s),
                None if self.d.arrived => return Ok(out),
                None => break,
            }
        }
        Err(SpeedError::NoEnd {
            ticks: out.len(),
            s: self.d.x.s,
        })
    }
}

/// Narrows `[lo, hi]` to the `a` with `e0 <= c a <= e1`; empty (lo > hi)
/// where no `a` does.
fn bound(lo: &mut f64, hi: &mut f64, c: f64, e0: f64, e1: f64) {
    if c.abs() <= 1e-12 {
        if e0 > 0.0 || e1 < 0.0 {
            *lo = f64::INFINITY;
            *hi = f64::NEG_INFINITY;
        }
        return;
    }
    let (x, y) = (e0 / c, e1 / c);
    *lo = lo.max(x.min(y));
    *hi = hi.min(x.max(y));
}

mod caps;
mod ends;
use ends::{landing, stretch};
mod hold;
pub use hold::Snapshot;
mod sampled;
#[cfg(test)]
mod tests;
