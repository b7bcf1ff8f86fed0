//! The geometry stage of a planner without setpoint filters (issue 17;
//! `bench/motion/g2_bound.py` prototypes it in Python): a run of moves
//! between rests, given as a dense polyline on the programmed path, becomes
//! a smooth path within the path tolerance P, independent of speed, and
//! then the stations `path_speed` plans on: the path planner's geometry
//! (`crate::path_run`). `Stream` (`stream.rs`) works a run out over a
//! moving window, as the path planner has it.
//!
//! **The smoothing.** A moving average in arc length, taken twice, turns
//! a kink into a curvature ramp and a curvature step into a smooth one
//! (two averages make the curvature continuous). Its width `w(s)` is as
//! large as P allows at each place:
//! - at most `W0`;
//! - narrowed, in rounds, wherever the smoothed path is further than
//!   `TARGET`·P from the programmed one, until no point is further than
//!   `DONE`·P; each round multiplies the width there by the square root of
//!   0.9·`TARGET`·P over the distance (a curve's distance grows with the
//!   width squared), kept between 0.2 and 0.8 (the prototype takes 0.8
//!   every round; this needs a third of the rounds for the same path
//!   within a few µm of width);
//! - made regular after every round, always from the requirement: it may
//!   change by at most `SLOPE` mm per mm, then it takes its least over
//!   ±0.5 mm and is averaged twice over 0.5 mm, so that it changes
//!   smoothly and the smoothed path's curvature change stays bounded.
//!
//! On CAM polylines the average's shrink of curves is made up by twicing
//! (`2·B − B·B`, B two averages), so that it can be wide enough to even
//! out the polyline's vertices.
//!
//! Past a run's ends the path is continued by point reflection about the
//! end point, so an average there is the end point itself: the smoothed
//! path starts and ends exactly where the run does, with no curvature, and
//! a run that stops on a curve stops smoothly.

/// Spacing of the fine grid the smoothing works on, mm.
pub const DS: f64 = 0.004;
/// The widest average, mm.
pub const W0: f64 = 3.0;
/// The share of P the smoothed path may use.
const TARGET: f64 = 0.95;
/// The smoothing is done once no point is further off than this share of P.
const DONE: f64 = TARGET;
/// How fast the width may change, mm per mm.
const SLOPE: f64 = 0.5;
/// Rounds of narrowing, at most.
const ROUNDS: usize = 300;

/// A run's programmed path as a polyline: points in order, no two further
/// apart than about `DS` (arcs sampled), and the feed at each point.
pub struct Polyline {
    pub p: Vec<[f64; 3]>,
    pub feed: Vec<f64>,
}

/// The smoothed path on its fine grid.
pub struct Smoothed {
    /// Points, `DS` or less apart along the programmed path.
    pub q: Vec<[f64; 3]>,
    /// Arc length of the smoothed path at each point.
    pub sig: Vec<f64>,
    /// Unit tangent at each point.
    pub t: Vec<[f64; 3]>,
    /// Curvature vector and its derivative at each point.
    pub k: Vec<[f64; 3]>,
    pub kd: Vec<[f64; 3]>,
    /// The feed at each point.
    pub feed: Vec<f64>,
    /// The width of the average at each point, mm.
    pub w: Vec<f64>,
    /// The largest distance from the programmed path, mm.
    pub dev: f64,
}

/// Why a run could not be smoothed.
#[derive(Clone, Debug, PartialEq)]
pub enum SmoothError {
    /// Fewer than two points, a point or feed that is not finite, or no
    /// length.
    BadRun(&'static str),
    /// The narrowing did not get within P in `ROUNDS` rounds.
    NoConvergence { dev: f64 },
}

impl std::fmt::Display for SmoothError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SmoothError::BadRun(why) => write!(f, "run: {why}"),
            SmoothError::NoConvergence { dev } => write!(
                f,
                "the smoothing did not get within the tolerance ({:.2} µm off after {ROUNDS} rounds)",
                dev * 1000.0
            ),
        }
    }
}

impl std::error::Error for SmoothError {}

/// A piecewise linear function of arc length: values at `s` (ascending),
/// with its running integral for exact averages.
struct Pl<'a> {
    s: &'a [f64],
    p: &'a [[f64; 3]],
    c: Vec<[f64; 3]>,
    /// each segment's slope (worked out once: `integral` runs millions of
    /// times a run)
    m: Vec<[f64; 3]>,
    uniform: Option<f64>,
}

impl<'a> Pl<'a> {
    fn new(s: &'a [f64], p: &'a [[f64; 3]], uniform: Option<f64>) -> Pl<'a> {
        let mut c = vec![[0.0; 3]; s.len()];
        let mut m = vec![[0.0; 3]; s.len()];
        for j in 1..s.len() {
            let h = s[j] - s[j - 1];
            c[j] = xyz(|k| c[j - 1][k] + 0.5 * (p[j][k] + p[j - 1][k]) * h);
            m[j - 1] = xyz(|k| (p[j][k] - p[j - 1][k]) / h);
        }
        Pl {
            s,
            p,
            c,
            m,
            uniform,
        }
    }

    fn seg(&self, y: f64) -> usize {
        let n = self.s.len();
        match self.uniform {
            Some(h) => (((y - self.s[0]) / h).max(0.0) as usize).min(n - 2),
            None => self.s.partition_point(|x| *x <= y).clamp(1, n - 1) - 1,
        }
    }

    fn value(&self, y: f64) -> [f64; 3] {
        let j = self.seg(y);
        let f = ((y - self.s[j]) / (self.s[j + 1] - self.s[j])).clamp(0.0, 1.0);
        xyz(|k| self.p[j][k] + f * (self.p[j + 1][k] - self.p[j][k]))
    }

    fn integral(&self, y: f64) -> [f64; 3] {
        let j = self.seg(y);
        let tau = y - self.s[j];
        let (c, p, m) = (&self.c[j], &self.p[j], &self.m[j]);
        xyz(|k| c[k] + p[k] * tau + m[k] * 0.5 * tau * tau)
    }

    /// The running integral continued past the ends by point reflection
    /// (`p(L + u) = 2 p(L) - p(L - u)`, and so at the start), so that an
    /// average at an end is the end point itself and the path leaves it
    /// with no curvature.
    fn integral_ext(&self, y: f64) -> [f64; 3] {
        let (first, last) = (self.s[0], self.s[self.s.len() - 1]);
        if y > last {
            let (c, pl) = (self.integral(2.0 * last - y), self.p[self.p.len() - 1]);
            xyz(|k| c[k] + 2.0 * pl[k] * (y - last))
        } else if y < first {
            let (c, pf) = (self.integral(2.0 * first - y), self.p[0]);
            xyz(|k| c[k] - 2.0 * pf[k] * (first - y))
        } else {
            self.integral(y)
        }
    }

    /// The average over `[x - w/2, x + w/2]` at each `x`, the path
    /// continued past its ends by point reflection (`integral_ext`; the
    /// window at most half the run).
    fn boxed(&self, w: &[f64], x: &[f64]) -> Vec<[f64; 3]> {
        let (first, last) = (self.s[0], self.s[self.s.len() - 1]);
        let most = 0.5 * (last - first);
        x.iter()
            .zip(w)
            .map(|(&x, &w)| {
                let half = (0.5 * w).min(most);
                if half > 1e-9 {
                    let (a, b) = (self.integral_ext(x + half), self.integral_ext(x - half));
                    xyz(|k| (a[k] - b[k]) / (2.0 * half))
                } else {
                    self.value(x)
                }
            })
            .collect()
    }
}

/// A width under `req` everywhere that changes slowly and smoothly (see
/// the module's text).
fn regular(req: &[f64]) -> Vec<f64> {
    let n = req.len();
    let step = SLOPE * DS;
    // the largest function under req with slope at most SLOPE
    let mut w = req.to_vec();
    for i in 1..n {
        w[i] = w[i].min(w[i - 1] + step);
    }
    for i in (0..n - 1).rev() {
        w[i] = w[i].min(w[i + 1] + step);
    }
    let m = ((0.5 / DS) as usize) | 1;
    let w = sliding_min(&w, m);
    let w = mean(&w, m / 2);
    mean(&w, m / 2)
}

/// The least of `x[i - r ..= i + r]` (the ends repeated) for every `i`,
/// by a queue of indices whose values rise.
fn sliding_min(x: &[f64], r: usize) -> Vec<f64> {
    let n = x.len();
    let mut out = Vec::with_capacity(n);
    let mut q: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0; // the next index to enter the queue
    for i in 0..n {
        let hi = (i + r).min(n - 1);
        while next <= hi {
            while q.back().is_some_and(|j| x[*j] >= x[next]) {
                q.pop_back();
            }
            q.push_back(next);
            next += 1;
        }
        while q.front().is_some_and(|j| *j + r < i) {
            q.pop_front();
        }
        out.push(q.front().map_or(f64::INFINITY, |j| x[*j]));
    }
    out
}

/// The mean over `x[i - r ..= i + r]`, the ends repeated, for every `i`.
fn mean(x: &[f64], r: usize) -> Vec<f64> {
    let n = x.len() as isize;
    let at = |i: isize| x[i.clamp(0, n - 1) as usize];
    let mut out = Vec::with_capacity(x.len());
    let ri = r as isize;
    let mut sum: f64 = (-ri..=ri).map(at).sum();
    for i in 0..n {
        out.push(sum / (2 * r + 1) as f64);
        sum += at(i + ri + 1) - at(i - ri);
    }
    out
}

/// `[f(0), f(1), f(2)]`, written out (`[0, 1, 2].map` was not inlined in
/// the smoothing's inner loops: a sixth of their instructions).
#[inline(always)]
fn xyz(f: impl Fn(usize) -> f64) -> [f64; 3] {
    [f(0), f(1), f(2)]
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The distance from `x` to the nearest of `p[i - reach ..= i + reach]`,
/// searched outwards from `i`, stopping at the first within `enough`.
/// The points are at most `DS` apart (a grid on the programmed path), so
/// a point `d` from `x` has the next `m` on its side at least `d − m DS`
/// from it: those that cannot be nearer than the nearest so far are not
/// looked at (the answer is the exhaustive search's, bit for bit).
fn nearest(x: &[f64; 3], p: &[[f64; 3]], i: usize, reach: usize, enough: f64) -> f64 {
    let d2 = |j: usize| (0..3).map(|k| (x[k] - p[j][k]).powi(2)).sum::<f64>();
    let (stop, last) = (enough * enough, p.len() - 1);
    let mut best = d2(i);
    // (the spacing's bound with room for rounding)
    let step = DS * (1.0 + 1e-9);
    // how many points after one `d2` from `x` cannot be nearer than `best`
    let skip = |d2: f64, best: f64| {
        let m = (d2.sqrt() - best.sqrt()) / step - 1e-6;
        if m >= 1.0 {
            m.min(1e9) as usize
        } else {
            0
        }
    };
    // the next offset looked at on either side
    let (mut lo, mut hi) = (1, 1);
    for k in 1..=reach {
        if best <= stop {
            break;
        }
        if k <= i && k >= lo {
            let d = d2(i - k);
            best = best.min(d);
            lo = k + 1 + skip(d, best);
        }
        if i + k <= last && k >= hi {
            let d = d2(i + k);
            best = best.min(d);
            hi = k + 1 + skip(d, best);
        }
    }
    best.sqrt()
}

/// Smooths one run within `tol` (P, mm); `twice` makes up the averages'
/// shrink of curves (for CAM polylines).
pub fn smooth(run: &Polyline, tol: f64, twice: bool) -> Result<Smoothed, SmoothError> {
    smooth_chunked(run, tol, twice, f64::INFINITY, 0.0)
}

/// `smooth`, worked out `chunk` mm of the run at a time, each with
/// `margin` mm of the run on either side, and the chunks' middles put
/// together: a point's smoothed place depends on the path near it only
/// (the averages, the width's regularisation and the rounds reach about
/// ±20 mm), which is what a look-ahead over a moving window needs.
pub fn smooth_chunked(
    run: &Polyline,
    tol: f64,
    twice: bool,
    chunk: f64,
    margin: f64,
) -> Result<Smoothed, SmoothError> {
    if run.feed.len() != run.p.len() {
        return Err(SmoothError::BadRun(
            "fewer than two points, or not one feed per point",
        ));
    }
    let mut st = Stream::new(tol, twice, chunk, margin, 1.0)?;
    for (p, f) in run.p.iter().zip(&run.feed) {
        st.push(*p, *f)?;
    }
    st.into_smoothed()
}

/// The smoothed points and widths on the grid `s` (a stretch of the run's
/// grid, `h` apart; `p` the programmed path there): the rounds of the
/// module's text. The first average reads the whole run (`path`); the
/// others read what the stretch has, continued past its ends by
/// reflection.
fn smooth_range(
    path: &Pl,
    s: &[f64],
    p: &[[f64; 3]],
    h: f64,
    tol: f64,
    twice: bool,
) -> Result<(Vec<[f64; 3]>, Vec<f64>), SmoothError> {
    let n = s.len();
    let mut req = vec![W0; n];
    let mut w = regular(&req);
    let mut worst = f64::INFINITY;
    for _ in 0..ROUNDS {
        let b1 = path.boxed(&w, s);
        let b = Pl::new(s, &b1, Some(h)).boxed(&w, s);
        let q: Vec<[f64; 3]> = if twice {
            let bb1 = Pl::new(s, &b, Some(h)).boxed(&w, s);
            let bb = Pl::new(s, &bb1, Some(h)).boxed(&w, s);
            (0..n).map(|i| xyz(|k| 2.0 * b[i][k] - bb[i][k])).collect()
        } else {
            b
        };
        // the distance from the programmed path where it may matter: to
        // the nearest programmed point within reach of the averages that
        // made the point (±w), the search stopping at one within TARGET
        // (such a point does not matter); the points are DS apart, so this
        // is at most a fraction of a µm over the distance to the path
        let mut dev = vec![0.0; n];
        for i in (0..n).filter(|i| dist(&q[*i], &p[*i]) > TARGET * tol) {
            dev[i] = nearest(&q[i], p, i, (w[i] / h).ceil() as usize + 2, TARGET * tol);
        }
        worst = dev.iter().fold(0.0, |m: f64, d| m.max(*d));
        if worst <= DONE * tol {
            return Ok((q, w));
        }
        for i in 0..n {
            if dev[i] > TARGET * tol {
                let f = (0.9 * TARGET * tol / dev[i]).sqrt().clamp(0.2, 0.8);
                req[i] = req[i].min(f * w[i]);
            }
        }
        w = regular(&req);
    }
    Err(SmoothError::NoConvergence { dev: worst })
}

/// A run taken as it is, not smoothed (a single line).
pub fn plain(run: &Polyline) -> Result<Smoothed, SmoothError> {
    arc_length(run)?;
    Ok(finish(
        run.p.clone(),
        vec![W0; run.p.len()],
        run.feed.clone(),
        0.0,
    ))
}

/// The run's arc length at each point, once the run is checked: two
/// points or more, each finite and apart from the one before, one
/// positive feed per point.
fn arc_length(run: &Polyline) -> Result<Vec<f64>, SmoothError> {
    let p0 = &run.p;
    if p0.len() < 2 || run.feed.len() != p0.len() {
        return Err(SmoothError::BadRun(
            "fewer than two points, or not one feed per point",
        ));
    }
    if p0.iter().any(|p| p.iter().any(|c| !c.is_finite()))
        || run.feed.iter().any(|f| f.is_nan() || *f <= 0.0)
    {
        return Err(SmoothError::BadRun(
            "a point that is not finite or a feed that is not positive",
        ));
    }
    let mut s0 = vec![0.0; p0.len()];
    for j in 1..p0.len() {
        let d = dist(&p0[j], &p0[j - 1]);
        if d <= 0.0 {
            return Err(SmoothError::BadRun("no length, or two points in one place"));
        }
        s0[j] = s0[j - 1] + d;
    }
    Ok(s0)
}

/// The smoothed points' own arc length, tangent, curvature and its change.
fn finish(q: Vec<[f64; 3]>, w: Vec<f64>, feed: Vec<f64>, dev: f64) -> Smoothed {
    let mut sig = vec![0.0; q.len()];
    for j in 1..q.len() {
        // points the smoothing put in one place keep the grid's order
        sig[j] = sig[j - 1] + dist(&q[j], &q[j - 1]).max(1e-12);
    }
    let (mut t, mut k, mut kd) = (Vec::new(), Vec::new(), Vec::new());
    stream::extend(&mut t, &q, &sig, true, true);
    stream::extend(&mut k, &t, &sig, true, false);
    stream::extend(&mut kd, &k, &sig, true, false);
    Smoothed {
        q,
        sig,
        t,
        k,
        kd,
        feed,
        w,
        dev,
    }
}

impl Smoothed {
    /// The path's length.
    pub fn len(&self) -> f64 {
        self.sig[self.sig.len() - 1]
    }

    /// Stations `h` apart for `path_speed`, the last at the end.
    pub fn stations(&self, h: f64) -> Vec<crate::path_speed::Station> {
        let len = self.len();
        let n = (len / h).ceil() as usize + 1;
        let sig = &self.sig;
        let (tl, kl, dl) = (
            Pl::new(sig, &self.t, None),
            Pl::new(sig, &self.k, None),
            Pl::new(sig, &self.kd, None),
        );
        let fl: Vec<[f64; 3]> = self.feed.iter().map(|f| [*f, 0.0, 0.0]).collect();
        let fl = Pl::new(sig, &fl, None);
        (0..n)
            .map(|i| {
                let x = (i as f64 * h).min(len);
                crate::path_speed::Station {
                    t: tl.value(x),
                    k: kl.value(x),
                    kd: dl.value(x),
                    feed: fl.value(x)[0],
                }
            })
            .collect()
    }

    /// The point at arc length `x`: cubic Hermite between grid points, from
    /// their positions and tangents.
    pub fn point(&self, x: f64) -> [f64; 3] {
        stream::hermite(&self.sig, &self.q, &self.t, x)
    }
}

mod ahead;
mod stream;
pub use ahead::Worker;
pub use stream::Stream;

#[cfg(test)]
mod tests;
