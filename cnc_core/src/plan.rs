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
//! path acceleration with the rest ([`LINE_SHARE`](crate::shares::LINE_SHARE)). A fine kink,
//! whose jump stays within [`FINE_KINK_SHARE`](crate::shares::FINE_KINK_SHARE) even at the fastest
//! path speed, costs its moves only that ([`FINE_SHARE`](crate::shares::FINE_SHARE)). A move whose
//! junctions are both tangent or stops has no jump to make room for and
//! uses the whole acceleration. A queue's tail does not know its next
//! junction yet; it is planned with the smaller share and raised when the
//! next move shows the junction to be smooth (raising an acceleration
//! only ever raises the entry speeds already handed out).

use crate::canon::{Event, Feed, Src, ThreadMove};
use crate::geom::Geom;
use crate::geom::V3;
use crate::jerk::{curvature, curvature_vector, ArcPart, JerkBudget};
pub use crate::limits::PlanLimits;
use crate::limits::{MoveLimits, MovePrep, Turn};
use crate::profile::Profile;
use std::collections::VecDeque;

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
    /// after an exact stop: the jerk filters and caps of the moves that
    /// follow ([`Event::Tolerance`])
    Smoothing(JerkBudget),
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
    /// the limits the move takes if its exit junction is smooth, and
    /// their `stop`, while they may still be taken (the whole acceleration
    /// if the entry junction is smooth, [`FINE_SHARE`](crate::shares::FINE_SHARE) if it is a fine
    /// kink; none after a kink)
    full: Option<(MoveLimits, f64)>,
    /// the limits with [`FINE_SHARE`](crate::shares::FINE_SHARE) and their `stop`: what `full`
    /// becomes if the exit junction is a fine kink
    fine: (MoveLimits, f64),
    /// the share in force, and `full`'s ([`Turn::Kink`]: `LINE_SHARE`)
    level: Turn,
    full_level: Turn,
    /// largest entry speed the junction allows
    j: f64,
    /// what `j` becomes if the move takes its `full` limits
    j_max: f64,
    /// largest entry speed from which the rest of the queue can stop
    entry_b: f64,
    /// jerk: the speed and acceleration caps this move gives its
    /// neighbours within the path filter's reach ([`crate::jerk`]), and
    /// the cap of its entry junction (∞: none; 0: a stop, which the
    /// filters settle on, so no cap reaches across it)
    own_v: f64,
    own_a: f64,
    j_in: f64,
}

impl<K> QSeg<K> {
    /// Largest entry speed from which the move can stop at its end.
    fn entry_to_stop(&self) -> f64 {
        self.j.min(self.stop)
    }
}

/// Jerk: a move the look-ahead holds back until the next event shows
/// whether its exit is a stop.
#[derive(Clone, Copy, Debug)]
struct Pending {
    geom: Geom,
    feed: Feed,
    src: Src,
    prep: MovePrep,
    /// whether it starts from a stop
    entry_stop: bool,
    /// whether the move before continues into it with its curvature ([`JerkBudget::curve_speed`])
    entry_curve: bool,
    /// whether it starts from a stop or from a long line, tangent ([`ArcPart::Beside`])
    entry_beside: bool,
    /// a cap on its entry junction (∞: none): the speed up to which the
    /// arc before continues into it as one curve
    /// ([`JerkBudget::curve_speed`])
    entry_cap: f64,
}

/// Jerk: the queue waits for the path filter's reach behind its head up to
/// this many times `lookahead_blocks` (pieces of split moves, short lines),
/// then commits the head anyway.
const REACH_QUEUE: usize = 64;

/// Lowers a queued move's speed and acceleration caps (jerk: a
/// neighbour's caps within the path filter's reach).
fn cap<K>(s: &mut QSeg<K>, v: f64, a: f64) {
    let length = s.length;
    let lower = |l: &mut MoveLimits, stop: &mut f64| {
        l.vcap = l.vcap.min(v);
        l.vlim = l.vlim.min(v);
        if a < l.a {
            l.a = a;
            *stop = (2.0 * a * length).sqrt();
        }
    };
    lower(&mut s.lim, &mut s.stop);
    if let Some((l, stop)) = s.full.as_mut() {
        lower(l, stop);
    }
    lower(&mut s.fine.0, &mut s.fine.1);
    s.j = s.j.min(v);
    s.j_max = s.j_max.min(v);
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
        profile.own_m = lim.own_m;
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
    /// the queue's total path length, mm
    queued: f64,
    /// jerk: the last move in, held back until its exit junction is
    /// known (a move between two stops needs no pieces at its ends: no
    /// neighbour's cap reaches across a stop). Boxed, with the box of
    /// the one released before kept for the next (`spare`): a move passes
    /// through here once per move, and moving it in and out by value
    /// copied its 360 bytes three times (5 % of the check's time)
    pending: Option<Box<Pending>>,
    spare: Option<Box<Pending>>,
    /// jerk: the cap on the next queued move's entry junction (∞: none)
    entry_cap: f64,
    /// planning everything to a stop
    flushing: bool,
    /// jerk: the queue's length behind its next head before the head is
    /// committed: the stop margin twice and the braking from the top speed
    reach_room: f64,
    /// moves planned beyond those that came in (the pieces of split
    /// lines): what a count of programmed moves takes off
    pub(crate) extra: u64,
    /// mm queued since the last kink or fine kink (∞: none yet)
    since_turn: f64,
    /// mm: the whole move being queued (all its pieces)
    move_length: f64,
    /// mm past the queue's end within which moves keep a kink's and a
    /// fine kink's share (without setpoint filters: plan/turns.rs)
    reach: [f64; 2],
}

impl<K: Copy> Lookahead<K> {
    pub(crate) fn new(lim: PlanLimits) -> Self {
        Lookahead {
            lim,
            queue: VecDeque::with_capacity(lim.lookahead + 2),
            v_head: 0.0,
            a_before: f64::INFINITY,
            queued: 0.0,
            pending: None,
            spare: None,
            entry_cap: f64::INFINITY,
            flushing: false,
            extra: 0,
            since_turn: f64::INFINITY,
            move_length: f64::INFINITY,
            reach: [0.0; 2],
            reach_room: 2.0 * lim.jerk.lag_distance(lim.top)
                + lim.top * lim.top / (2.0 * lim.amax.min()),
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
        // (anything but a move is planned after a stop)
        let item = match *ev {
            Event::Move {
                ref geom,
                feed,
                src,
            } => {
                match prep {
                    Some(p) => self.push_move(geom, p, feed, src, out),
                    None => {
                        let prep = self.lim.prepare(geom, &feed, O::VLIM);
                        self.push_move(geom, &prep, feed, src, out)
                    }
                }
                return;
            }
            Event::Dwell { seconds, src } => Item::Dwell { seconds, src },
            Event::Spindle { rpm, src } => Item::Spindle { rpm, src },
            Event::Tool { number, src } => Item::Tool { number, src },
            Event::Thread(m) => Item::Thread(m),
            Event::End { src } => Item::End { src },
            Event::Tolerance { mm } => Item::Smoothing(self.lim.jerk.for_tolerance(mm)),
        };
        self.flush(out);
        if let Item::Smoothing(b) = item {
            self.lim.jerk = b;
        }
        out.item(item);
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
        if prep.length <= 0.0 {
            return;
        }
        if !self.lim.jerk.limited() {
            self.move_length = prep.length;
            self.enqueue(O::keep(geom, feed, src), prep, out);
            return;
        }
        // jerk: the move before is released now that its exit is known;
        // this one waits for its own
        // (a line the XYZ filter's span long at the top speed: the window
        // across its junction with an arc holds no other curvature or kink)
        let span = self.xyz_span();
        let long_line = |g: &Geom, length: f64| matches!(g, Geom::Line { .. }) && length >= span;
        let mut entry_cap = f64::INFINITY;
        let (entry_stop, entry_curve, beside) = match (&self.pending, self.queue.back()) {
            (Some(p), _) => {
                let (v, turn) = self.lim.junction(&p.prep.t_end, &prep.t_start);
                // (only an arc continues a curvature: at any speed, or
                // under a cap on the junction where that is faster than
                // both ends' caps, as on a CAM curve's rounded blends)
                let jb = &self.lim.jerk;
                let curve_v = if v > 0.0 && turn != Turn::Kink && matches!(p.geom, Geom::Arc(_)) {
                    jb.curve_speed(
                        &curvature_vector(&p.geom, true),
                        &curvature_vector(geom, false),
                        (prep.t_start - p.prep.t_end).norm(),
                    )
                } else {
                    0.0
                };
                let end_cap = |g: &Geom| jb.arc_caps(curvature(g), ArcPart::End).0;
                let curve = curve_v >= self.lim.top
                    || (curve_v > 0.0
                        && matches!(geom, Geom::Arc(_))
                        && curve_v >= end_cap(&p.geom).max(end_cap(geom)));
                if curve {
                    entry_cap = curve_v;
                }
                // (whether the move before ends beside this one, and this
                // one starts beside that one)
                let smooth = v == 0.0 || turn == Turn::Smooth;
                let beside = (
                    smooth && (v == 0.0 || long_line(geom, prep.length)),
                    smooth && (v == 0.0 || long_line(&p.geom, p.prep.length)),
                );
                (v == 0.0, curve, beside)
            }
            (None, Some(prev)) => {
                let stop = self.lim.junction(&prev.t_end, &prep.t_start).0 == 0.0;
                (stop, false, (false, stop))
            }
            (None, None) => (self.v_head == 0.0, false, (false, self.v_head == 0.0)),
        };
        self.release(entry_stop, entry_curve, beside.0, out);
        let held = match self.spare.take() {
            // (field by field: built apart and moved in, it was copied whole)
            Some(mut b) => {
                b.geom = *geom;
                b.feed = feed;
                b.src = src;
                b.prep = *prep;
                b.entry_stop = entry_stop;
                b.entry_curve = entry_curve;
                b.entry_beside = beside.1;
                b.entry_cap = entry_cap;
                b
            }
            None => Box::new(Pending {
                geom: *geom,
                feed,
                src,
                prep: *prep,
                entry_stop,
                entry_curve,
                entry_beside: beside.1,
                entry_cap,
            }),
        };
        self.pending = Some(held);
    }

    /// Queues one move (or piece) and plans what it changes.
    #[inline]
    fn enqueue<O: ItemSink<Kept = K>>(&mut self, kept: K, prep: &MovePrep, out: &mut O) {
        let length = prep.length;
        let red = prep.red;
        let t2 = prep.t_start;
        // the entry junction; a smooth one lets the move before take its
        // whole acceleration (its exit is now known) and this one keep the
        // chance of it
        // (a curve's cap on the junction, [`Pending::entry_cap`]: the
        // move before is still queued, its exit not yet final)
        let cap = std::mem::replace(&mut self.entry_cap, f64::INFINITY);
        let (j_kink, turn) = match self.queue.back() {
            Some(prev) => {
                // (the nearest other kink: the last one, or this move's end)
                let gap = self.since_turn.min(self.move_length);
                let (j, turn) = self.lim.spaced_junction(&prev.t_end, &t2, gap);
                (self.reach_cap(turn, j.min(cap)), turn)
            }
            None => (self.v_head, Turn::Smooth),
        };
        let level = self.start_level(turn);
        self.pass_junction(turn, j_kink, length);
        match (turn, self.queue.back_mut()) {
            (Turn::Kink, Some(prev)) => {
                // a kink: the move before keeps its share for good
                prev.full = None;
                prev.j_max = prev.j;
            }
            (Turn::Fine, Some(prev)) => {
                // a fine kink: the move before takes the fine share at
                // most (its `j_max` was that of `full`, whose speed cap
                // is at least the fine one's)
                if prev.full.is_some() {
                    prev.full = Some(prev.fine);
                    prev.full_level = Turn::Fine;
                    prev.j_max = prev.j_max.min(prev.fine.0.vcap);
                }
                self.upgrade_tail();
            }
            _ => self.upgrade_tail(),
        }
        let full = match level {
            Turn::Smooth => Some((prep.full, prep.stop[2])),
            Turn::Fine => Some((prep.fine, prep.stop[1])),
            Turn::Kink => None,
        };
        let (j, j_max) = match self.queue.back() {
            Some(prev) => {
                let j = j_kink.min(prev.lim.vcap);
                (j.min(red.vcap), j.min(full.map_or(red.vcap, |f| f.0.vcap)))
            }
            None => (self.v_head, self.v_head),
        };
        let t_end = prep.t_end;
        let mut seg = QSeg {
            kept,
            t_end,
            length,
            lim: red,
            stop: prep.stop[0],
            full,
            fine: (prep.fine, prep.stop[1]),
            level: Turn::Kink,
            full_level: level,
            j,
            j_max,
            entry_b: 0.0,
            own_v: red.vlim,
            // (the whole acceleration while it may take it)
            own_a: full.map_or(red.a, |f| f.0.a),
            j_in: if self.queue.is_empty() { 0.0 } else { j_kink },
        };
        let capped = self.lim.jerk.limited() && self.smear(&mut seg);
        seg.entry_b = seg.entry_to_stop();
        self.queued += length;
        self.queue.push_back(seg);
        if self.lim.jerk.limited() {
            self.recompute(capped);
        } else {
            self.backward_pass(self.queue.len() - 1);
        }
        self.commit(false, out);
    }

    /// Jerk: the path filter's setpoint at a point moves with the speed and
    /// acceleration the profile had up to `lag_distance` on either side of
    /// it, so each move's caps (and a junction's) reach that far into its
    /// neighbours; not across a stop, where the filters settle. Caps `seg`
    /// (about to be queued) and the queue's moves within reach; whether any
    /// queued move changed.
    fn smear(&mut self, seg: &mut QSeg<K>) -> bool {
        if seg.j_in == 0.0 {
            return false;
        }
        let jb = self.lim.jerk;
        // a cap c on a stretch of path holds for the filtered setpoint if
        // the profile keeps it from lag·c before to lag·c after the
        // stretch (it cannot cross that in less than the window)
        let reach = |v: f64| jb.lag_distance(v.min(self.lim.top));
        let (own_v, own_a, j_in) = (seg.own_v, seg.own_a, seg.j_in);
        let (mut fwd_v, mut fwd_a) = (j_in, f64::INFINITY);
        // distance from the end of queued move k to `seg`'s start
        let mut dist = 0.0;
        let mut changed = false;
        for k in (0..self.queue.len()).rev() {
            let q = &mut self.queue[k];
            let (mut v, mut a) = (f64::INFINITY, f64::INFINITY);
            if dist < reach(own_v) {
                v = own_v;
                a = own_a;
            }
            if dist < reach(j_in) {
                v = v.min(j_in);
            }
            if q.lim.vlim > v || q.lim.a > a {
                cap(q, v, a);
                changed = true;
            }
            if dist < reach(q.own_v) {
                fwd_v = fwd_v.min(q.own_v);
                fwd_a = fwd_a.min(q.own_a);
            }
            dist += q.length;
            if q.j_in == 0.0 {
                break;
            }
            if dist < reach(q.j_in) {
                fwd_v = fwd_v.min(q.j_in);
            }
            if dist >= reach(self.lim.top) {
                break;
            }
        }
        cap(seg, fwd_v, fwd_a);
        changed
    }

    /// Jerk: how far before the tail's end the queue plans its stop: the
    /// farthest a move still to come may reach back with its caps.
    fn margin(&self) -> f64 {
        if self.flushing {
            // (nothing comes after: the tail stops at its end)
            return 0.0;
        }
        self.lim.jerk.lag_distance(self.lim.top)
    }

    /// Every entry limit again from the tail back (after caps fell:
    /// `capped`, some queued move's; else only the tail's own limits and
    /// where the stop margin ends changed).
    fn recompute(&mut self, capped: bool) {
        // the stop is planned `margin` before the tail's end: what a move
        // still to come may cap (speeds and accelerations over at most
        // lag·top behind it) is not used for braking
        let mut margin = self.margin();
        // (caps changed within the reach behind the tail's start, the
        // margin within its own length: before both, an unchanged limit
        // leaves every one before it unchanged)
        let tail = self.queue.back().map_or(0.0, |t| t.length);
        let reach = if capped {
            self.lim.jerk.lag_distance(self.lim.top)
        } else {
            0.0
        };
        let settled = margin + tail + reach;
        let mut dist = 0.0;
        let mut next_b = 0.0;
        // (past a stop: no cap of a move still to come reaches across it,
        // so no margin, and an unchanged limit there leaves every one
        // before it unchanged)
        let mut past_stop = false;
        // (from the tail back, each move with the one before it)
        let mut moves = self.queue.iter_mut().rev();
        let mut earlier = moves.next();
        while let Some(s) = earlier {
            earlier = moves.next();
            let before = earlier.as_ref().map_or(f64::INFINITY, |p| p.lim.vcap);
            s.j = s.j.min(before);
            s.j_max = s.j_max.min(before);
            let b = if margin >= s.length {
                margin -= s.length;
                0.0
            } else {
                let room = s.length - margin;
                margin = 0.0;
                s.j.min((next_b * next_b + 2.0 * s.lim.a * room).sqrt())
            };
            let same = b == s.entry_b;
            s.entry_b = b;
            next_b = b;
            dist += s.length;
            if same && (past_stop || dist > settled) {
                break;
            }
            if s.j_in == 0.0 {
                past_stop = true;
                margin = 0.0;
            }
        }
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
    fn commit<O: ItemSink<Kept = K>>(&mut self, all: bool, out: &mut O) {
        // (jerk: a cap of a move still to come falls on whole pieces, so
        // it may lower the entry of the piece that reaches over the last
        // `lag_distance(top)` from as far back as that piece starts; found
        // once, when the room is otherwise there)
        let mut straddle = None;
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
                    // (jerk: not while a move still to come may cap the
                    // next one, whose entry this fixes)
                    // (looked at only when the rest would commit it)
                    let room = self.queued - h.length - nx.length;
                    let mut covered = || {
                        !self.lim.jerk.limited()
                            || room >= self.reach_room
                                && room - *straddle.get_or_insert_with(|| self.straddle())
                                    >= self.reach_room
                    };
                    let full = self.queue.len() > self.lim.lookahead;
                    let overfull = self.queue.len() > REACH_QUEUE * self.lim.lookahead;
                    if !(all || (final_exit || full) && covered() || overfull) {
                        return;
                    }
                    nx.entry_b.min(reach)
                }
                None if all => 0.0,
                None => return,
            };
            let mut lim = h.lim;
            if lim.own_m > 0 && self.v_head == 0.0 && v1 == 0.0 {
                // a line or an arc from rest to rest under its own path
                // filter: its cruise outlasts the filter's window (an
                // arc: and its speed keeps the normal jerk)
                lim = self.lim.own_run(lim, h.length, O::VLIM);
            }
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
            self.queued -= h.length;
            self.queue.pop_front();
        }
        if all {
            self.v_head = 0.0;
            self.queued = 0.0;
        }
    }

    /// Jerk: how far the queued piece that reaches over the last
    /// `lag_distance(top)` of the queue starts before that point (0 if a
    /// piece ends there, or the queue is shorter). A move still to come
    /// caps the pieces within its reach whole ([`Self::smear`]): a long
    /// piece there takes its cap, and lowers its entry, from its start
    /// on. Without this room a head before it was committed at an exit
    /// the piece could no longer take (a full circle's long middle behind
    /// a line, capped by the slower end pieces of the circle's own end:
    /// twice the acceleration limit on the mill at 300 m/s³).
    fn straddle(&self) -> f64 {
        let reach = self.lim.jerk.lag_distance(self.lim.top);
        let mut behind = 0.0;
        for q in self.queue.iter().rev() {
            if behind + q.length > reach {
                return behind + q.length - reach;
            }
            behind += q.length;
        }
        0.0
    }

    /// Plans everything queued to a stop.
    pub(crate) fn flush<O: ItemSink<Kept = K>>(&mut self, out: &mut O) {
        // the move held back ends in a stop
        self.release(true, false, true, out);
        // the tail's exit is a stop: smooth
        self.flushing = true;
        self.upgrade_tail();
        if self.lim.jerk.limited() {
            self.recompute(true);
        }
        self.commit(true, out);
        self.flushing = false;
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

    /// Moves handed out beyond those that came in (pieces of long lines
    /// under a jerk limit).
    pub fn split_extra(&self) -> u64 {
        self.look.extra
    }
}

mod pieces;
#[cfg(test)]
mod tests;
mod turns;
