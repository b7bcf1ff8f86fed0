//! Jumps and repeats (`docs/dialects.md` §2.2): G73 L<n> Q<q> jumps back
//! to block N<n> q times. Loops are executed, not expanded: the source
//! seeks back; the check adds up what the loops would run before the
//! first jump and refuses a program over `limits.max_executed_blocks`.

use super::state::{Interpreter, LoopScan};
use super::words::{slot, Words};
use crate::canon::Canon;
use crate::diag::Diagnostic;
use crate::parse::{block_no, parse_line, Block, Word};
use crate::source::{ProgramSource, SourceError, SourcePos};

/// G73's L: the block number to jump back to, if it is one.
pub(super) fn jump_target(l: &Word) -> Option<i64> {
    l.as_int().filter(|&n| l.integer && n >= 0)
}

/// G73's Q: the repeat count, a whole number 0..=9999, if it is one.
pub(super) fn jump_count(q: &Word) -> Option<i64> {
    q.as_int().filter(|&c| q.integer && (0..=9999).contains(&c))
}

impl<S: ProgramSource, C: Canon> Interpreter<S, C> {
    /// G73 L<n> Q<q> after its block ran: jumps back to N<n> while the
    /// block's counter lasts; the counter resets when the loop is done.
    #[inline(never)]
    pub(super) fn exec_jump(&mut self, w: &Words, g73: &Word) {
        let (Some(l), q) = (w.get(slot::L), w.get(slot::Q)) else {
            self.error(
                Some(g73),
                "G73 needs the target block L<n> (and the repeat count Q)".into(),
            );
            return;
        };
        let Some(n) = jump_target(&l) else {
            self.error(
                Some(&l),
                format!(
                    "L must be a block number, found {}",
                    super::words::written(&l)
                ),
            );
            return;
        };
        let count = match q {
            None => 0,
            Some(q) => match jump_count(&q) {
                Some(c) => c as u32,
                None => {
                    self.error(
                        Some(&q),
                        format!(
                            "Q must be a whole number 0..9999, found {}",
                            super::words::written(&q)
                        ),
                    );
                    return;
                }
            },
        };
        let line = self.last.line;
        let target = match self.targets.get(&line) {
            Some(t) => *t,
            None => {
                if !self.src.can_seek() {
                    self.needs_seek = true;
                    self.finished = true;
                    return;
                }
                if self.loop_scan == LoopScan::Wanted {
                    self.loop_scan = LoopScan::Done;
                    match self.scan_loops() {
                        Ok(None) => {}
                        Ok(Some(d)) => {
                            self.error_count += 1;
                            if self.errors.len() < self.max_errors {
                                self.errors.push(d);
                            }
                            self.finish();
                            return;
                        }
                        Err(e) => {
                            self.read_failed(&e);
                            return;
                        }
                    }
                }
                match self.find_block(n as u64, line) {
                    Ok(Some(t)) => {
                        self.targets.insert(line, t);
                        t
                    }
                    Ok(None) => {
                        self.error(
                            Some(&l),
                            format!("jump target N{n} is not a block at or before this one (G73 jumps back only)"),
                        );
                        return;
                    }
                    Err(e) => {
                        self.read_failed(&e);
                        return;
                    }
                }
            }
        };
        let i = match self.loops.iter().position(|l| l.0 == line) {
            Some(i) => i,
            None => {
                self.loops.push((line, count, None));
                self.loops.len() - 1
            }
        };
        if self.loops[i].1 == 0 {
            // done: the counter resets, so an enclosing loop may run it again
            self.loops.remove(i);
            return;
        }
        if !self.src.can_seek() {
            self.needs_seek = true;
            self.finished = true;
            return;
        }
        // the blocks this loop will have run: every pass runs the same
        // blocks (inner loops' counters reset), so after one repeated pass
        // the total is known; before it, what has run so far
        let (left, last) = (self.loops[i].1, self.loops[i].2);
        let projected = match last {
            Some(at) => self
                .executed
                .saturating_add((self.executed - at).saturating_mul(left as u64)),
            None => self.executed,
        };
        if projected > self.max_executed {
            let max = self.max_executed;
            let text = match last {
                Some(at) => format!(
                    "this loop would make the program execute {projected} blocks, more than the machine's limit of {max} (limits.max_executed_blocks): {left} more passes of {} blocks back to N{n}",
                    self.executed - at
                ),
                None => format!(
                    "this loop would make the program execute more than the machine's limit of {max} blocks (limits.max_executed_blocks): {} have run, and {left} more passes back to N{n} are due",
                    self.executed
                ),
            };
            self.error(Some(g73), text);
            self.finish();
            return;
        }
        self.loops[i].2 = Some(self.executed);
        self.loops[i].1 -= 1;
        self.jumps += 1;
        if let Err(e) = self.src.seek(target) {
            self.read_failed(&e);
        }
    }

    /// How many blocks the program would run with its G73 loops, counted
    /// from the loops' structure (two reads of the program, memory for its
    /// G73 blocks only): a block runs the product of (Q + 1) over the loops
    /// around it (exact for nested loops; overlapping ones are caught as
    /// they run, by the count in `exec_parsed`). Over `limits.max_executed_blocks`:
    /// the error, at the G73 of the outermost loop around the blocks that
    /// made it so. Returns to where the interpreter was.
    pub(super) fn scan_loops(&mut self) -> Result<Option<Diagnostic>, SourceError> {
        struct Jump {
            pos: SourcePos,
            word: Word,
            block_no: Option<u64>,
            target: u64,
            times: f64,
            /// blocks through this one, and before its target
            end: u64,
            start: Option<u64>,
        }
        let here = self.cur_pos;
        let mut jumps: Vec<Jump> = Vec::new();
        let mut buf = Vec::new();
        let mut block = Block::default();
        let is_g73 = |w: &Word| w.letter == b'G' && w.value == 73.0;
        // first read: the G73 blocks (those the interpreter would run)
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let mut blocks = 0u64;
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_err()
                || block.words.is_empty()
            {
                continue;
            }
            blocks += 1;
            let Some(g73) = block.words.iter().find(|w| is_g73(w)) else {
                continue;
            };
            let word = |c: u8| block.words.iter().find(|w| w.letter == c);
            let target = word(b'L').and_then(jump_target);
            let times = match word(b'Q') {
                None => Some(1),
                Some(q) => jump_count(q).map(|c| c + 1),
            };
            if let (Some(target), Some(times)) = (target, times) {
                jumps.push(Jump {
                    pos,
                    word: *g73,
                    block_no: block_no(&block.words),
                    target: target as u64,
                    times: times as f64,
                    end: blocks,
                    start: None,
                });
            }
        }
        // second read: each loop's first block (the last N<target> at or
        // before its G73), counted in blocks
        let wanted: std::collections::HashSet<u64> = jumps.iter().map(|j| j.target).collect();
        let mut last_at: std::collections::HashMap<u64, u64> = std::collections::HashMap::new();
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let (mut blocks, mut next) = (0u64, 0usize);
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if next >= jumps.len() {
                break;
            }
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_err()
                || block.words.is_empty()
            {
                continue;
            }
            if let Some(n) = block_no(&block.words).filter(|n| wanted.contains(n)) {
                last_at.insert(n, blocks);
            }
            blocks += 1;
            while next < jumps.len() && jumps[next].pos.line == pos.line {
                jumps[next].start = last_at.get(&jumps[next].target).copied();
                next += 1;
            }
        }
        self.src.seek(here)?;
        self.src.read_line(&mut buf)?;
        // blocks run: over the stretches between the loops' ends, the
        // stretch's blocks times the product of the loops around it
        let mut edges: Vec<(u64, usize)> = Vec::new();
        for (i, j) in jumps.iter().enumerate() {
            if let Some(s) = j.start {
                edges.push((s, i));
                edges.push((j.end, i));
            }
        }
        edges.sort_unstable();
        let mut open: Vec<usize> = Vec::new();
        let (mut total, mut at) = (0.0f64, 0u64);
        for (x, i) in edges {
            // (exact while below 2^53; past f64's range it is infinite,
            // which is over any limit too)
            let times: f64 = open.iter().map(|&k| jumps[k].times).product();
            total += (x - at) as f64 * times;
            at = x;
            if total > self.max_executed as f64 {
                // the outermost loop around this stretch
                let Some(&k) = open
                    .iter()
                    .min_by_key(|&&k| (jumps[k].start, u64::MAX - jumps[k].end))
                else {
                    break;
                };
                let j = &jumps[k];
                let runs = total + (blocks.saturating_sub(at)) as f64;
                let runs = if runs < 1e15 {
                    format!("{runs:.0}")
                } else {
                    format!("about {runs:.1e}")
                };
                let mut d = Diagnostic::new(
                    j.pos.line,
                    j.word.col,
                    j.word.len,
                    format!(
                        "with its loops the program would run {runs} blocks or more, over the \
                         machine's limit of {} (limits.max_executed_blocks; loops are executed, \
                         not expanded: fewer repetitions, or fewer nested loops)",
                        self.max_executed
                    ),
                );
                d.block_no = j.block_no;
                self.src.seek(j.pos)?;
                if self.src.read_line(&mut buf)?.is_some() {
                    d.source = String::from_utf8_lossy(&buf).into_owned();
                }
                self.src.seek(here)?;
                self.src.read_line(&mut buf)?;
                return Ok(Some(d));
            }
            match open.iter().position(|&k| k == i) {
                Some(p) => {
                    open.swap_remove(p);
                }
                None => open.push(i),
            }
        }
        Ok(None)
    }

    /// The last line at or before `upto` whose block number is `n`; reads
    /// the program from the start and returns to the line after `upto`.
    pub(super) fn find_block(
        &mut self,
        n: u64,
        upto: u32,
    ) -> Result<Option<SourcePos>, SourceError> {
        let here = self.cur_pos;
        self.src.seek(SourcePos { offset: 0, line: 1 })?;
        let mut found = None;
        let mut buf = Vec::new();
        let mut block = Block::default();
        while let Some(pos) = self.src.read_line(&mut buf)? {
            if pos.line > upto {
                break;
            }
            if parse_line(self.dialect, pos.line, &buf, &mut block).is_ok()
                && block_no(&block.words) == Some(n)
            {
                found = Some(pos);
            }
        }
        self.src.seek(here)?;
        self.src.read_line(&mut buf)?;
        Ok(found)
    }
}
