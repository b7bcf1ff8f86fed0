//! The range of the curvature's change over the path one sample may pass.
//!
//! An axis's jerk is `T σ + 3 K v a + K' v³`: checked at the samples
//! alone, a peak of `K'` between two of them (a blend's curvature ramp a
//! few tenths of a millimetre long, passed at 200 mm/s in two samples)
//! goes unseen, and the setpoints' third difference, a weighted mean of
//! the jerk over three samples, takes it in. So the planner bounds the
//! jerk with every `K'` of the stations from a sample's place to as far
//! as one sample at the axes' top speed reaches (`Path::set_window`):
//! each station's least and largest `K'` per axis over that window,
//! kept by sliding minima and maxima as the stations come.

use std::collections::VecDeque;

/// Least and largest `K'` per axis, 1/mm².
#[derive(Clone, Copy, Debug)]
pub struct Range {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

impl Range {
    /// One `K'` alone.
    pub fn of(kd: [f64; 3]) -> Range {
        Range { lo: kd, hi: kd }
    }
}

#[derive(Clone, Debug, Default)]
pub(super) struct Envelope {
    /// Stations after each one the window takes in.
    win: usize,
    /// The index of `done[0]`, and each station's range once its window
    /// has come.
    base: usize,
    done: VecDeque<Range>,
    /// Stations pushed so far.
    next: usize,
    /// Per axis, the candidates for the window's least and largest
    /// (index, value), values rising and falling.
    lo: [VecDeque<(usize, f64)>; 3],
    hi: [VecDeque<(usize, f64)>; 3],
}

impl Envelope {
    pub(super) fn new(win: usize) -> Envelope {
        Envelope {
            win,
            ..Envelope::default()
        }
    }

    /// The next station's `K'`.
    pub(super) fn push(&mut self, kd: [f64; 3]) {
        let j = self.next;
        self.next += 1;
        for (c, x) in kd.into_iter().enumerate() {
            let lo = &mut self.lo[c];
            while lo.back().is_some_and(|b| b.1 >= x) {
                lo.pop_back();
            }
            lo.push_back((j, x));
            let hi = &mut self.hi[c];
            while hi.back().is_some_and(|b| b.1 <= x) {
                hi.pop_back();
            }
            hi.push_back((j, x));
        }
        if j >= self.win {
            self.close(j - self.win);
        }
    }

    /// No more stations: the last windows end at the run's end.
    pub(super) fn finish(&mut self) {
        while self.base + self.done.len() < self.next {
            self.close(self.base + self.done.len());
        }
    }

    /// Station `i`'s window is all there (it is the next to close).
    fn close(&mut self, i: usize) {
        let first = |side: &mut VecDeque<(usize, f64)>| {
            while side.front().is_some_and(|f| f.0 < i) {
                side.pop_front();
            }
            side.front().map_or(0.0, |f| f.1)
        };
        let lo = self.lo.each_mut().map(first);
        let hi = self.hi.each_mut().map(first);
        self.done.push_back(Range { lo, hi });
    }

    /// Station `i`'s range, once its window has come.
    pub(super) fn get(&self, i: usize) -> Option<Range> {
        i.checked_sub(self.base)
            .and_then(|k| self.done.get(k))
            .copied()
    }

    /// Forgets the ranges of the stations before `base`.
    pub(super) fn forget_before(&mut self, base: usize) {
        while self.base < base && !self.done.is_empty() {
            self.done.pop_front();
            self.base += 1;
        }
    }

    /// How many stations after one its window takes in.
    pub(super) fn window(&self) -> usize {
        self.win
    }
}
