//! The helix (`docs/dialects.md` §2.1): a pitch block names the dragged
//! axis and its pitch, helix on makes every arc in the plane drag it by
//! pitch × turns, helix off stands alone.

use super::state::Interpreter;
use super::words::{slot, Words, AXIS_LETTERS};
use crate::canon::Canon;
use crate::canon::Feed;
use crate::geom::{Arc, V3};
use crate::parse::Word;
use crate::source::ProgramSource;

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// The helix's block rules that come before the block runs: G98 alone,
    /// G10 pitch blocks, G09, the dragged axis; and L/Q only with a jump.
    /// False: the block is done.
    #[inline]
    pub(super) fn helix_block(&mut self, w: &Words) -> bool {
        // (nothing to do without these words or a helix in force)
        let words = [
            slot::HELIX_OFF,
            slot::PITCH,
            slot::HELIX_ON,
            slot::L,
            slot::Q,
        ];
        if !words.iter().any(|&s| w.has(s)) && (self.pitch.is_none() || self.helix.is_none()) {
            return true;
        }
        self.helix_rules(w)
    }

    /// [`helix_block`](Self::helix_block) with something to do.
    #[inline(never)]
    fn helix_rules(&mut self, w: &Words) -> bool {
        if let Some(g98) = w.get(slot::HELIX_OFF) {
            let other = w.all.iter().find(|x| x.letter != b'N' && x.col != g98.col);
            if let Some(o) = other {
                self.error(
                    Some(o),
                    "G98 (helix off) must stand alone in its block (an N number and a comment are allowed)".into(),
                );
            }
            self.helix = None;
            return false;
        }
        if let Some(g10) = w.get(slot::PITCH) {
            let axes: Vec<(usize, Word)> =
                (0..3).filter_map(|i| w.axis(i).map(|a| (i, a))).collect();
            let other = w
                .all
                .iter()
                .find(|x| !matches!(x.letter, b'N' | b'X' | b'Y' | b'Z') && x.col != g10.col);
            if let Some(o) = other {
                self.error(
                    Some(o),
                    "a G10 block (helix pitch) holds only the pitch: one axis word, e.g. Z1.05 G10"
                        .into(),
                );
            } else if axes.len() != 1 {
                self.error(
                    axes.get(1).map(|a| &a.1).or(Some(&g10)),
                    format!(
                        "G10 (helix pitch) takes exactly one axis word, the dragged axis with its pitch; found {}",
                        axes.len()
                    ),
                );
            } else {
                let (i, a) = axes[0];
                let (p, q, _) = self.modal.plane.axes();
                if i == p || i == q {
                    self.error(
                        Some(&a),
                        format!(
                            "the dragged axis {} is an axis of the {} plane; the helix drags the third axis",
                            AXIS_LETTERS[i] as char,
                            self.modal.plane.gcode()
                        ),
                    );
                } else if self.helix.is_some() && self.pitch.is_some_and(|(d, _)| d != i) {
                    self.error(
                        Some(&a),
                        "the dragged axis cannot change while the helix is on (G98 first)".into(),
                    );
                } else {
                    let v = if i == 0 && self.diameter {
                        a.value * 0.5
                    } else {
                        a.value
                    };
                    self.pitch = Some((i, v));
                    // a new pitch counts from here
                    if self.helix.is_some() {
                        self.helix = Some((self.pos[i], 0.0));
                    }
                }
            }
            return false;
        }
        if let Some(g09) = w.get(slot::HELIX_ON) {
            match self.pitch {
                None => self.error(
                    Some(&g09),
                    "G09 (helix on) needs a pitch programmed before it (a G10 block such as Z1.05 G10)".into(),
                ),
                Some((d, _)) => {
                    if self.helix.is_none() {
                        self.helix = Some((self.pos[d], 0.0));
                    }
                }
            }
        }
        if let (Some((d, _)), Some(_)) = (self.pitch, self.helix) {
            if let Some(a) = w.axis(d) {
                self.error(
                    Some(&a),
                    format!(
                        "axis {} is dragged by the helix (G09): it cannot be programmed until G98",
                        AXIS_LETTERS[d] as char
                    ),
                );
                return false;
            }
        }
        if let Some(l) = w.get(slot::L).filter(|_| !w.has(slot::JUMP)) {
            self.error(Some(&l), "address L is only used with G73 (jump)".into());
        }
        if let Some(q) = w.get(slot::Q).filter(|_| !w.has(slot::JUMP)) {
            self.error(Some(&q), "address Q is only used with G73 (jump)".into());
        }
        true
    }

    /// G09 in force: the arc `a` (counter-clockwise: `ccw`) to `target` drags the pitch's axis by
    /// pitch × turns (the turns summed, the position computed from them, so
    /// no error accumulates over thousands of turns), and F becomes the
    /// speed of the circular motion in the plane. Returns the feed.
    pub(super) fn drag_helix(
        &mut self,
        a: &mut Arc,
        target: &mut V3,
        ccw: bool,
        feed: Option<Feed>,
        anchor: Option<&Word>,
    ) -> Option<Feed> {
        let (Some((d, pitch)), Some((base, turns))) = (self.pitch, self.helix) else {
            return feed;
        };
        let (p, q, _) = a.plane.axes();
        if d == p || d == q {
            self.error(
                anchor,
                format!(
                    "the dragged axis {} is an axis of this arc's {} plane",
                    AXIS_LETTERS[d] as char,
                    a.plane.gcode()
                ),
            );
            return feed;
        }
        let turns = turns + a.sweep.abs() / std::f64::consts::TAU;
        self.helix = Some((base, turns));
        target[d] = base + pitch * turns;
        *a = Arc::new(a.start, *target, a.center, a.plane, ccw, 0);
        let c = a.plane_fraction();
        feed.map(|f| match f {
            Feed::PerMin(v) => Feed::PerMin(v / c),
            Feed::PerRev { mm_per_rev, rpm } => Feed::PerRev {
                mm_per_rev: mm_per_rev / c,
                rpm,
            },
            Feed::Rapid => Feed::Rapid,
        })
    }
}
