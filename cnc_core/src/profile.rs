//! The trapezoidal (or triangular) speed profile of one move: how far
//! along it and how fast the planned path is at any time. The planner
//! (`plan`) chooses each move's entry and exit speeds; this is what lies
//! between them.

/// A trapezoidal (or triangular) speed profile over one move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    pub v0: f64,
    pub vp: f64,
    pub v1: f64,
    pub a: f64,
    pub length: f64,
    pub t_acc: f64,
    pub t_cruise: f64,
    pub t_dec: f64,
    pub d_acc: f64,
    pub d_cruise: f64,
    /// total time, s
    pub duration: f64,
    /// fastest speed the move's geometry allows at any feed, with its
    /// acceleration `a` (what a feed override over 100 % may reach)
    pub vlim: f64,
    /// the smallest path acceleration of this move and the moves it joins
    /// without a stop: what a change of the feed scale may use in a
    /// sample step that reaches across a junction
    pub a_join: f64,
    /// a line's or an arc's own path filter length, samples
    /// ([`MoveLimits::own_m`](crate::limits::MoveLimits::own_m)): run
    /// from rest to rest, the line is filtered with it alone (no XYZ
    /// filter), starts a tick late and the hold after it is `own_m`
    /// ([`crate::timeline::Timeline::move_time`]); 0: the machine's
    /// filters
    pub own_m: u32,
}

impl Profile {
    /// Fastest profile from `v0` to `v1` over `length` with acceleration
    /// `a` and speed cap `vcap` (`v0, v1 <= vcap`, `|v1²-v0²| <= 2 a length`).
    #[inline]
    pub fn new(v0: f64, v1: f64, vcap: f64, a: f64, length: f64) -> Profile {
        let peak = ((2.0 * a * length + v0 * v0 + v1 * v1) * 0.5).sqrt();
        let vp = peak.min(vcap).max(v0).max(v1);
        let d_acc = ((vp * vp - v0 * v0) / (2.0 * a)).max(0.0);
        let t_acc = (vp - v0) / a;
        // (from rest to rest, say: the same speeds, the same ramps)
        let same = v1.to_bits() == v0.to_bits();
        let d_dec = if same {
            d_acc
        } else {
            ((vp * vp - v1 * v1) / (2.0 * a)).max(0.0)
        };
        let d_cruise = (length - d_acc - d_dec).max(0.0);
        let t_dec = if same { t_acc } else { (vp - v1) / a };
        let t_cruise = if vp > 0.0 { d_cruise / vp } else { 0.0 };
        Profile {
            v0,
            vp,
            v1,
            a,
            length,
            t_acc,
            t_cruise,
            t_dec,
            d_acc,
            d_cruise,
            duration: t_acc + t_cruise + t_dec,
            vlim: vcap,
            a_join: a,
            own_m: 0,
        }
    }

    /// The length of the path filter this move runs with on its own, if
    /// it does: a line or an arc from rest to rest under the path filter.
    #[inline]
    pub fn own_filter(&self) -> Option<u32> {
        (self.own_m > 0 && self.v0 == 0.0 && self.v1 == 0.0).then_some(self.own_m)
    }

    /// Distance along the move at time `t` after its start.
    pub fn s_at(&self, t: f64) -> f64 {
        if t <= 0.0 {
            return 0.0;
        }
        if t >= self.duration {
            return self.length;
        }
        let s = if t < self.t_acc {
            self.v0 * t + 0.5 * self.a * t * t
        } else if t < self.t_acc + self.t_cruise {
            self.d_acc + self.vp * (t - self.t_acc)
        } else {
            let u = t - self.t_acc - self.t_cruise;
            self.d_acc + self.d_cruise + self.vp * u - 0.5 * self.a * u * u
        };
        s.min(self.length)
    }

    /// Path speed at time `t`.
    pub fn v_at(&self, t: f64) -> f64 {
        if t <= 0.0 {
            self.v0
        } else if t < self.t_acc {
            self.v0 + self.a * t
        } else if t < self.t_acc + self.t_cruise {
            self.vp
        } else if t < self.duration {
            self.vp - self.a * (t - self.t_acc - self.t_cruise)
        } else {
            self.v1
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_shapes() {
        // trapezoid: 0 -> 100 mm/s at 1000 mm/s², 100 mm
        let p = Profile::new(0.0, 0.0, 100.0, 1000.0, 100.0);
        assert!((p.t_acc - 0.1).abs() < 1e-12 && (p.d_acc - 5.0).abs() < 1e-12);
        assert!((p.duration - (0.2 + 0.9)).abs() < 1e-12);
        assert!((p.s_at(0.05) - 1.25).abs() < 1e-12);
        assert_eq!(p.s_at(2.0), 100.0);
        // triangle: 10 mm, cap not reached: peak sqrt(a*L) = 100
        let p = Profile::new(0.0, 0.0, 1000.0, 1000.0, 10.0);
        assert!((p.vp - 100.0).abs() < 1e-9 && p.t_cruise.abs() < 1e-9);
        // entry and exit speeds
        let p = Profile::new(50.0, 20.0, 100.0, 1000.0, 30.0);
        assert!((p.v_at(0.0) - 50.0).abs() < 1e-12 && (p.v_at(p.duration) - 20.0).abs() < 1e-12);
        assert!((p.s_at(p.duration - 1e-12) - 30.0).abs() < 1e-6);
    }

    #[test]
    fn equal_speeds_share_their_ramps_bit_for_bit() {
        // the profile as computed before equal entry and exit speeds
        // shared their ramps
        let reference = |v0: f64, v1: f64, vcap: f64, a: f64, length: f64| {
            let peak = ((2.0 * a * length + v0 * v0 + v1 * v1) * 0.5).sqrt();
            let vp = peak.min(vcap).max(v0).max(v1);
            let d_acc = ((vp * vp - v0 * v0) / (2.0 * a)).max(0.0);
            let d_dec = ((vp * vp - v1 * v1) / (2.0 * a)).max(0.0);
            let d_cruise = (length - d_acc - d_dec).max(0.0);
            let t_acc = (vp - v0) / a;
            let t_dec = (vp - v1) / a;
            let t_cruise = if vp > 0.0 { d_cruise / vp } else { 0.0 };
            [
                t_acc,
                t_cruise,
                t_dec,
                d_acc,
                d_cruise,
                t_acc + t_cruise + t_dec,
            ]
        };
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || (crate::xorshift64(&mut x) >> 11) as f64 / (1u64 << 53) as f64;
        for k in 0..50_000 {
            let (vcap, a, length) = (next() * 300.0, 10.0 + next() * 3000.0, next() * 20.0);
            let v0 = [0.0, -0.0, next() * vcap][k % 3];
            let v1 = if k % 2 == 0 { v0 } else { next() * vcap };
            let p = Profile::new(v0, v1, vcap, a, length);
            let got = [
                p.t_acc, p.t_cruise, p.t_dec, p.d_acc, p.d_cruise, p.duration,
            ];
            let want = reference(v0, v1, vcap, a, length);
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{v0} {v1}");
        }
    }
}
