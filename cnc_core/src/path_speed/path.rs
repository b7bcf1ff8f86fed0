//! The path the speed stage plans on: stations a fixed arc length apart,
//! given all at once (`Path::new`) or as they come (`Path::open`, `push`,
//! `finish`), the ones behind forgotten (`forget_before`), so that a run
//! of any length takes the memory of a look-ahead.

use super::envelope::{Envelope, Range};
use std::collections::VecDeque;

/// The path's shape at one station.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Station {
    /// Unit tangent.
    pub t: [f64; 3],
    /// `dT/ds`, 1/mm.
    pub k: [f64; 3],
    /// `d²T/ds²`, 1/mm².
    pub kd: [f64; 3],
    /// Programmed feed, mm/s.
    pub feed: f64,
}

/// Why a path or a run was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum SpeedError {
    /// The stations do not describe a path (fewer than two, a spacing or
    /// length that is not positive and finite, the last station not
    /// within one spacing of the one before, a value not finite, a
    /// station after the end).
    BadPath(String),
    /// A limit is not positive and finite.
    BadLimits,
    /// The run did not end within `ticks` samples.
    NoEnd { ticks: usize, s: f64 },
    /// At `s` no path jerk keeps every axis within its limits: the
    /// curvature's terms alone are over (a path sharper than its stations
    /// let the planner see).
    Stuck { s: f64, v: f64 },
}

impl std::fmt::Display for SpeedError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SpeedError::BadPath(why) => write!(f, "path: {why}"),
            SpeedError::BadLimits => write!(f, "every axis limit must be positive and finite"),
            SpeedError::Stuck { s, v } => write!(
                f,
                "at {s:.6} mm ({v:.3} mm/s) no jerk keeps every axis within its limits"
            ),
            SpeedError::NoEnd { ticks, s } => write!(
                f,
                "the run did not reach its end in {ticks} samples (it is at {s:.6} mm)"
            ),
        }
    }
}

impl std::error::Error for SpeedError {}

fn bad<T>(why: &str) -> Result<T, SpeedError> {
    Err(SpeedError::BadPath(why.to_string()))
}

/// A run from rest to rest: station `i` at `s = i h`, the last at the
/// run's end `len` (at most `h` after the one before).
#[derive(Clone, Debug)]
pub struct Path {
    pub(super) h: f64,
    /// The run's end once it is known (`finish`), else 0.
    pub(super) len: f64,
    pub(super) finished: bool,
    /// The index of `st[0]` (the stations before are forgotten).
    pub(super) base: usize,
    pub(super) st: VecDeque<Station>,
    /// Each station's range of `K'` over the path a sample from it may
    /// pass (`set_window`; without one, its own).
    env: Envelope,
}

impl Path {
    /// A whole run.
    pub fn new(h: f64, len: f64, st: Vec<Station>) -> Result<Path, SpeedError> {
        let mut p = Path::open(h)?;
        for s in st {
            p.push(s)?;
        }
        p.finish(len)?;
        Ok(p)
    }

    /// A run whose stations will come with `push`.
    pub fn open(h: f64) -> Result<Path, SpeedError> {
        if !(h > 0.0 && h.is_finite()) {
            return bad("spacing and length must be positive and finite");
        }
        Ok(Path {
            h,
            len: 0.0,
            finished: false,
            base: 0,
            st: VecDeque::new(),
            env: Envelope::new(0),
        })
    }

    /// The next station.
    pub fn push(&mut self, p: Station) -> Result<(), SpeedError> {
        if self.finished {
            return bad("a station after the run's end");
        }
        let finite = |x: &[f64; 3]| x.iter().all(|c| c.is_finite());
        if !(finite(&p.t) && finite(&p.k) && finite(&p.kd)) {
            return bad("a station's shape is not finite");
        }
        if p.feed.is_nan() || p.feed <= 0.0 {
            return bad("a station's feed is not positive");
        }
        self.st.push_back(p);
        self.env.push(p.kd);
        Ok(())
    }

    /// The run ends at `len`: the last station's place.
    pub fn finish(&mut self, len: f64) -> Result<(), SpeedError> {
        let n = self.count();
        if n < 2 {
            return bad("fewer than two stations");
        }
        if !(len > 0.0 && len.is_finite()) {
            return bad("spacing and length must be positive and finite");
        }
        let before = (n - 2) as f64 * self.h;
        if !(len > before && len <= before + self.h * (1.0 + 1e-9)) {
            return bad("the last station is not within one spacing of the one before");
        }
        self.len = len;
        self.finished = true;
        self.env.finish();
        Ok(())
    }

    /// The run's length once it is known.
    pub fn len(&self) -> Option<f64> {
        self.finished.then_some(self.len)
    }

    /// How many stations there have been, forgotten ones included.
    pub(super) fn count(&self) -> usize {
        self.base + self.st.len()
    }

    /// How many stations are kept.
    pub fn kept(&self) -> usize {
        self.st.len()
    }

    /// Where station `i` is.
    pub(super) fn place(&self, i: usize) -> f64 {
        if self.finished && i + 1 == self.count() {
            self.len
        } else {
            i as f64 * self.h
        }
    }

    /// How far the known stations reach.
    pub fn known(&self) -> f64 {
        match self.count() {
            0 => 0.0,
            n => self.place(n - 1),
        }
    }

    /// Forgets the stations the path before `s` no longer needs (all but
    /// the one `s` is after, and the one before that).
    pub fn forget_before(&mut self, s: f64) -> usize {
        let keep_from = ((s / self.h) as usize).saturating_sub(1);
        let mut gone = 0;
        while self.base < keep_from && self.st.len() > 2 {
            self.st.pop_front();
            self.base += 1;
            gone += 1;
        }
        self.env.forget_before(self.base);
        gone
    }

    /// Each station's range of `K'` takes in the `win` stations after
    /// it (before the first station is pushed).
    pub(super) fn set_window(&mut self, win: usize) {
        if self.st.is_empty() && self.base == 0 {
            self.env = Envelope::new(win);
        }
    }

    /// How many stations after the one a place is in its range of `K'`
    /// needs.
    pub(super) fn window(&self) -> usize {
        self.env.window()
    }

    /// The range of `K'` over the path a sample from `s` may pass: that
    /// of the station before `s` (its window takes in the rest), once its
    /// window has come.
    pub(super) fn kd_range(&self, s: f64) -> Option<Range> {
        let n = self.count();
        let i = ((s.max(0.0) / self.h) as usize).clamp(self.base, n.max(2) - 2);
        self.env.get(i)
    }

    /// Station `i` (kept).
    pub(super) fn station(&self, i: usize) -> &Station {
        &self.st[i - self.base]
    }

    /// The shape at `s` (clamped to the kept stations), interpolated;
    /// `None` before there are two stations.
    pub fn shape_at(&self, s: f64) -> Option<Station> {
        (self.count() >= 2).then(|| self.at(s))
    }

    /// `shape_at` where there are two stations or more.
    pub(super) fn at(&self, s: f64) -> Station {
        let n = self.count();
        let i = ((s.max(0.0) / self.h) as usize).clamp(self.base, n - 2);
        let (s0, s1) = (self.place(i), self.place(i + 1));
        let f = ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
        let (p, q) = (self.station(i), self.station(i + 1));
        let mix = |x: &[f64; 3], y: &[f64; 3]| [0, 1, 2].map(|k| x[k] + f * (y[k] - x[k]));
        Station {
            t: mix(&p.t, &q.t),
            k: mix(&p.k, &q.k),
            kd: mix(&p.kd, &q.kd),
            feed: p.feed + f * (q.feed - p.feed),
        }
    }
}
