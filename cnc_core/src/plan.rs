//! The motion planner: a look-ahead queue in the manner of Klipper. Each
//! move gets a trapezoidal speed profile whose entry and exit speeds respect
//! the axis limits, the junction with its neighbours and the need to stop at
//! the end of what is known so far. Tangent and nearly tangent junctions are
//! passed at speed; sharper corners stop exactly.
//!
//! Limits are honoured at every *sample*, not only in continuous time: a
//! junction with a small direction change (a kink) makes each axis's
//! velocity jump, and the sampled acceleration of that jump is Δv/dt. The
//! planner therefore reserves [`KINK_SHARE`](crate::shares::KINK_SHARE) of every axis's acceleration
//! for such jumps in the two moves that meet at a kink, and plans their
//! path acceleration with the rest ([`LINE_SHARE`](crate::shares::LINE_SHARE)). A move whose
//! junctions are both tangent or stops has no jump to make room for and
//! uses the whole acceleration. A queue's tail does not know its next
//! junction yet; it is planned with the smaller share and raised when the
//! next move shows the junction to be smooth (raising an acceleration
//! only ever raises the entry speeds already handed out).

use crate::canon::ThreadMove;
use crate::canon::{Event, Feed, Src};
use crate::geom::V3;
use crate::geom::{ceil, Geom};
pub use crate::limits::PlanLimits;
use crate::limits::{MoveLimits, MovePrep};
use std::collections::VecDeque;

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
        }
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

/// A move with its profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedMove {
    pub geom: Geom,
    pub feed: Feed,
    pub src: Src,
    pub profile: Profile,
}

/// What the planner hands on, in order.
// Moves are nearly all items: boxing them would allocate for each.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Item {
    Move(PlannedMove),
    Dwell {
        seconds: f64,
        src: Src,
    },
    Spindle {
        rpm: f64,
        src: Src,
    },
    Tool {
        number: u32,
        src: Src,
    },
    /// a G33 block: from rest (or from the thread block before it)
    Thread(ThreadMove),
    End {
        src: Src,
    },
}

#[derive(Clone, Copy, Debug)]
struct QSeg<K> {
    /// what the sink keeps of the move
    kept: K,
    /// unit tangent at the end (for the junction with the next move)
    t_end: V3,
    length: f64,
    /// the limits in force ([`LINE_SHARE`](crate::shares::LINE_SHARE) until both junctions are known
    /// to be smooth)
    lim: MoveLimits,
    /// √(2·a·length) with `lim` (the speed from which it stops)
    stop: f64,
    /// the limits with the whole acceleration and their `stop`, while they
    /// may still be taken (the entry junction is smooth, the exit one not
    /// yet known)
    full: Option<(MoveLimits, f64)>,
    /// largest entry speed the junction allows
    j: f64,
    /// what `j` becomes if the move takes its `full` limits
    j_max: f64,
    /// largest entry speed from which the rest of the queue can stop
    entry_b: f64,
}

impl<K> QSeg<K> {
    /// Largest entry speed from which the move can stop at its end.
    fn entry_to_stop(&self) -> f64 {
        self.j.min(self.stop)
    }
}

/// Where the look-ahead hands its finished items, and what its queue keeps
/// of each move until the move's profile is final: the executor needs the
/// whole move, the check only the profile.
pub(crate) trait ItemSink {
    /// What the queue keeps of a move.
    type Kept: Copy;
    /// Whether the profiles' [`Profile::vlim`] is wanted (it is computed
    /// only then).
    const VLIM: bool = true;
    fn keep(geom: &Geom, feed: Feed, src: Src) -> Self::Kept;
    /// A move, with its final profile.
    fn planned(&mut self, kept: Self::Kept, profile: Profile);
    /// A move whose profile is final: from `v0` to `v1` with limits `lim`
    /// over `length`, `a_join` its [`Profile::a_join`]. (A sink may put
    /// off computing the profile; the items stay in order.)
    #[inline]
    fn plan(
        &mut self,
        kept: Self::Kept,
        v0: f64,
        v1: f64,
        lim: MoveLimits,
        length: f64,
        a_join: f64,
    ) {
        let mut profile = Profile::new(v0, v1, lim.vcap, lim.a, length);
        profile.vlim = lim.vlim;
        profile.a_join = a_join;
        self.planned(kept, profile);
    }
    /// Any other item.
    fn item(&mut self, item: Item);
}

impl ItemSink for VecDeque<Item> {
    type Kept = (Geom, Feed, Src);
    #[inline]
    fn keep(geom: &Geom, feed: Feed, src: Src) -> Self::Kept {
        (*geom, feed, src)
    }
    #[inline]
    fn planned(&mut self, (geom, feed, src): Self::Kept, profile: Profile) {
        self.push_back(Item::Move(PlannedMove {
            geom,
            feed,
            src,
            profile,
        }));
    }
    #[inline]
    fn item(&mut self, item: Item) {
        self.push_back(item);
    }
}

/// The look-ahead queue proper; finished items go to a sink passed in, so
/// the check can consume them in place. `K`: what the sink keeps of a move.
#[derive(Debug)]
pub(crate) struct Lookahead<K> {
    lim: PlanLimits,
    queue: VecDeque<QSeg<K>>,
    /// fixed entry speed of the queue's head
    v_head: f64,
    /// path acceleration of the move before the head, if it joins the
    /// head without a stop (else ∞)
    a_before: f64,
}

impl<K: Copy> Lookahead<K> {
    pub(crate) fn new(lim: PlanLimits) -> Self {
        Lookahead {
            lim,
            queue: VecDeque::with_capacity(lim.lookahead + 2),
            v_head: 0.0,
            a_before: f64::INFINITY,
        }
    }

    /// Feeds one event in. `prep`: what [`PlanLimits::prepare`] makes of
    /// the move, if the caller has it already (the check computes it on
    /// another thread).
    #[inline]
    pub(crate) fn push<O: ItemSink<Kept = K>>(
        &mut self,
        ev: &Event,
        prep: Option<&MovePrep>,
        out: &mut O,
    ) {
        match *ev {
            Event::Move {
                ref geom,
                feed,
                src,
            } => match prep {
                Some(p) => self.push_move(geom, p, feed, src, out),
                None => {
                    let prep = self.lim.prepare(geom, &feed, O::VLIM);
                    self.push_move(geom, &prep, feed, src, out)
                }
            },
            Event::Dwell { seconds, src } => {
                self.flush(out);
                out.item(Item::Dwell { seconds, src });
            }
            Event::Spindle { rpm, src } => {
                self.flush(out);
                out.item(Item::Spindle { rpm, src });
            }
            Event::Tool { number, src } => {
                self.flush(out);
                out.item(Item::Tool { number, src });
            }
            Event::Thread(m) => {
                self.flush(out);
                out.item(Item::Thread(m));
            }
            Event::End { src } => {
                self.flush(out);
                out.item(Item::End { src });
            }
        }
    }

    #[inline]
    fn push_move<O: ItemSink<Kept = K>>(
        &mut self,
        geom: &Geom,
        prep: &MovePrep,
        feed: Feed,
        src: Src,
        out: &mut O,
    ) {
        let length = prep.length;
        if length <= 0.0 {
            return;
        }
        let red = prep.red;
        let t2 = prep.t_start;
        // the entry junction; a smooth one lets the move before take its
        // whole acceleration (its exit is now known) and this one keep the
        // chance of it
        let (j_kink, kink) = match self.queue.back() {
            Some(prev) => self.lim.junction(&prev.t_end, &t2),
            None => (self.v_head, false),
        };
        if !kink {
            self.upgrade_tail();
        } else if let Some(prev) = self.queue.back_mut() {
            // a kink: the move before keeps its share for good
            prev.full = None;
            prev.j_max = prev.j;
        }
        let full = (!kink).then_some((prep.full, prep.stop[1]));
        let (j, j_max) = match self.queue.back() {
            Some(prev) => {
                let j = j_kink.min(prev.lim.vcap);
                (j.min(red.vcap), j.min(full.map_or(red.vcap, |f| f.0.vcap)))
            }
            None => (self.v_head, self.v_head),
        };
        let t_end = prep.t_end;
        let mut seg = QSeg {
            kept: O::keep(geom, feed, src),
            t_end,
            length,
            lim: red,
            stop: prep.stop[0],
            full,
            j,
            j_max,
            entry_b: 0.0,
        };
        seg.entry_b = seg.entry_to_stop();
        self.queue.push_back(seg);
        self.backward_pass(self.queue.len() - 1);
        self.commit(false, out);
    }

    /// The queue's tail takes its whole acceleration (its exit junction is
    /// smooth or a stop), if its entry allows; its entry limits rise.
    fn upgrade_tail(&mut self) {
        let n = self.queue.len();
        let Some(t) = self.queue.back_mut() else {
            return;
        };
        let Some((full, stop)) = t.full.take() else {
            return;
        };
        t.lim = full;
        t.stop = stop;
        t.j = t.j_max;
        t.entry_b = t.entry_to_stop();
        // (the tail's own entry_b; the pass takes it from here)
        self.backward_pass(n - 1);
    }

    /// Raises the entry limits before segment `from` that it relaxes, from
    /// its own `entry_b` backwards. The tail stops at its end.
    fn backward_pass(&mut self, from: usize) {
        for k in (0..from).rev() {
            let next_b = self.queue[k + 1].entry_b;
            let s = &mut self.queue[k];
            // (at or under its junction's speed it has nothing to gain;
            // from rest, √(2·a·length) is its stopping speed)
            if s.j <= s.entry_b {
                break;
            }
            let nb = s.j.min(if next_b == 0.0 {
                s.stop
            } else {
                (next_b * next_b + 2.0 * s.lim.a * s.length).sqrt()
            });
            if nb <= s.entry_b {
                break;
            }
            s.entry_b = nb;
        }
    }

    /// Commits every head whose exit speed can no longer change.
    fn commit(&mut self, all: bool, out: &mut impl ItemSink<Kept = K>) {
        while let Some(h) = self.queue.front() {
            let v1 = match self.queue.get(1) {
                Some(nx) => {
                    // (only here: a lone head waits without it)
                    // (from rest: the move's stopping speed, √(2·a·length))
                    let reach = if self.v_head == 0.0 {
                        h.stop
                    } else {
                        (self.v_head * self.v_head + 2.0 * h.lim.a * h.length).sqrt()
                    };
                    // (final unless the next move may still take its whole
                    // acceleration and with it a faster entry)
                    let final_exit = nx.entry_b >= nx.j_max || reach <= nx.entry_b;
                    if !(all || final_exit || self.queue.len() > self.lim.lookahead) {
                        return;
                    }
                    nx.entry_b.min(reach)
                }
                None if all => 0.0,
                None => return,
            };
            let lim = h.lim;
            // (the next move's acceleration may still rise, never fall)
            let a_after = match self.queue.get(1) {
                Some(nx) if v1 > 0.0 => nx.lim.a,
                _ => f64::INFINITY,
            };
            let a_join = lim.a.min(a_after).min(if self.v_head > 0.0 {
                self.a_before
            } else {
                f64::INFINITY
            });
            out.plan(h.kept, self.v_head, v1, lim, h.length, a_join);
            self.a_before = lim.a;
            self.v_head = v1;
            self.queue.pop_front();
        }
        if all {
            self.v_head = 0.0;
        }
    }

    /// Plans everything queued to a stop.
    pub(crate) fn flush(&mut self, out: &mut impl ItemSink<Kept = K>) {
        // the tail's exit is a stop: smooth
        self.upgrade_tail();
        self.commit(true, out);
    }
}

/// The look-ahead queue.
pub struct Planner {
    look: Lookahead<(Geom, Feed, Src)>,
    out: VecDeque<Item>,
}

impl Planner {
    pub fn new(lim: PlanLimits) -> Self {
        Planner {
            look: Lookahead::new(lim),
            out: VecDeque::with_capacity(16),
        }
    }

    /// Feeds one event in.
    pub fn push(&mut self, ev: Event) {
        self.look.push(&ev, None, &mut self.out);
    }

    /// Takes the next finished item.
    pub fn pop(&mut self) -> Option<Item> {
        self.out.pop_front()
    }

    /// Plans everything queued to a stop.
    pub fn flush(&mut self) {
        self.look.flush(&mut self.out);
    }
}

/// Turns planned items into whole sample ticks. Motion that runs without a
/// stop forms a group; every group and dwell starts on a sample tick, so a
/// stop is sampled exactly at its end point. The executor and the check use
/// this same type, so the estimated cycle time equals the simulated one.
#[derive(Clone, Copy, Debug)]
pub struct Timeline {
    pub dt: f64,
    /// tick at which the current group started
    pub group_k0: u64,
    /// time from the group start to the start of the current move, s
    pub seg_t0: f64,
    /// the ideal spindle (turning exactly as commanded): rpm, and its
    /// angle in revolutions at tick `spin_k`
    pub spin_rpm: f64,
    pub spin_k: f64,
    pub spin_rev: f64,
    /// θ₀ of the thread block being run (revolutions, in the direction of
    /// rotation)
    pub theta0: f64,
    /// ticks the setpoints hold still after each stop, so that the jerk
    /// filter settles on the stop point (M − 1 for an M-sample filter)
    pub hold: u64,
}

impl Timeline {
    pub fn new(dt: f64) -> Self {
        Timeline {
            dt,
            group_k0: 0,
            seg_t0: 0.0,
            spin_rpm: 0.0,
            spin_k: 0.0,
            spin_rev: 0.0,
            theta0: 0.0,
            hold: 0,
        }
    }

    /// The timeline of a planner with these limits (with its stop holds).
    pub fn for_limits(lim: &PlanLimits) -> Self {
        Timeline {
            hold: lim.smooth.saturating_sub(1) as u64,
            ..Timeline::new(lim.dt)
        }
    }

    /// Whole ticks covering `seconds` (a hair of rounding is forgiven).
    #[inline]
    pub fn ticks(&self, seconds: f64) -> u64 {
        let t = ceil(seconds / self.dt - 1e-9);
        if t > 0.0 {
            t as u64
        } else {
            0
        }
    }

    /// For a move that ends at rest: the tick of its end (the next group's start).
    pub fn stop_tick(&self, m: &PlannedMove) -> Option<u64> {
        (m.profile.v1 == 0.0).then(|| self.group_k0 + self.ticks(self.seg_t0 + m.profile.duration))
    }

    /// Time of (virtual) tick `k` relative to the start of the current move;
    /// `k` is the tick index unless the executor scales the feed.
    pub fn local_time(&self, k: f64) -> f64 {
        (k - self.group_k0 as f64) * self.dt - self.seg_t0
    }

    /// Advances past a finished move.
    pub fn finish_move(&mut self, m: &PlannedMove) {
        self.finish_profile(&m.profile);
    }

    /// Advances past a finished move with profile `p`.
    #[inline]
    pub(crate) fn finish_profile(&mut self, p: &Profile) {
        // as `stop_tick`, then the hold
        if p.v1 == 0.0 {
            self.group_k0 += self.ticks(self.seg_t0 + p.duration) + self.hold;
            self.seg_t0 = 0.0;
        } else {
            self.seg_t0 += p.duration;
        }
    }

    /// The ideal spindle's angle at (virtual) tick `k`, revolutions.
    pub fn ideal_rev(&self, k: f64) -> f64 {
        self.spin_rev + self.spin_rpm / 60.0 * (k - self.spin_k) * self.dt
    }

    /// A spindle command at the current group tick (everything stopped).
    pub fn set_spindle(&mut self, rpm: f64) {
        let k = self.group_k0 as f64;
        self.spin_rev = self.ideal_rev(k);
        self.spin_k = k;
        self.spin_rpm = rpm;
    }

    /// θ₀ of thread block `m`: for a chain's first block, synchronized
    /// from the angle `now` with the index at `index`; otherwise where the
    /// block before ended on the thread line.
    pub fn thread_begin(&mut self, m: &ThreadMove, now: f64, index: f64) -> f64 {
        if m.runin.is_some() {
            self.theta0 = m.sync_angle(now, index);
        }
        self.theta0
    }

    /// After a thread block that is not the last of its chain.
    pub fn thread_next(&mut self, m: &ThreadMove) {
        self.theta0 += m.seg.len / m.seg.pitch;
    }

    /// With the ideal spindle: the tick at which the chain whose last block
    /// is `m` (θ₀ = `self.theta0`) ends at rest, the chain having started at
    /// the group tick.
    pub fn ideal_thread_end(&self, m: &ThreadMove) -> u64 {
        let dir = m.dir();
        let speed = dir * self.spin_rpm / 60.0 * self.dt; // rev per tick
        if speed <= 0.0 {
            return self.group_k0;
        }
        let now = dir * self.ideal_rev(self.group_k0 as f64);
        self.group_k0 + self.ticks((self.theta0 + m.end_x() - now) / speed * self.dt)
    }

    /// A group (a thread chain) ended at rest at tick `k`; the next starts
    /// after the hold.
    pub fn finish_group_at(&mut self, k: u64) {
        self.group_k0 = k + self.hold;
        self.seg_t0 = 0.0;
    }

    /// Advances past thread block `m`, run with the ideal spindle.
    pub fn finish_thread(&mut self, m: &ThreadMove) {
        let now = m.dir() * self.ideal_rev(self.group_k0 as f64);
        self.thread_begin(m, now, 0.0);
        if m.decel.is_some() {
            let k = self.ideal_thread_end(m);
            self.finish_group_at(k);
        } else {
            self.thread_next(m);
        }
    }

    /// Advances past a dwell starting at the current group tick.
    pub fn finish_dwell(&mut self, seconds: f64) {
        self.group_k0 += self.ticks(seconds);
        self.seg_t0 = 0.0;
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
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
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

    #[test]
    fn ticks_forgive_rounding() {
        let t = Timeline::new(0.001);
        assert_eq!(t.ticks(0.005), 5);
        assert_eq!(t.ticks(0.005 + 1e-15), 5);
        assert_eq!(t.ticks(0.0051), 6);
        assert_eq!(t.ticks(0.0), 0);
    }
}
