//! The look-ahead's pieces under a jerk limit: the move held back until
//! its exit junction is known is released here; a long move is queued as
//! pieces so that a neighbour's caps reach only its ends, and an arc's
//! pieces get the caps of the part of it they lie on
//! ([`ArcPart`]). (A file of its own: plan.rs would be over 800 lines.)

use super::{ItemSink, Lookahead, Pending};
use crate::canon::{Feed, Src};
use crate::geom::Geom;
use crate::jerk::{least_piece, piece_cuts, ArcPart};
use crate::shares::MAX_OVERRIDE;

impl<K: Copy> Lookahead<K> {
    /// Jerk: queues the move held back, `exit_stop` whether its exit
    /// junction is a stop: whole if it also starts from one (a line; an
    /// arc cut only where its inside starts), else in pieces. An arc whose
    /// neighbours both continue its curvature (`exit_curve` the next one)
    /// is inside a longer curve: all of it has the caps of an arc's inside.
    pub(super) fn release<O: ItemSink<Kept = K>>(
        &mut self,
        exit_stop: bool,
        exit_curve: bool,
        exit_beside: bool,
        out: &mut O,
    ) {
        let Some(p) = self.pending.take() else {
            return;
        };
        self.queue_pending(&p, exit_stop, exit_curve, exit_beside, out);
        self.spare = Some(p);
    }

    /// [`release`](Self::release) of `p`, the move held back.
    fn queue_pending<O: ItemSink<Kept = K>>(
        &mut self,
        p: &Pending,
        exit_stop: bool,
        exit_curve: bool,
        exit_beside: bool,
        out: &mut O,
    ) {
        // (the first piece queued takes it)
        self.entry_cap = p.entry_cap;
        self.move_length = p.prep.length;
        if p.entry_curve && exit_curve && matches!(p.geom, Geom::Arc(_)) {
            self.curve_inside(p, out);
            return;
        }
        let ends = !(p.entry_stop && exit_stop);
        let beside = (p.entry_beside, exit_beside);
        if !self.split(p, ends, beside, out) {
            let kept = O::keep(&p.geom, p.feed, p.src);
            if beside == (true, true) {
                let prep = self.lim.repart(&p.prep, &p.geom, &p.feed, ArcPart::Beside);
                self.enqueue(kept, &prep, out);
            } else {
                self.enqueue(kept, &p.prep, out);
            }
        }
    }

    /// The XYZ filter's span at the top path speed, mm: a line at least
    /// this long keeps whatever lies beyond it out of the filter's window
    /// across its junction with an arc, and pieces of an arc farther than
    /// this from its ends have no neighbour in theirs.
    pub(super) fn xyz_span(&self) -> f64 {
        self.lim.jerk.step_span() * self.lim.top
    }

    /// Jerk: an arc inside a longer curve, as pieces towards its ends if
    /// it is long (a neighbour's caps then reach only its ends), every
    /// piece with the caps of an arc's inside.
    pub(super) fn curve_inside<O: ItemSink<Kept = K>>(&mut self, p: &Pending, out: &mut O) {
        let (geom, feed, src) = (&p.geom, p.feed, p.src);
        let inner = self
            .lim
            .prepare_piece(geom, &feed, O::VLIM, ArcPart::Inside);
        let reach = self
            .lim
            .jerk
            .lag_distance(inner.full.vlim.min(self.lim.top));
        let Some((cuts, n)) = piece_cuts(reach, inner.length, None) else {
            self.enqueue(O::keep(geom, feed, src), &inner, out);
            return;
        };
        self.enqueue_pieces(
            geom,
            feed,
            src,
            &cuts[..n],
            inner.length,
            |_, _| ArcPart::Inside,
            out,
        );
    }

    /// Jerk: queues `geom` (of `length`) cut at `cuts` as pieces, each
    /// prepared with the caps of `part(from, to)` of an arc.
    #[allow(clippy::too_many_arguments)]
    fn enqueue_pieces<O: ItemSink<Kept = K>>(
        &mut self,
        geom: &Geom,
        feed: Feed,
        src: Src,
        cuts: &[f64],
        length: f64,
        part: impl Fn(f64, f64) -> ArcPart,
        out: &mut O,
    ) {
        self.extra += cuts.len() as u64;
        let mut from = 0.0;
        for &d in cuts.iter().chain(std::iter::once(&length)) {
            let g = geom.piece(from, d);
            let p = self.lim.prepare_piece(&g, &feed, O::VLIM, part(from, d));
            self.enqueue(O::keep(&g, feed, src), &p, out);
            from = d;
        }
    }

    /// Jerk: a long move is planned as pieces, so that a neighbour's caps
    /// reach only its ends: a middle and, at either end, pieces of
    /// reach/64, /64, /32, ..., /2 (a cap reaching r holds over at most
    /// 2r). An arc's pieces farther than the XYZ filter's span (at the
    /// arc's speed inside) from its ends see only the arc in the filter's
    /// window and may go faster ([`crate::jerk::JerkBudget::arc_caps`]);
    /// they start a further cap's reach (the ends' speed) in, so that the
    /// ends' caps do not reach them. `ends`: whether a neighbour's caps
    /// may reach its ends (else only an arc's inside is cut off);
    /// `beside`: whether its start and its end are beside a line or a stop
    /// ([`ArcPart::Beside`]). Whether the move was split.
    pub(super) fn split<O: ItemSink<Kept = K>>(
        &mut self,
        p: &Pending,
        ends: bool,
        beside: (bool, bool),
        out: &mut O,
    ) -> bool {
        let (geom, prep, feed, src) = (&p.geom, &p.prep, p.feed, p.src);
        let (jb, top, length) = (self.lim.jerk, self.lim.top, prep.length);
        // an arc's ends' caps: beside a line or a stop, or any end's
        // (`ends_v` the faster, for how far they reach)
        let mut ends_v = prep.full.vlim.min(top);
        if matches!(geom, Geom::Arc(_)) && (beside.0 || beside.1) {
            let b = self.lim.repart(prep, geom, &feed, ArcPart::Beside);
            ends_v = ends_v.max(b.full.vlim.min(top));
        }
        // an arc's inside: from `edge` on, pieces from `inner_at` on (not
        // where even the largest override keeps it under the ends' speed;
        // between two stops, not where the feed does)
        let over = if ends { MAX_OVERRIDE } else { 1.0 };
        let (inner, edge, inner_at) = match geom {
            Geom::Arc(_) if over * prep.full.vcap > ends_v => {
                let inner = self
                    .lim
                    .prepare_piece(geom, &feed, O::VLIM, ArcPart::Inside);
                let v = inner.full.vlim.min(top);
                let edge = jb.step_span() * v;
                // (the end pieces end at the first cut past `edge`: at
                // most twice as far, or the least piece)
                let ends_to = (2.0 * edge).max(least_piece(jb.lag_distance(v)));
                let at = ends_to + jb.lag_distance(ends_v);
                (v > ends_v && length > 2.0 * at).then_some((v, edge, at))
            }
            Geom::Arc(_) | Geom::Line { .. } => None,
        }
        .map_or((None, 0.0, 0.0), |(v, e, at)| (Some(v), e, at));
        let reach = jb.lag_distance(inner.unwrap_or(ends_v));
        let (cuts, n) = if ends {
            let Some(c) = piece_cuts(reach, length, inner.map(|_| inner_at)) else {
                return false;
            };
            c
        } else {
            // between two stops: the ends and the inside
            if inner.is_none() {
                return false;
            }
            let mut c = [0.0; crate::jerk::MAX_CUTS];
            c[0] = inner_at;
            c[1] = length - inner_at;
            (c, 2)
        };
        // (farther than the XYZ filter's span at the top speed from an
        // end, no neighbour is in a piece's window)
        let near = self.xyz_span();
        let part = |from: f64, d: f64| {
            if inner.is_some() && from >= edge && d <= length - edge {
                ArcPart::Inside
            } else if (beside.0 || from >= near) && (beside.1 || d <= length - near) {
                ArcPart::Beside
            } else {
                ArcPart::End
            }
        };
        self.enqueue_pieces(geom, feed, src, &cuts[..n], length, part, out);
        true
    }
}
