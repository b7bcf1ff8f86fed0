//! The tool path of a recording as it grows: besides the whole path at
//! the end (`/cnc/toolpath` of up to [`TOOLPATH_MAX_POINTS`] points), both
//! recorders write the path *so far* every [`GROWING_EVERY_NS`] of
//! recording time ([`GrowingPath::due`]), thinned evenly to at most
//! [`GROWING_MAX_POINTS`] points and ending at the tool ([`thin`]), so a
//! viewer that shows the newest cloud at its cursor (Foxglove, Rerun's
//! MCAP loader, RViz with `ros2 bag play`) shows the path grow as the
//! timeline is scrubbed. The path so far is kept by [`LivePath`] (thinned
//! as it grows, however long the run), so the growing clouds of the first
//! minutes are the same whether the run is short or endless.
//!
//! For any length: after [`GROWING_STEPS`] seconds the interval grows
//! with the recording (1/[`GROWING_STEPS`] of the time so far), so an
//! hour holds about 1 500 growing clouds (≤ 90 MB before compression
//! against the setpoints' and joint states' gigabyte), ten hours about
//! 2 600.

use crate::convert::{push_point, TOOLPATH_MAX_POINTS};

/// A growing cloud at least this often (of the recording's time), ns.
pub const GROWING_EVERY_NS: u64 = 1_000_000_000;
/// The most points of a growing cloud.
pub const GROWING_MAX_POINTS: usize = 5_000;
/// After this many intervals the interval is this fraction of the time so
/// far.
pub const GROWING_STEPS: u64 = 500;

/// When the next growing cloud is due.
#[derive(Clone, Copy, Debug, Default)]
pub struct GrowingPath {
    start_ns: Option<u64>,
    next_ns: u64,
}

impl GrowingPath {
    /// Whether a growing cloud is due at the sample stamped `ns` (the
    /// first sample starts the clock; the first cloud is one interval
    /// later); when it is, the next is scheduled.
    pub fn due(&mut self, ns: u64) -> bool {
        let start = match self.start_ns {
            Some(s) => s,
            None => {
                self.start_ns = Some(ns);
                self.next_ns = ns.saturating_add(GROWING_EVERY_NS);
                return false;
            }
        };
        if ns < self.next_ns {
            return false;
        }
        let t = ns.saturating_sub(start);
        self.next_ns = ns.saturating_add(GROWING_EVERY_NS.max(t / GROWING_STEPS));
        true
    }
}

/// The cloud data of the path so far: the points of `data` (x, y, z
/// float32 each, as [`push_point`] writes them) thinned to every n-th so
/// that with `tool` (the newest position, m) at the end there are at most
/// `max` (≥ 2) points (`tool` is not repeated when the last point kept is
/// already there).
pub fn thin(data: &[u8], max: usize, tool: [f64; 3]) -> Vec<u8> {
    let n = data.len() / 12;
    let room = max.max(2) - 1;
    let step = n.div_ceil(room).max(1);
    let mut out = Vec::with_capacity((n.min(room) + 1) * 12);
    for i in (0..n).step_by(step) {
        out.extend_from_slice(&data[i * 12..i * 12 + 12]);
    }
    let mut end = Vec::with_capacity(12);
    push_point(&mut end, tool);
    if !out.ends_with(&end) {
        out.extend_from_slice(&end);
    }
    out
}

const _: () = assert!(GROWING_MAX_POINTS as u64 <= TOOLPATH_MAX_POINTS);

/// The tool path of a live job of unknown length, thinned as it grows:
/// setpoint k is kept when k is a multiple of the stride (1 at first); when
/// [`TOOLPATH_MAX_POINTS`] − 1 points are kept, every other one is dropped
/// and the stride doubles, so the cloud always spans the whole job with
/// evenly spaced samples (a 1 kHz job: every setpoint up to 100 s, every
/// 2nd up to 200 s, every 4th up to 400 s, ...), and the last setpoint
/// ends it ([`finish`](Self::finish)): at most [`TOOLPATH_MAX_POINTS`].
#[derive(Debug, Default)]
pub struct LivePath {
    /// x, y, z float32 per point (the cloud's data)
    data: Vec<u8>,
    /// log2 of the stride
    shift: u32,
    /// the last point seen, if it was not kept
    last: Option<[f64; 3]>,
}

impl LivePath {
    /// Setpoint number `k` (from 0) at `p` (m).
    pub fn push(&mut self, k: u64, p: [f64; 3]) {
        if k & ((1u64 << self.shift) - 1) != 0 {
            self.last = Some(p);
            return;
        }
        if self.len() as u64 >= TOOLPATH_MAX_POINTS - 1 {
            // keep points 0, 2, 4, ...: the multiples of the doubled stride
            let n = self.len();
            for (w, i) in (0..n).step_by(2).enumerate() {
                self.data.copy_within(i * 12..i * 12 + 12, w * 12);
            }
            self.data.truncate(n.div_ceil(2) * 12);
            self.shift += 1;
            if k & ((1u64 << self.shift) - 1) != 0 {
                self.last = Some(p);
                return;
            }
        }
        push_point(&mut self.data, p);
        self.last = None;
    }

    /// points kept so far
    pub fn len(&self) -> usize {
        self.data.len() / 12
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The path so far thinned to at most `max` points, ending at `tool`
    /// (the newest setpoint, m).
    pub fn so_far(&self, max: usize, tool: [f64; 3]) -> Vec<u8> {
        thin(&self.data, max, tool)
    }

    /// setpoints between two kept points
    pub fn stride(&self) -> u64 {
        1 << self.shift
    }

    /// The cloud's data: the kept points and the last setpoint.
    pub fn finish(mut self) -> Vec<u8> {
        if let Some(p) = self.last.take() {
            push_point(&mut self.data, p);
        }
        self.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_second_then_a_fraction_of_the_time_so_far() {
        let mut g = GrowingPath::default();
        let t0 = 1_700_000_000_000_000_000u64;
        let ms = 1_000_000u64;
        // 1 kHz for 2000 s
        let due: Vec<u64> = (0..2_000_000u64).filter(|k| g.due(t0 + k * ms)).collect();
        // every 1000 samples for the first 500 s
        assert_eq!(due[..5], [1000, 2000, 3000, 4000, 5000]);
        assert!(due.windows(2).take(498).all(|w| w[1] - w[0] == 1000));
        // then 1/500 of the time so far: 1500 s in about 500·ln 4 more
        let later = due.iter().filter(|&&k| k > 500_000).count();
        assert!((690..=700).contains(&later), "{later}");
        let last = &due[due.len() - 2..];
        assert!((3_980..=4_000).contains(&(last[1] - last[0])), "{last:?}");
    }

    fn xs(data: &[u8]) -> Vec<f32> {
        data.chunks(12)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn thinned_evenly_with_the_tool_at_the_end() {
        let mut data = Vec::new();
        for k in 0..12_345 {
            push_point(&mut data, [k as f64, 0.0, 0.0]);
        }
        let out = xs(&thin(&data, 5_000, [99_999.0, 0.0, 0.0]));
        assert!(out.len() <= 5_000, "{}", out.len());
        // every 3rd point (12 345 / 4 999 rounded up), then the tool
        assert_eq!(out.len(), 12_345usize.div_ceil(3) + 1);
        assert_eq!(out[..3], [0.0, 3.0, 6.0]);
        assert_eq!(*out.last().unwrap(), 99_999.0);
        // short paths keep every point
        let out = xs(&thin(&data[..120], 5_000, [7.0, 0.0, 0.0]));
        assert_eq!(out, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 7.0]);
        // nothing yet: the tool alone; the tool where the path ends: once
        assert_eq!(xs(&thin(&[], 5_000, [1.0, 2.0, 3.0])), [1.0]);
        assert_eq!(xs(&thin(&data[..24], 5_000, [1.0, 0.0, 0.0])), [0.0, 1.0]);
    }

    #[test]
    fn a_long_live_path_is_thinned_evenly_and_keeps_its_end() {
        // 250.5 s at 1 kHz: x = k / 1000 (m)
        let n = 250_500u64;
        let mut path = LivePath::default();
        for k in 0..n {
            path.push(k, [k as f64 / 1000.0, 0.0, 0.0]);
            assert!((path.len() as u64) < TOOLPATH_MAX_POINTS);
        }
        // 100 s, 200 s: the stride doubled twice
        assert_eq!(path.stride(), 4);
        let xs = xs(&path.finish());
        assert!(xs.len() as u64 <= TOOLPATH_MAX_POINTS);
        assert_eq!(xs.len() as u64, (n - 1) / 4 + 1 + 1);
        // the whole job: from the start, every 4th setpoint, and the last
        assert_eq!(xs[0], 0.0);
        assert!(xs
            .windows(2)
            .take(xs.len() - 2)
            .all(|w| (w[1] - w[0] - 0.004).abs() < 1e-4));
        assert_eq!(*xs.last().unwrap(), ((n - 1) as f64 / 1000.0) as f32);
    }

    #[test]
    fn a_short_live_path_keeps_every_setpoint() {
        let mut path = LivePath::default();
        for k in 0..1000 {
            path.push(k, [0.0, k as f64, 0.0]);
        }
        assert_eq!(path.stride(), 1);
        assert_eq!(path.finish().len(), 1000 * 12);
    }
}
