//! The G33 passes of a recording measured against its recorded spindle
//! encoder: the lead error of each pass (`cnc plot REC.mcap --thread`,
//! the figure and numbers a program's offline run gives) and the groove's
//! phase (`cnc bag compare`). One measurement for both.
//!
//! The recording's program runs through the interpreter again (on the
//! recorded machine file, in the recorded dialect) for the passes: each
//! G33 chain's blocks as the executor ran them — lead axis, direction,
//! start and end point, pitch, the start angle `I`, the run-in and the
//! deceleration. A pass's setpoints (`/cnc/joint_setpoints`) are those
//! from the last one standing at its start point to the first at its end
//! point. Each setpoint is paired with the encoder (`/sim/spindle_encoder`)
//! interpolated at its stamp **plus the lead the controller used**: the
//! drives' setpoint delay (the `cnc` metadata's `setpoint_delay_ms`, which
//! the node writes; an offline run applies each setpoint in its own step,
//! so 0 there) plus the lead axis's servo lag ([`Machine::servo_lag_s`]);
//! each simulator joint state (`/sim/joint_states`) with the encoder at
//! its own stamp. The encoder is read as `pairs_at` of
//! `tests/ros/test_thread.py` reads it: between the two readings around
//! the instant (the count's centre, count + 0.5, interpolated), in
//! revolutions from the index (`(count − count_at_index) / counts_per_rev`);
//! a sample without readings within [`MAX_GAP_NS`] on both sides is left
//! out. The lead error is `lead travel − pitch × (revolutions − I/360)`
//! (whole revolutions taken out once per pass) and the groove's phase
//! `((lead travel) / pitch − revolutions) × 360° + I`, wrapped to
//! (−180°, 180°] (`groove` of the same file), over the synchronized part:
//! the lead travel between the end of the run-in and the start of the
//! deceleration, each sample by its own position.

use super::reader::{Bag, Extent, Job};
use crate::offline::check_text;
use crate::plot::{PassBuilder, PhaseStats, ThreadErrorPoint, ThreadErrorSeries};
use crate::record::{from_cdr, stamp_ns, topics};
use cnc_core::canon::{Event, ThreadMove};
use cnc_core::interp::Interpreter;
use cnc_core::machine::axis_index;
use cnc_core::source::StrSource;
use cnc_core::V3;
use cnc_msgs::{ControllerStatus, JointState, SpindleEncoder};
use std::fmt;
use std::path::Path;

/// Readings more than this before or after a sample's instant leave the
/// sample out, ns (4 ms).
pub const MAX_GAP_NS: i64 = 4_000_000;
/// A position within this of a pass's start or end point stands there, mm
/// (as in an offline run's passes).
const AT_MM: f64 = crate::plot::AT_START_MM;
/// Lead travel this close to the synchronized part's ends is in it, mm.
const ON_LINE_MM: f64 = 1e-9;

/// Why a recording's threads were not measured.
#[derive(Clone, Debug, PartialEq)]
pub enum NotMeasured {
    /// the recording does not carry its job (program, machine file)
    NoJob(String),
    /// the program cuts no G33 thread
    NoThread(String),
    /// it does, but the recording cannot measure it (no encoder messages,
    /// no setpoints at the passes, an unreadable file)
    Failed(String),
}

impl fmt::Display for NotMeasured {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NotMeasured::NoJob(e) | NotMeasured::NoThread(e) | NotMeasured::Failed(e) => {
                f.write_str(e)
            }
        }
    }
}

impl From<NotMeasured> for String {
    fn from(e: NotMeasured) -> String {
        e.to_string()
    }
}

/// What was measured of one pass beyond its [`crate::plot::ThreadPass`].
#[derive(Clone, Debug, PartialEq)]
pub struct PassWindow {
    /// the start angle `I` of the pass, degrees after the index
    pub start_angle_deg: f64,
    /// how far ahead of its stamp the first block's setpoints lead, s
    pub lead_s: f64,
    /// the synchronized part: the lead axis's coordinates (the first
    /// block's at the end of the run-in, the last block's at the start of
    /// the deceleration), mm
    pub sync_mm: (f64, f64),
    /// the first block's lead axis (0 X, 1 Y, 2 Z)
    pub lead: usize,
    /// setpoints and joint states of the pass paired with the encoder
    /// (run-in and deceleration too)
    pub set_pairs: u64,
    pub act_pairs: u64,
}

/// The G33 passes of a recording, measured against its encoder.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingThreads {
    pub program_name: String,
    pub machine_name: String,
    /// the lead error and groove phase of each pass found in the
    /// recording (`fault`: the last status's error, if the job ended in
    /// one)
    pub series: ThreadErrorSeries,
    /// one per pass of `series`
    pub windows: Vec<PassWindow>,
    /// the drives' setpoint delay the controller led by (metadata
    /// `cnc.setpoint_delay_ms`; 0 without it: an offline run), s
    pub setpoint_delay_s: f64,
    /// the passes the program cuts (the recording may end before some)
    pub programmed_passes: usize,
}

impl RecordingThreads {
    /// How each pass was measured, one line per pass (for `cnc plot`).
    pub fn describe(&self) -> String {
        let mut s = String::new();
        for (i, w) in self.windows.iter().enumerate() {
            let axis = ["X", "Y", "Z"].get(w.lead).copied().unwrap_or("?");
            s.push_str(&format!(
                "  pass {}: I{} against the recorded encoder, setpoints at their stamp + {:.3} ms ({} paired), joint states at their own ({} paired); synchronized {axis} {:.6}..{:.6} mm\n",
                i + 1,
                cnc_core::diag::num(w.start_angle_deg),
                w.lead_s * 1000.0,
                w.set_pairs,
                w.act_pairs,
                w.sync_mm.0,
                w.sync_mm.1
            ));
        }
        s
    }
}

/// One encoder message.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reading {
    ns: i64,
    count: i64,
    cpr: u32,
    index_count: i64,
    count_at_index: i64,
}

/// A position message: stamp, machine coordinates in mm.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Position {
    ns: i64,
    p: V3,
}

/// The streams of a recording the measurement reads, sorted by stamp.
#[derive(Default)]
struct Streams {
    setpoints: Vec<Position>,
    actual: Vec<Position>,
    encoder: Vec<Reading>,
    /// the last status's error, if it was one
    fault: Option<String>,
}

fn position(js: &JointState) -> Position {
    let mut p = V3::zeros();
    for (name, v) in js.name.iter().zip(&js.position) {
        if let Some(i) = axis_index(name) {
            p[i] = v * 1000.0;
        }
    }
    Position {
        ns: stamp_ns(&js.header.stamp) as i64,
        p,
    }
}

impl Streams {
    /// Takes a message of the recording (those of other topics are left).
    fn take(&mut self, topic: &str, data: &[u8]) -> Result<(), String> {
        let err = |e: String| format!("{topic}: {e}");
        match topic {
            topics::JOINT_SETPOINTS => self
                .setpoints
                .push(position(&from_cdr::<JointState>(data).map_err(err)?)),
            topics::JOINT_STATES => self
                .actual
                .push(position(&from_cdr::<JointState>(data).map_err(err)?)),
            topics::SPINDLE_ENCODER => {
                let e: SpindleEncoder = from_cdr(data).map_err(err)?;
                self.encoder.push(Reading {
                    ns: stamp_ns(&e.stamp) as i64,
                    count: e.count,
                    cpr: e.counts_per_rev,
                    index_count: e.index_count,
                    count_at_index: e.count_at_index,
                });
            }
            topics::STATUS => {
                let s: ControllerStatus = from_cdr(data).map_err(err)?;
                self.fault = (s.state == ControllerStatus::STATE_ERROR && !s.last_error.is_empty())
                    .then_some(s.last_error);
            }
            _ => {}
        }
        Ok(())
    }

    /// In stamp order (messages of equal stamps in file order).
    fn sort(&mut self) {
        self.setpoints.sort_by_key(|p| p.ns);
        self.actual.sort_by_key(|p| p.ns);
        self.encoder.sort_by_key(|r| r.ns);
    }

    fn of_bag(bag: &Bag) -> Result<Streams, String> {
        let mut s = Streams::default();
        for t in [
            topics::JOINT_SETPOINTS,
            topics::JOINT_STATES,
            topics::SPINDLE_ENCODER,
            topics::STATUS,
        ] {
            for (_, data) in bag.topic(t).map_or(&[][..], |d| &d.messages) {
                s.take(t, data)?;
            }
        }
        s.sort();
        Ok(s)
    }
}

/// The encoder at instant `ns` as `pairs_at` of `tests/ros/test_thread.py`
/// reads it: the readings `a`, `b` around it (`b` the first at or after
/// it; `a` = `b` when `b` is at it), both within [`MAX_GAP_NS`], the
/// count linearly interpolated and its centre taken (+ 0.5). `(count,
/// count_at_index, counts_per_rev)`; `None` without such readings (or
/// before an index was seen).
fn angle_at(enc: &[Reading], ns: i64) -> Option<(f64, i64, u32)> {
    let i = enc.partition_point(|r| r.ns < ns);
    if i == 0 || i >= enc.len() {
        return None;
    }
    let b = enc[i];
    let a = if b.ns == ns { b } else { enc[i - 1] };
    if ns.saturating_sub(a.ns) > MAX_GAP_NS || b.ns.saturating_sub(ns) > MAX_GAP_NS {
        return None;
    }
    if a.cpr == 0 || a.index_count <= 0 {
        return None;
    }
    let f = if b.ns == a.ns {
        0.0
    } else {
        ns.saturating_sub(a.ns) as f64 / b.ns.saturating_sub(a.ns) as f64
    };
    let count = a.count as f64 + f * (b.count as f64 - a.count as f64) + 0.5;
    Some((count, a.count_at_index, a.cpr))
}

/// The positions at instant `ns`, linearly between the two messages around
/// it (both within [`MAX_GAP_NS`]).
fn position_at(ps: &[Position], ns: i64) -> Option<V3> {
    let i = ps.partition_point(|r| r.ns < ns);
    let b = ps.get(i)?;
    if b.ns == ns {
        return Some(b.p);
    }
    let a = ps.get(i.checked_sub(1)?)?;
    if ns.saturating_sub(a.ns) > MAX_GAP_NS || b.ns.saturating_sub(ns) > MAX_GAP_NS {
        return None;
    }
    let f = ns.saturating_sub(a.ns) as f64 / b.ns.saturating_sub(a.ns) as f64;
    Some(a.p + (b.p - a.p) * f)
}

/// One G33 block of a pass as the executor ran it.
#[derive(Clone, Copy, Debug)]
struct Block {
    m: ThreadMove,
    /// θ₀ of this block from the pass's first θ₀, revolutions
    off: f64,
    /// the synchronized part: lead travel from..to, mm
    u_in: f64,
    u_out: f64,
    /// how far ahead of its stamp a setpoint leads, ns
    lead_ns: i64,
    /// the sign of the lead axis's travel
    sign: f64,
}

impl Block {
    /// Lead travel from the block's start at position `p`.
    fn travel(&self, p: &V3) -> f64 {
        let l = self.m.seg.lead;
        self.sign * (p[l] - self.m.seg.start[l])
    }

    fn pitch(&self) -> f64 {
        self.m.seg.pitch
    }

    fn on_line(&self, u: f64) -> bool {
        u >= self.u_in - ON_LINE_MM && u <= self.u_out + ON_LINE_MM
    }
}

/// One pass: a chain of G33 blocks, the first with its run-in, the last
/// with its deceleration.
#[derive(Clone, Debug)]
struct Chain {
    blocks: Vec<Block>,
    /// `I` / 360, revolutions
    start_rev: f64,
    /// +1 M03, −1 M04
    dir: f64,
}

impl Chain {
    /// The block position `p` is on, going on from block `k`.
    fn block_at(&self, mut k: usize, p: &V3) -> usize {
        while k + 1 < self.blocks.len() && self.blocks[k].travel(p) >= self.blocks[k].m.seg.len {
            k += 1;
        }
        k
    }
}

/// The G33 passes of the recording's program, as the executor runs them,
/// each block leading by `delay_s` plus its lead axis's servo lag.
fn chains(job: &Job, delay_s: f64) -> Result<Vec<Chain>, NotMeasured> {
    let m = &job.machine;
    check_text(
        m,
        job.dialect,
        &job.program_name,
        &job.program_text,
        "nothing measured",
    )
    .map_err(NotMeasured::Failed)?;
    let lag = m.servo_lag_s();
    let mut out = Vec::new();
    let mut cur: Option<Chain> = None;
    for ev in Interpreter::new(StrSource::new(&job.program_text), job.dialect, m) {
        let m = match ev {
            Event::Thread(m) => m,
            Event::End { .. } => break,
            _ => continue,
        };
        if m.runin.is_some() {
            out.extend(cur.take());
        }
        let c = cur.get_or_insert_with(|| Chain {
            blocks: Vec::new(),
            start_rev: m.runin.map_or(0.0, |(i, _)| i),
            dir: m.dir(),
        });
        let off = c
            .blocks
            .last()
            .map_or(0.0, |b| b.off + b.m.seg.len / b.m.seg.pitch);
        let lead = m.seg.lead;
        let half = |d: Option<f64>| d.map_or(0.0, |d| 0.5 * d * m.seg.pitch);
        c.blocks.push(Block {
            m,
            off,
            u_in: half(m.runin.map(|(_, d)| d)),
            u_out: m.seg.len - half(m.decel),
            lead_ns: ((delay_s + lag[lead]) * 1e9).round() as i64,
            sign: (m.seg.prog_end[lead] - m.seg.start[lead]).signum(),
        });
        if m.decel.is_some() {
            out.extend(cur.take());
        }
    }
    out.extend(cur);
    Ok(out)
}

/// The setpoints of pass `c` from index `from` on: from the last one at
/// its start point (waiting for the sync angle) to the first at its end
/// point, or, for a pass stopped short, to the one furthest along. `None`:
/// no setpoint stands at its start.
fn span(sp: &[Position], from: usize, c: &Chain, joints: &[usize]) -> Option<(usize, usize)> {
    let (first, last) = (c.blocks.first()?, c.blocks.last()?);
    let at = |p: &V3, q: &V3| joints.iter().all(|&i| (p[i] - q[i]).abs() <= AT_MM);
    let (start, end) = (first.m.seg.start, last.m.seg.end);
    let mut i = (from..sp.len()).find(|&i| at(&sp[i].p, &start))?;
    while i + 1 < sp.len() && at(&sp[i + 1].p, &start) {
        i += 1;
    }
    let j = match (i + 1..sp.len()).find(|&j| at(&sp[j].p, &end)) {
        Some(j) => j,
        None => {
            let mut best = i;
            for (j, q) in sp.iter().enumerate().skip(i) {
                if first.travel(&q.p) > first.travel(&sp[best].p) {
                    best = j;
                }
            }
            best
        }
    };
    Some((i, j))
}

/// A sample of a pass paired with the encoder.
struct Pair {
    k: usize,
    u: f64,
    ns: i64,
    /// revolutions from the pass's reference index, in the direction of
    /// rotation
    revs: f64,
}

/// Measures pass `c` over setpoints `i0..=i1`.
fn measure_pass(
    c: &Chain,
    s: &Streams,
    (i0, i1): (usize, usize),
    default_cpr: u32,
) -> Option<(crate::plot::ThreadPass, PassWindow)> {
    let first = c.blocks.first()?;
    let last = c.blocks.last()?;
    // the index the pass counts from: the first reading it pairs with
    let mut reference: Option<(i64, u32)> = None;
    let mut pair = |k: usize, u: f64, ns: i64| -> Option<Pair> {
        let (count, index, cpr) = angle_at(&s.encoder, ns)?;
        let (index, _) = *reference.get_or_insert((index, cpr));
        Some(Pair {
            k,
            u,
            ns,
            revs: c.dir * (count - index as f64) / f64::from(cpr),
        })
    };
    let mut set = Vec::new();
    let mut k = 0;
    for q in &s.setpoints[i0..=i1] {
        k = c.block_at(k, &q.p);
        let b = &c.blocks[k];
        set.extend(pair(k, b.travel(&q.p), q.ns.saturating_add(b.lead_ns)));
    }
    let (t_from, t_to) = (
        s.setpoints[i0].ns.saturating_add(first.lead_ns),
        s.setpoints[i1].ns.saturating_add(last.lead_ns),
    );
    let from = s.actual.partition_point(|q| q.ns < t_from);
    let mut act = Vec::new();
    let mut k = 0;
    for q in s.actual[from..].iter().take_while(|q| q.ns <= t_to) {
        k = c.block_at(k, &q.p);
        act.extend(pair(k, c.blocks[k].travel(&q.p), q.ns));
    }
    let cpr = reference.map_or(default_cpr, |r| r.1);
    // whole revolutions from the start angle to θ₀: the setpoints' on the
    // line (all of them if none is)
    let whole = |on: bool| {
        let x: Vec<f64> = set
            .iter()
            .filter(|p| !on || c.blocks[p.k].on_line(p.u))
            .map(|p| {
                let b = &c.blocks[p.k];
                p.revs - c.start_rev - b.off - p.u / b.pitch()
            })
            .collect();
        (!x.is_empty()).then(|| (x.iter().sum::<f64>() / x.len() as f64).round())
    };
    let n = whole(true).or_else(|| whole(false)).unwrap_or(0.0);
    let theta0 = c.start_rev + n;
    let err = |b: &Block, u: f64, x: f64| (u - b.pitch() * (x - b.off)) * 1000.0;
    let mut pass = PassBuilder::new(
        first.m.src.line,
        first.m.src.block_no,
        first.m.seg.lead,
        first.pitch(),
        theta0,
        cpr,
    );
    for p in &set {
        let b = &c.blocks[p.k];
        let x = p.revs - theta0;
        let act_um = position_at(&s.actual, p.ns).map_or(f64::NAN, |a| err(b, b.travel(&a), x));
        let pt = ThreadErrorPoint {
            deg: x * 360.0,
            set_um: err(b, p.u, x),
            act_um,
            on_line: b.on_line(p.u),
        };
        pass.push(pt, b.pitch(), cpr, false);
    }
    for p in &act {
        let b = &c.blocks[p.k];
        let x = p.revs - theta0;
        pass.push_act(x * 360.0, err(b, p.u, x), b.on_line(p.u), b.pitch(), cpr);
    }
    let coord = |b: &Block, u: f64| b.m.seg.start[b.m.seg.lead] + b.sign * u;
    let window = PassWindow {
        start_angle_deg: c.start_rev * 360.0,
        lead_s: first.lead_ns as f64 * 1e-9,
        sync_mm: (coord(first, first.u_in), coord(last, last.u_out)),
        lead: first.m.seg.lead,
        set_pairs: set.len() as u64,
        act_pairs: act.len() as u64,
    };
    Some((pass.finish(None), window))
}

/// The setpoint delay the controller led G33 by: the `cnc` metadata's
/// `setpoint_delay_ms` (the node writes it), 0 without it (an offline
/// run: each setpoint drives the model in its own step).
fn setpoint_delay_s(bag: &Bag) -> Result<f64, String> {
    match bag
        .metadata
        .get("cnc")
        .and_then(|m| m.get("setpoint_delay_ms"))
    {
        None => Ok(0.0),
        Some(v) => match v.parse::<f64>() {
            Ok(ms) if ms.is_finite() && ms >= 0.0 => Ok(ms * 1e-3),
            _ => Err(format!(
                "metadata cnc.setpoint_delay_ms: not a delay in ms: {v:?}"
            )),
        },
    }
}

/// Measures the G33 passes of `bag` (its job) in `streams`.
fn measure(bag: &Bag, streams: Option<Streams>) -> Result<RecordingThreads, NotMeasured> {
    let file = bag.path.display().to_string();
    let job = bag
        .job()
        .map_err(|e| NotMeasured::NoJob(format!("{file}: {e}")))?;
    let failed = |e: String| NotMeasured::Failed(format!("{file}: {e}"));
    let delay = setpoint_delay_s(bag).map_err(failed)?;
    let chains = chains(&job, delay).map_err(|e| failed(e.to_string()))?;
    if chains.is_empty() {
        return Err(NotMeasured::NoThread(format!(
            "{file}: the recorded program {} cuts no G33 thread",
            job.program_name
        )));
    }
    let s = match streams {
        Some(s) => s,
        None => Streams::of_bag(bag).map_err(failed)?,
    };
    if s.encoder.is_empty() {
        return Err(failed(format!(
            "no messages on {}: a G33 pass is measured against the recorded spindle encoder",
            topics::SPINDLE_ENCODER
        )));
    }
    if s.setpoints.is_empty() {
        return Err(failed(format!(
            "no messages on {}",
            topics::JOINT_SETPOINTS
        )));
    }
    let joints = job.machine.joint_indices();
    let default_cpr = job
        .machine
        .spindle
        .as_ref()
        .map_or(0, |sp| sp.encoder_counts_per_rev);
    let mut passes = Vec::new();
    let mut windows = Vec::new();
    let mut from = 0;
    for c in &chains {
        let Some((i0, i1)) = span(&s.setpoints, from, c, &joints) else {
            break;
        };
        from = i1;
        if let Some((p, w)) = measure_pass(c, &s, (i0, i1), default_cpr) {
            passes.push(p);
            windows.push(w);
        }
    }
    if passes.is_empty() {
        let at = chains
            .first()
            .and_then(|c| c.blocks.first())
            .map(|b| b.m.seg.start)
            .unwrap_or_default();
        return Err(failed(format!(
            "no setpoint stands at the start of the first G33 pass (line {}, at {} mm): the job ended before it?",
            chains
                .first()
                .and_then(|c| c.blocks.first())
                .map_or(0, |b| b.m.src.line),
            joints
                .iter()
                .map(|&i| format!("{} {}", ["X", "Y", "Z"][i.min(2)], cnc_core::diag::num(at[i])))
                .collect::<Vec<_>>()
                .join(" ")
        )));
    }
    if passes.iter().all(|p| p.samples == 0) {
        return Err(failed(format!(
            "no setpoint of a G33 pass has {} readings within {} ms before and after the instant it is for",
            topics::SPINDLE_ENCODER,
            MAX_GAP_NS / 1_000_000
        )));
    }
    let counts_per_rev = s
        .encoder
        .iter()
        .find(|r| r.cpr > 0)
        .map_or(default_cpr, |r| r.cpr);
    Ok(RecordingThreads {
        program_name: job.program_name,
        machine_name: job.machine.name.clone(),
        series: ThreadErrorSeries {
            counts_per_rev,
            passes,
            fault: s.fault,
        },
        windows,
        setpoint_delay_s: delay,
        programmed_passes: chains.len(),
    })
}

/// Measures the G33 passes of a recording read with [`Bag::read`] (its
/// messages kept).
pub fn measure_bag(bag: &Bag) -> Result<RecordingThreads, NotMeasured> {
    measure(bag, None)
}

/// Reads a recording (as far as it goes, like `cnc plot`) and measures its
/// G33 passes; the positions and readings are decoded as they are read.
pub fn measure_recording(path: &Path) -> Result<RecordingThreads, NotMeasured> {
    let mut s = Streams::default();
    let bag = Bag::scan(path, Extent::AsFarAsItGoes, |m| match m.topic {
        // the job as latched messages, for a recording without attachments
        topics::PROGRAM | topics::MACHINE_FILE => Ok(true),
        t => s.take(t, m.data).map(|_| false),
    })
    .map_err(NotMeasured::Failed)?;
    s.sort();
    measure(&bag, Some(s))
}

/// The groove phases of one pass, for `cnc bag compare`.
#[derive(Clone, Debug, PartialEq)]
pub struct PassPhase {
    pub line: u32,
    pub block_no: Option<u64>,
    /// `I`, degrees
    pub start_angle_deg: f64,
    pub set: PhaseStats,
    pub act: PhaseStats,
}

impl RecordingThreads {
    /// The groove phase of each pass.
    pub fn phases(&self) -> Vec<PassPhase> {
        self.series
            .passes
            .iter()
            .zip(&self.windows)
            .map(|(p, w)| PassPhase {
                line: p.line,
                block_no: p.block_no,
                start_angle_deg: w.start_angle_deg,
                set: p.groove_set,
                act: p.groove_act,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(ns: i64, count: i64) -> Reading {
        Reading {
            ns,
            count,
            cpr: 4096,
            index_count: 1,
            count_at_index: 100,
        }
    }

    #[test]
    fn the_encoder_is_read_as_the_python_reference_reads_it() {
        let enc = [
            reading(0, 100),
            reading(1_000_000, 110),
            reading(2_000_000, 130),
        ];
        // between two readings: interpolated, the count's centre
        let (c, i, cpr) = angle_at(&enc, 1_500_000).unwrap();
        assert_eq!((c, i, cpr), (120.5, 100, 4096));
        // at a reading: that reading
        assert_eq!(angle_at(&enc, 1_000_000).unwrap().0, 110.5);
        // before the first, at the first (nothing before it), after the last
        assert!(angle_at(&enc, -1).is_none());
        assert!(angle_at(&enc, 0).is_none());
        assert!(angle_at(&enc, 2_000_001).is_none());
        assert_eq!(angle_at(&enc, 2_000_000).unwrap().0, 130.5);
        // a gap of more than 4 ms around the instant
        let gap = [
            reading(0, 0),
            reading(4_000_000, 40),
            reading(8_000_002, 80),
        ];
        assert!(angle_at(&gap, 2_000_000).is_some());
        assert!(angle_at(&gap, 4_000_002).is_some());
        assert!(angle_at(&gap, 4_000_001).is_none());
        // no index seen yet, or no counts per revolution
        let mut none = enc;
        none[0].index_count = 0;
        assert!(angle_at(&none, 500_000).is_none());
        none[0].index_count = 1;
        none[0].cpr = 0;
        assert!(angle_at(&none, 500_000).is_none());
    }

    #[test]
    fn positions_between_messages() {
        let ps = [
            Position {
                ns: 0,
                p: V3::new(0.0, 0.0, 1.0),
            },
            Position {
                ns: 1000,
                p: V3::new(0.0, 0.0, 3.0),
            },
        ];
        assert_eq!(position_at(&ps, 250), Some(V3::new(0.0, 0.0, 1.5)));
        assert_eq!(position_at(&ps, 0), Some(V3::new(0.0, 0.0, 1.0)));
        assert_eq!(position_at(&ps, 1000), Some(V3::new(0.0, 0.0, 3.0)));
        assert_eq!(position_at(&ps, -1), None);
        assert_eq!(position_at(&ps, 1001), None);
        assert_eq!(position_at(&[], 0), None);
    }
}
