//! Thinning long streams of points to a bounded number ([`Decimator`]),
//! so that a long run does not grow memory or the file.

/// Most points of one series of [`plot_program`](super::plot_program) and
/// [`plot_recording`](super::plot_recording).
pub const MAX_SERIES_POINTS: usize = 20_000;

/// Thins a stream of points to at most `max` kept points (plus the last
/// of each run), with bounded memory: every `stride`-th point is kept, and
/// when more than `max` are kept every other one is dropped and the stride
/// doubles. Points carry a tag; a change of tag starts a new run (a new
/// polyline) that begins at the previous run's last point, so runs join.
#[derive(Clone, Debug)]
pub struct Decimator<T> {
    max: usize,
    stride: u64,
    count: u64,
    kept: usize,
    runs: Vec<(u8, Vec<T>)>,
    /// the newest point of the current run if it was not kept
    pending: Option<T>,
}

impl<T: Copy> Decimator<T> {
    pub fn new(max: usize) -> Self {
        Decimator {
            max: max.max(4),
            stride: 1,
            count: 0,
            kept: 0,
            runs: Vec::new(),
            pending: None,
        }
    }

    pub fn push(&mut self, tag: u8, p: T) {
        let new_run = self.runs.last().is_none_or(|r| r.0 != tag);
        if new_run {
            let join = self.close_run();
            let mut v = Vec::with_capacity(16);
            v.extend(join);
            v.push(p);
            self.kept += v.len();
            self.runs.push((tag, v));
            self.count = 0;
        } else {
            self.count += 1;
            if self.count.is_multiple_of(self.stride) {
                self.pending = None;
                if let Some(r) = self.runs.last_mut() {
                    r.1.push(p);
                }
                self.kept += 1;
            } else {
                self.pending = Some(p);
            }
        }
        if self.kept > self.max && self.stride < 1 << 40 {
            self.thin();
        }
    }

    /// Ends the current run (keeping its newest point); its last point.
    fn close_run(&mut self) -> Option<T> {
        let r = self.runs.last_mut()?;
        if let Some(p) = self.pending.take() {
            r.1.push(p);
            self.kept += 1;
        }
        r.1.last().copied()
    }

    fn thin(&mut self) {
        let mut kept = 0;
        for (_, v) in &mut self.runs {
            let n = v.len();
            if n > 2 {
                let last = v[n - 1];
                let mut i = 0;
                v.retain(|_| {
                    i += 1;
                    (i - 1) % 2 == 0
                });
                if n % 2 == 0 {
                    v.push(last); // the last was an odd index: keep it
                }
            }
            kept += v.len();
        }
        self.kept = kept;
        self.stride *= 2;
    }

    /// The runs: `(tag, points)` in order.
    pub fn finish(mut self) -> Vec<(u8, Vec<T>)> {
        self.close_run();
        self.runs
    }
}

/// The points of all runs, in order.
pub(crate) fn one_run<T: Copy>(d: Decimator<T>) -> Vec<T> {
    d.finish().into_iter().flat_map(|(_, v)| v).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimator_bounds_points_and_keeps_ends() {
        let mut d = Decimator::new(100);
        for i in 0..100_000u32 {
            d.push(0, i);
        }
        let runs = d.finish();
        assert_eq!(runs.len(), 1);
        let v = &runs[0].1;
        assert!(v.len() <= 101 && v.len() >= 50, "{}", v.len());
        assert_eq!(v[0], 0);
        assert_eq!(*v.last().unwrap(), 99_999);
        assert!(v.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn decimator_runs_join() {
        let mut d = Decimator::new(1000);
        for i in 0..10 {
            d.push(if i < 5 { 1 } else { 0 }, i);
        }
        let runs = d.finish();
        assert_eq!(
            runs,
            vec![(1, vec![0, 1, 2, 3, 4]), (0, vec![4, 5, 6, 7, 8, 9])]
        );
    }
}
