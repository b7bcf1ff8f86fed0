//! The geometry stage over a moving window: points of a run's programmed
//! path come in as the look-ahead has them, the smoothed path comes out a
//! chunk at a time, each worked out with a margin of the run on either
//! side (`smooth_chunked` is this stream fed a whole run), and the
//! stations `path_speed` plans on come out as soon as the smoothed path
//! reaches past them. What lies behind the chunk being worked out and
//! behind the samples (`forget_before`) is dropped, so a run of any length
//! takes the memory of its window.
//!
//! The grid is `DS` apart from the run's start, the last interval ending on
//! the run's end (between `DS/2` and `1.5 DS` long), so a grid point's place
//! does not depend on how long the run turns out to be: a chunk is worked
//! out once the run is known `W0` past its margin.

use super::ahead::{Done, Job, Link, Worker};
use super::{dist, nearest, xyz, SmoothError, Smoothed, DS, W0};
use crate::path_speed::Station;
use std::sync::Arc;

/// Points dropped at once from the front of a buffer (amortises the move).
const DROP_BATCH: usize = 4096;
/// Where two chunks meet, the next one's path takes over from the last
/// one's over this many mm, by a smooth step: at a small P the rounds of
/// narrowing couple the whole of a curve, so that two chunks' paths may
/// differ by a micron or so far from their ends, which a seam would show
/// as a step in the curvature's change.
const FADE: f64 = 8.0;
/// With a worker, grid points taken in from a chunk at a time (1 mm): the
/// stations come a few at a time as the samples need them, and no call
/// takes in a whole chunk at once.
const SLICE: usize = 250;

/// A run's geometry, smoothed as its programmed path comes.
pub struct Stream {
    tol: f64,
    twice: bool,
    /// grid points per chunk, and either side of it
    per: usize,
    extra: usize,
    /// the programmed path from raw point `raw_base` on: arc length, point,
    /// feed
    rs: Vec<f64>,
    rp: Vec<[f64; 3]>,
    rf: Vec<f64>,
    raw_base: usize,
    /// the run's programmed length once it is finished
    len: Option<f64>,
    /// the first grid point of the next chunk, and of the next one not
    /// taken in yet (from the worker)
    next: usize,
    applied: usize,
    /// the smoothed grid from point `base` on: point, width, feed, own arc
    /// length (as long as `q`); tangent, curvature and its change (each as
    /// far as its neighbours are known)
    base: usize,
    q: Vec<[f64; 3]>,
    w: Vec<f64>,
    feed: Vec<f64>,
    sig: Vec<f64>,
    t: Vec<[f64; 3]>,
    k: Vec<[f64; 3]>,
    kd: Vec<[f64; 3]>,
    /// the last chunk's path and width past its end, for the next one to
    /// take over from (`FADE`)
    tail: Vec<([f64; 3], f64)>,
    /// the largest distance from the programmed path so far
    dev: f64,
    /// stations: spacing, the next one's index, the grid interval it lies
    /// in, and whether the last has been handed out
    h: f64,
    station: usize,
    at: usize,
    stations_done: bool,
    /// the worker the chunks go to, if any (`work_ahead`), and the chunk
    /// being taken in from it
    ahead: Option<Link>,
    part: Option<Part>,
}

/// A chunk smoothed and not yet wholly taken in: its next grid point.
struct Part {
    job: Arc<Job>,
    done: Done,
    next: usize,
}

impl Stream {
    /// A run smoothed within `tol` (P, mm), its curves' shrink made up if
    /// `twice`, `chunk` mm at a time with `margin` mm either side (at least
    /// `W0` for the distance to be exact), stations `h` apart.
    pub fn new(
        tol: f64,
        twice: bool,
        chunk: f64,
        margin: f64,
        h: f64,
    ) -> Result<Self, SmoothError> {
        if !(tol > 0.0
            && tol.is_finite()
            && chunk > 0.0
            && margin >= 0.0
            && h > 0.0
            && h.is_finite())
        {
            return Err(SmoothError::BadRun(
                "tolerance, chunk and station spacing must be positive, the margin not negative",
            ));
        }
        let per = if chunk.is_finite() {
            ((chunk / DS).ceil() as usize).max(1)
        } else {
            usize::MAX / 4
        };
        let extra = if margin.is_finite() {
            (margin / DS).ceil() as usize
        } else {
            usize::MAX / 4
        };
        Ok(Stream {
            tol,
            twice,
            per,
            extra,
            rs: Vec::new(),
            rp: Vec::new(),
            rf: Vec::new(),
            raw_base: 0,
            len: None,
            next: 0,
            applied: 0,
            base: 0,
            q: Vec::new(),
            w: Vec::new(),
            feed: Vec::new(),
            sig: Vec::new(),
            t: Vec::new(),
            k: Vec::new(),
            kd: Vec::new(),
            tail: Vec::new(),
            dev: 0.0,
            h,
            station: 0,
            at: 0,
            stations_done: false,
            ahead: None,
            part: None,
        })
    }

    /// Hands the chunks to `worker` from now on, to be smoothed on its
    /// thread while this one goes on.
    pub fn work_ahead(&mut self, worker: &Worker) {
        self.ahead = Some(worker.link());
    }

    /// The next point of the programmed path (points on arcs no further
    /// apart than about `DS`), and the feed there.
    pub fn push(&mut self, p: [f64; 3], feed: f64) -> Result<(), SmoothError> {
        if self.len.is_some() {
            return Err(SmoothError::BadRun("a point after the run's end"));
        }
        if p.iter().any(|c| !c.is_finite()) || feed.is_nan() || feed <= 0.0 {
            return Err(SmoothError::BadRun(
                "a point that is not finite or a feed that is not positive",
            ));
        }
        let s = match (self.rp.last(), self.rs.last()) {
            (Some(last), Some(s)) => {
                let d = dist(last, &p);
                if d <= 0.0 {
                    return Err(SmoothError::BadRun("no length, or two points in one place"));
                }
                s + d
            }
            _ => 0.0,
        };
        self.rs.push(s);
        self.rp.push(p);
        self.rf.push(feed);
        Ok(())
    }

    /// The run ends at the last point pushed.
    pub fn finish(&mut self) -> Result<(), SmoothError> {
        if self.raw_base + self.rp.len() < 2 {
            return Err(SmoothError::BadRun(
                "fewer than two points, or not one feed per point",
            ));
        }
        self.len = self.rs.last().copied();
        Ok(())
    }

    /// The programmed length known so far.
    fn known(&self) -> f64 {
        self.rs.last().copied().unwrap_or(0.0)
    }

    /// How many grid points the finished run has (regular ones `DS`
    /// apart, short of `len - DS/2`, then the end).
    fn grid_count(len: f64) -> usize {
        let mut r = ((len - 0.5 * DS) / DS).ceil().max(1.0) as usize;
        while r > 1 && (r - 1) as f64 * DS >= len - 0.5 * DS {
            r -= 1;
        }
        while (r as f64) * DS < len - 0.5 * DS {
            r += 1;
        }
        r + 1
    }

    /// Grid point `i`'s place on the programmed path.
    fn grid_s(&self, i: usize, n: Option<usize>) -> f64 {
        match (n, self.len) {
            (Some(n), Some(len)) if i + 1 == n => len,
            _ => i as f64 * DS,
        }
    }

    /// Works out every chunk the known path allows (with a worker: hands
    /// them to it, and takes what it has finished, waiting for the oldest
    /// when no station would come otherwise), and the tangents, curvatures
    /// and stations that follow; stations go to `out`. The stations are
    /// the same with a worker or without; only when they come differs.
    pub fn advance(&mut self, out: &mut Vec<Station>) -> Result<(), SmoothError> {
        self.advance_some(out, true)
    }

    /// With a worker: what it has ready, a slice at most, without waiting
    /// (the stations a little ahead of need, a little each sample).
    pub fn advance_ready(&mut self, out: &mut Vec<Station>) -> Result<(), SmoothError> {
        if self.ahead.is_none() {
            return Ok(());
        }
        self.advance_some(out, false)
    }

    fn advance_some(&mut self, out: &mut Vec<Station>, wait: bool) -> Result<(), SmoothError> {
        let n = self.len.map(Self::grid_count);
        self.chunks(n)?;
        let before = out.len();
        loop {
            if self.part.is_none() {
                if let Some((job, done)) = self.take(false) {
                    self.start_part(job, done?);
                }
            }
            let any = self.take_in(SLICE);
            self.derive(n);
            self.emit(n, out);
            if out.len() > before || !wait {
                break;
            }
            if any || self.part.is_some() {
                continue;
            }
            // nothing is ready: the oldest chunk handed over, once it is
            match self.take(true) {
                Some((job, done)) => self.start_part(job, done?),
                None => break,
            }
        }
        self.drop_raw();
        Ok(())
    }

    /// With a worker: hands it every chunk the known path allows (the
    /// stations come with `advance`). Without one, nothing.
    pub fn hand_over(&mut self) -> Result<(), SmoothError> {
        if self.ahead.is_none() {
            return Ok(());
        }
        self.chunks(self.len.map(Self::grid_count))
    }

    /// Every chunk the known path allows: to the worker, or worked out.
    fn chunks(&mut self, n: Option<usize>) -> Result<(), SmoothError> {
        loop {
            let i0 = self.next;
            if n.is_some_and(|n| i0 >= n) {
                break;
            }
            let i1 = n.map_or(i0 + self.per, |n| (i0 + self.per).min(n));
            let (a, b) = (
                i0.saturating_sub(self.extra),
                n.map_or(i1 + self.extra, |n| (i1 + self.extra).min(n)),
            );
            if n.is_none() && (b - 1) as f64 * DS + W0 >= self.known() {
                break;
            }
            let job = self.job(i0, i1, a, b, n);
            match self.ahead.as_mut() {
                Some(link) => link.send(job, self.tol, self.twice),
                None => {
                    let done = job.smooth(self.tol, self.twice)?;
                    self.start_part(Arc::new(job), done);
                    self.take_in(usize::MAX);
                }
            }
            self.next = i1;
        }
        Ok(())
    }

    /// The oldest chunk the worker has finished (`wait`: once it has).
    fn take(&mut self, wait: bool) -> Option<(Arc<Job>, Result<Done, SmoothError>)> {
        let (tol, twice) = (self.tol, self.twice);
        self.ahead.as_mut()?.take(tol, twice, wait)
    }

    /// What smoothing grid points `i0..i1` with `a..b` around them reads.
    fn job(&self, i0: usize, i1: usize, a: usize, b: usize, n: Option<usize>) -> Job {
        let s: Vec<f64> = (a..b).map(|i| self.grid_s(i, n)).collect();
        // the programmed path the first average reads: W0 either side
        let (lo, hi) = (s[0] - W0, s[s.len() - 1] + W0);
        let r0 = self.rs.partition_point(|x| *x <= lo).saturating_sub(1);
        let r1 = (self.rs.partition_point(|x| *x < hi) + 1).min(self.rs.len());
        Job {
            i0,
            i1,
            a,
            b,
            s,
            rs: self.rs[r0..r1].to_vec(),
            rp: self.rp[r0..r1].to_vec(),
            rf: self.rf[r0..r1].to_vec(),
        }
    }

    /// Takes in a chunk's smoothed points and widths: the last chunk's
    /// path fades into this one's, and its points wait in `part` to be
    /// taken in (`take_in`).
    fn start_part(&mut self, job: Arc<Job>, done: Done) {
        let Done {
            q: mut cq,
            w: mut cw,
            ..
        } = done;
        let (i0, i1, a, b) = (job.i0, job.i1, job.a, job.b);
        // (a quintic smooth step: the curvature's change stays continuous)
        let fade = self.tail.len().min(i1 - i0);
        for (j, (tq, tw)) in self.tail.iter().take(fade).enumerate() {
            let u = (j + 1) as f64 / (self.tail.len() + 1) as f64;
            let f = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
            let k = i0 + j - a;
            cq[k] = xyz(|c| tq[c] + f * (cq[k][c] - tq[c]));
            cw[k] = tw + f * (cw[k] - tw);
        }
        let keep = ((FADE / DS) as usize).min(b - i1);
        self.tail = (i1..i1 + keep).map(|i| (cq[i - a], cw[i - a])).collect();
        self.part = Some(Part {
            next: i0,
            job,
            done: Done {
                q: cq,
                w: cw,
                ..done
            },
        });
    }

    /// Takes in up to `most` grid points of the chunk in `part`; whether
    /// any were.
    fn take_in(&mut self, most: usize) -> bool {
        let Some(part) = self.part.as_mut() else {
            return false;
        };
        let (i1, a) = (part.job.i1, part.job.a);
        let upto = i1.min(part.next.saturating_add(most));
        let Done {
            q: cq,
            w: cw,
            p,
            feed,
        } = &part.done;
        for i in part.next..upto {
            // the distance of the chunk's points, exactly: each search may
            // stop at a programmed point nearer than the largest so far
            let reach = (cw[i - a] / DS).ceil() as usize + 2;
            self.dev = self.dev.max(nearest(&cq[i - a], p, i - a, reach, self.dev));
            self.feed.push(feed[i - part.job.i0]);
            let x = &cq[i - a];
            let s = match (self.q.last(), self.sig.last()) {
                // points the smoothing put in one place keep the grid's order
                (Some(last), Some(s)) => s + dist(x, last).max(1e-12),
                _ => 0.0,
            };
            self.q.push(*x);
            self.w.push(cw[i - a]);
            self.sig.push(s);
        }
        let any = upto > part.next;
        part.next = upto;
        if upto == i1 {
            self.applied = i1;
            self.part = None;
        }
        any
    }

    /// Tangents, curvatures and their change as far as the points allow:
    /// each the derivative of the one before in the smoothed arc length,
    /// second order inside, first order at the run's ends.
    fn derive(&mut self, n: Option<usize>) {
        let all = n.is_some_and(|n| self.applied >= n);
        extend(&mut self.t, &self.q, &self.sig, all, true);
        extend(&mut self.k, &self.t, &self.sig, all, false);
        extend(&mut self.kd, &self.k, &self.sig, all, false);
    }

    /// The stations the derived grid reaches past.
    fn emit(&mut self, n: Option<usize>, out: &mut Vec<Station>) {
        if self.stations_done || self.kd.len() < 2 {
            return;
        }
        let all = n.is_some_and(|n| self.applied >= n) && self.kd.len() == self.q.len();
        let last = self.kd.len() - 1;
        let end = self.sig[last];
        loop {
            let mut x = self.station as f64 * self.h;
            if all {
                x = x.min(end);
            } else if x >= end {
                return;
            }
            while self.at + 1 < last && self.sig[self.at + 1] <= x {
                self.at += 1;
            }
            let j = self.at;
            let f = ((x - self.sig[j]) / (self.sig[j + 1] - self.sig[j])).clamp(0.0, 1.0);
            let mix = |v: &[[f64; 3]]| xyz(|c| v[j][c] + f * (v[j + 1][c] - v[j][c]));
            out.push(Station {
                t: mix(&self.t),
                k: mix(&self.k),
                kd: mix(&self.kd),
                feed: self.feed[j] + f * (self.feed[j + 1] - self.feed[j]),
            });
            self.station += 1;
            if all && x >= end {
                self.stations_done = true;
                return;
            }
        }
    }

    /// Drops the programmed points no chunk will read again.
    fn drop_raw(&mut self) {
        let a = self.next.saturating_sub(self.extra);
        let lo = a as f64 * DS - 2.0 * W0;
        let keep = self.rs.partition_point(|x| *x <= lo).saturating_sub(1);
        if keep >= DROP_BATCH {
            self.rs.drain(..keep);
            self.rp.drain(..keep);
            self.rf.drain(..keep);
            self.raw_base += keep;
        }
    }

    /// The smoothed path's length once the run is worked out to its end.
    pub fn len(&self) -> Option<f64> {
        self.stations_done.then(|| self.sig[self.sig.len() - 1])
    }

    /// The largest distance from the programmed path so far, mm.
    pub fn dev(&self) -> f64 {
        self.dev
    }

    /// How many smoothed grid points are kept.
    pub fn kept(&self) -> usize {
        self.q.len()
    }

    /// The point at smoothed arc length `x` (clamped to what is kept and
    /// derived): cubic Hermite between grid points, from their positions
    /// and tangents. `None` before two points have tangents.
    pub fn point(&self, x: f64) -> Option<[f64; 3]> {
        let n = self.t.len();
        (n >= 2).then(|| hermite(&self.sig[..n], &self.q[..n], &self.t[..n], x))
    }

    /// Forgets the grid behind smoothed arc length `x` (what `point` and
    /// the stations still need is kept).
    pub fn forget_before(&mut self, x: f64) {
        let n = self.kd.len();
        if n < 4 {
            return;
        }
        let j = self.sig[..n].partition_point(|s| *s <= x).saturating_sub(2);
        let drop = j.min(self.at).min(n - 4);
        if drop >= DROP_BATCH {
            for v in [&mut self.q, &mut self.t, &mut self.k, &mut self.kd] {
                v.drain(..drop);
            }
            self.w.drain(..drop);
            self.feed.drain(..drop);
            self.sig.drain(..drop);
            self.at -= drop;
            self.base += drop;
        }
    }

    /// The whole run, worked out (nothing forgotten): for `smooth`.
    pub(super) fn into_smoothed(mut self) -> Result<Smoothed, SmoothError> {
        self.finish()?;
        let mut sink = Vec::new();
        self.advance(&mut sink)?;
        Ok(Smoothed {
            q: self.q,
            sig: self.sig,
            t: self.t,
            k: self.k,
            kd: self.kd,
            feed: self.feed,
            w: self.w,
            dev: self.dev,
        })
    }
}

/// Extends `d` with the derivative of `f` in `x` as far as `f`'s points
/// allow (numpy's `gradient`: second order inside, first order at the
/// ends; `all`: `f` is complete); `unit` normalises each.
pub(super) fn extend(d: &mut Vec<[f64; 3]>, f: &[[f64; 3]], x: &[f64], all: bool, unit: bool) {
    let n = f.len();
    let upto = if all { n } else { n.saturating_sub(1) };
    // (the first one overall is one-sided only at the run's start, which
    // is where an empty `d` always is: the grid is never dropped before
    // its derivatives exist)
    while d.len() < upto && n >= 2 {
        let i = d.len();
        let mut v = if i == 0 {
            let h = x[1] - x[0];
            xyz(|k| (f[1][k] - f[0][k]) / h)
        } else if i == n - 1 {
            let h = x[n - 1] - x[n - 2];
            xyz(|k| (f[n - 1][k] - f[n - 2][k]) / h)
        } else {
            let (h1, h2) = (x[i] - x[i - 1], x[i + 1] - x[i]);
            let a = -h2 / (h1 * (h1 + h2));
            let b = (h2 - h1) / (h1 * h2);
            let c = h1 / (h2 * (h1 + h2));
            xyz(|k| a * f[i - 1][k] + b * f[i][k] + c * f[i + 1][k])
        };
        if unit {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
            v = v.map(|c| c / l);
        }
        d.push(v);
    }
}

/// The cubic Hermite point at `x` on grid points `sig` (positions `q`,
/// unit tangents `t`).
pub(super) fn hermite(sig: &[f64], q: &[[f64; 3]], t: &[[f64; 3]], x: f64) -> [f64; 3] {
    let n = sig.len();
    let j = sig.partition_point(|y| *y <= x).clamp(1, n - 1) - 1;
    let h = sig[j + 1] - sig[j];
    let u = ((x - sig[j]) / h).clamp(0.0, 1.0);
    let (h00, h10) = (
        2.0 * u * u * u - 3.0 * u * u + 1.0,
        u * u * u - 2.0 * u * u + u,
    );
    let (h01, h11) = (-2.0 * u * u * u + 3.0 * u * u, u * u * u - u * u);
    xyz(|k| h00 * q[j][k] + h10 * h * t[j][k] + h01 * q[j + 1][k] + h11 * h * t[j + 1][k])
}
