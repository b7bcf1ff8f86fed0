//! `cnc bag compare`: two recordings topic by topic (see [`crate::bag`]
//! for what is compared).

use super::reader::{Bag, TopicData};
use super::thread_phase::{measure_bag, NotMeasured, PassPhase, RecordingThreads};
use crate::plot::{signed_deg4, PhaseStats};
use crate::record::{self, from_cdr, topics};
use cnc_msgs::schema::RosSchema;
use cnc_msgs::{ControllerStatus, JointState, PointCloud2, PointField, PoseStamped, TFMessage};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Where a deviation was found.
#[derive(Clone, Debug, PartialEq)]
pub struct At {
    /// index of the message on its topic
    pub index: usize,
    /// index of the point (PointCloud2 only)
    pub point: Option<usize>,
    /// s from the first message of file B
    pub t: f64,
    /// source line and block number (-1: none) from `/cnc/status`
    pub line: Option<(u32, i64)>,
}

impl fmt::Display for At {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = self.point {
            write!(f, "point {p}, ")?;
        }
        write!(f, "t={:.3} s", self.t)?;
        match self.line {
            Some((l, b)) if b >= 0 => write!(f, ", line {l} (N{b})"),
            Some((l, _)) => write!(f, ", line {l}"),
            None => Ok(()),
        }
    }
}

/// One compared value of a topic (a joint, a coordinate).
#[derive(Clone, Debug, PartialEq)]
pub struct ValueDiff {
    /// joint name, `x`/`y`/`z`, or `frame.x` for `/tf`
    pub name: String,
    /// largest |a - b|, mm (NaN if a value was NaN on one side only)
    pub max_mm: f64,
    /// where the largest deviation is (None while it is 0)
    pub max_at: Option<At>,
    /// where it first exceeds the tolerance
    pub first_over: Option<At>,
    /// messages (or points) where it exceeds the tolerance
    pub over: u64,
}

/// The comparison of one topic.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicDiff {
    pub topic: String,
    pub type_name: String,
    /// messages in A and in B; None: the topic is not in that file
    pub count_a: Option<usize>,
    pub count_b: Option<usize>,
    /// compared values (empty for topics compared byte by byte)
    pub values: Vec<ValueDiff>,
    /// paired messages whose payloads are not byte-identical
    pub payload_diffs: u64,
    pub first_payload_diff: Option<At>,
    /// paired messages that differ in more than the compared values (for
    /// topics without values: the same as the payload differences)
    pub other_diffs: u64,
    pub first_other_diff: Option<At>,
    /// paired messages with different log times
    pub time_diffs: u64,
    pub first_time_diff: Option<At>,
}

impl TopicDiff {
    /// A topic in both files, with as many messages, equal log times and
    /// equal payloads (within the tolerance where values are compared).
    pub fn within(&self, tolerance_mm: f64) -> bool {
        self.count_a.is_some()
            && self.count_a == self.count_b
            && self.time_diffs == 0
            && self.other_diffs == 0
            && self.values.iter().all(|v| v.first_over.is_none())
            && (tolerance_mm > 0.0 || self.payload_diffs == 0)
    }
}

/// What [`compare`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct CompareReport {
    pub a: PathBuf,
    pub b: PathBuf,
    pub tolerance_mm: f64,
    /// topics of A in channel order, then those only in B
    pub topics: Vec<TopicDiff>,
    /// differences of the `cnc` metadata and of the attachments (notes:
    /// they do not count against [`within`](Self::within))
    pub notes: Vec<String>,
    /// the groove phase of the G33 passes of both files (None: neither
    /// program cuts a thread, or neither file carries its job); it does
    /// not count against [`within`](Self::within)
    pub thread: Option<ThreadPhases>,
}

/// The groove phase of every G33 pass of two recordings, each measured
/// against its own recorded encoder ([`super::measure_bag`]), or why it
/// could not be.
#[derive(Clone, Debug, PartialEq)]
pub struct ThreadPhases {
    pub a: Result<Vec<PassPhase>, String>,
    pub b: Result<Vec<PassPhase>, String>,
}

impl ThreadPhases {
    fn fmt_lines(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (name, r) in [("A", &self.a), ("B", &self.b)] {
            if let Err(e) = r {
                writeln!(f, "thread phase of {name}: {e}")?;
            }
        }
        let none = Vec::new();
        let (pa, pb) = (
            self.a.as_ref().unwrap_or(&none),
            self.b.as_ref().unwrap_or(&none),
        );
        if self.a.is_ok() && self.b.is_ok() && pa.len() != pb.len() {
            writeln!(f, "thread passes: A {}, B {}", pa.len(), pb.len())?;
        }
        let side = |g: Option<&PhaseStats>| match g {
            Some(g) if g.n > 0 => format!(
                "mean {:+.4}° worst {:.4}° ({} samples)",
                signed_deg4(g.mean_deg),
                g.worst_deg,
                g.n
            ),
            _ => "none".to_string(),
        };
        for i in 0..pa.len().max(pb.len()) {
            let (a, b) = (pa.get(i), pb.get(i));
            let Some(p) = b.or(a) else { continue };
            let block = p.block_no.map(|n| format!("N{n}, ")).unwrap_or_default();
            for (what, get) in [
                (
                    "setpoints",
                    (|p: &PassPhase| p.set) as fn(&PassPhase) -> PhaseStats,
                ),
                ("actual", |p: &PassPhase| p.act),
            ] {
                let (ga, gb) = (a.map(get), b.map(get));
                write!(
                    f,
                    "thread pass {} ({block}line {}, I{}) groove phase, {what}: A {}, B {}",
                    i + 1,
                    p.line,
                    cnc_core::diag::num(p.start_angle_deg),
                    side(ga.as_ref()),
                    side(gb.as_ref())
                )?;
                if let (Some(x), Some(y)) = (ga.filter(|g| g.n > 0), gb.filter(|g| g.n > 0)) {
                    write!(
                        f,
                        ", B - A mean {:+.4}° worst {:+.4}°",
                        signed_deg4(y.mean_deg - x.mean_deg),
                        signed_deg4(y.worst_deg - x.worst_deg)
                    )?;
                }
                writeln!(f)?;
            }
        }
        Ok(())
    }
}

impl CompareReport {
    /// Every topic within the tolerance (`cnc bag compare` exits 0).
    pub fn within(&self) -> bool {
        self.topics.iter().all(|t| t.within(self.tolerance_mm))
    }

    /// The earliest place (in B's time) where a value exceeds the
    /// tolerance: (topic, value name, where).
    pub fn first_divergence(&self) -> Option<(&str, &str, &At)> {
        self.topics
            .iter()
            .flat_map(|t| {
                t.values.iter().filter_map(move |v| {
                    v.first_over
                        .as_ref()
                        .map(|at| (t.topic.as_str(), v.name.as_str(), at))
                })
            })
            .min_by(|x, y| x.2.t.total_cmp(&y.2.t))
    }

    /// The comparison of a topic.
    pub fn topic(&self, name: &str) -> Option<&TopicDiff> {
        self.topics.iter().find(|t| t.topic == name)
    }
}

/// `1 message`, `2 messages`
fn messages(n: usize) -> String {
    if n == 1 {
        "1 message".into()
    } else {
        format!("{n} messages")
    }
}

impl fmt::Display for CompareReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let tol = self.tolerance_mm;
        writeln!(
            f,
            "A: {}\nB: {}\ntolerance: {} mm{}",
            self.a.display(),
            self.b.display(),
            tol,
            if tol > 0.0 { "" } else { " (exact)" }
        )?;
        for t in &self.topics {
            let name = &t.topic;
            match (t.count_a, t.count_b) {
                (Some(_), None) => writeln!(f, "{name}: missing in B")?,
                (None, Some(n)) => writeln!(f, "{name}: extra in B ({})", messages(n))?,
                (Some(a), Some(b)) if a > b => {
                    writeln!(f, "{name}: {} missing in B (A {a}, B {b})", messages(a - b))?
                }
                (Some(a), Some(b)) if b > a => {
                    writeln!(f, "{name}: {} extra in B (A {a}, B {b})", messages(b - a))?
                }
                _ => {}
            }
            for v in &t.values {
                write!(f, "{name} {}: max {:.6} mm", v.name, v.max_mm)?;
                if let Some(at) = &v.max_at {
                    write!(f, " at {}", at_paren(at))?;
                }
                if let Some(at) = &v.first_over {
                    write!(
                        f,
                        "; first over {tol} mm at {at}; over in {} {}",
                        v.over,
                        if t.type_name == PointCloud2::schema_name() {
                            "point(s)"
                        } else {
                            "message(s)"
                        }
                    )?;
                }
                writeln!(f)?;
            }
            if t.time_diffs > 0 {
                writeln!(
                    f,
                    "{name}: {} message(s) with other log times, first at index {} ({})",
                    t.time_diffs,
                    t.first_time_diff.as_ref().map_or(0, |a| a.index),
                    t.first_time_diff
                        .as_ref()
                        .map_or(String::new(), |a| a.to_string())
                )?;
            }
            if t.values.is_empty() || t.other_diffs > 0 {
                let (n, first, what) = if t.values.is_empty() {
                    (t.payload_diffs, &t.first_payload_diff, "payload")
                } else {
                    (
                        t.other_diffs,
                        &t.first_other_diff,
                        "content besides the positions",
                    )
                };
                if n > 0 {
                    writeln!(
                        f,
                        "{name}: {what} differs in {n} message(s), first at {}",
                        first.as_ref().map_or(String::new(), |a| a.to_string())
                    )?;
                } else if t.count_a.is_some() && t.count_b.is_some() {
                    writeln!(f, "{name}: {}, equal", messages(t.count_b.unwrap_or(0)))?;
                }
            } else if tol == 0.0 && t.payload_diffs > 0 {
                writeln!(
                    f,
                    "{name}: payload differs in {} message(s), first at {}",
                    t.payload_diffs,
                    t.first_payload_diff
                        .as_ref()
                        .map_or(String::new(), |a| a.to_string())
                )?;
            }
        }
        if let Some(t) = &self.thread {
            t.fmt_lines(f)?;
        }
        for n in &self.notes {
            writeln!(f, "note: {n}")?;
        }
        if let Some((topic, value, at)) = self.first_divergence() {
            writeln!(f, "first divergence: {topic} {value} at {at}")?;
        }
        write!(
            f,
            "{}",
            if self.within() {
                "result: within tolerance"
            } else {
                "result: NOT within tolerance"
            }
        )
    }
}

/// `t=3.217 s (line 7, N60)`
fn at_paren(at: &At) -> String {
    let mut s = String::new();
    if let Some(p) = at.point {
        s.push_str(&format!("point {p}, "));
    }
    s.push_str(&format!("t={:.3} s", at.t));
    match at.line {
        Some((l, b)) if b >= 0 => s.push_str(&format!(" (line {l}, N{b})")),
        Some((l, _)) => s.push_str(&format!(" (line {l})")),
        None => {}
    }
    s
}

/// The compared values of a message, mm, and the message with those
/// values (and velocities, efforts) zeroed, for comparing the rest.
type Values = (Vec<(String, Vec<f64>)>, Vec<u8>);

fn kind_has_values(type_name: &str) -> bool {
    [
        JointState::schema_name(),
        PoseStamped::schema_name(),
        TFMessage::schema_name(),
        PointCloud2::schema_name(),
    ]
    .contains(&type_name)
}

fn values(type_name: &str, data: &[u8]) -> Result<Values, String> {
    let mm = |m: f64| m * 1000.0;
    if type_name == JointState::schema_name() {
        let mut js: JointState = from_cdr(data)?;
        let v = js
            .name
            .iter()
            .zip(&js.position)
            .map(|(n, p)| (n.clone(), vec![mm(*p)]))
            .collect();
        js.position.iter_mut().for_each(|p| *p = 0.0);
        js.velocity.iter_mut().for_each(|p| *p = 0.0);
        js.effort.iter_mut().for_each(|p| *p = 0.0);
        Ok((v, record::to_cdr(&js)?))
    } else if type_name == PoseStamped::schema_name() {
        let mut p: PoseStamped = from_cdr(data)?;
        let q = p.pose.position;
        let v = vec![
            ("x".into(), vec![mm(q.x)]),
            ("y".into(), vec![mm(q.y)]),
            ("z".into(), vec![mm(q.z)]),
        ];
        p.pose.position = Default::default();
        Ok((v, record::to_cdr(&p)?))
    } else if type_name == TFMessage::schema_name() {
        let mut m: TFMessage = from_cdr(data)?;
        let mut v = Vec::new();
        for t in &mut m.transforms {
            let c = &t.child_frame_id;
            let q = t.transform.translation;
            v.push((format!("{c}.x"), vec![mm(q.x)]));
            v.push((format!("{c}.y"), vec![mm(q.y)]));
            v.push((format!("{c}.z"), vec![mm(q.z)]));
            t.transform.translation = Default::default();
        }
        Ok((v, record::to_cdr(&m)?))
    } else if type_name == PointCloud2::schema_name() {
        let mut c: PointCloud2 = from_cdr(data)?;
        let step = c.point_step as usize;
        let n = c.data.len().checked_div(step).unwrap_or(0);
        let mut v = Vec::new();
        for fld in &c.fields {
            let size = match fld.datatype {
                PointField::FLOAT32 => 4,
                PointField::FLOAT64 => 8,
                _ => continue,
            };
            let off = fld.offset as usize;
            if fld.count != 1 || off + size > step {
                continue;
            }
            let mut vals = Vec::with_capacity(n);
            for i in 0..n {
                let b = &c.data[i * step + off..i * step + off + size];
                let x = if size == 4 {
                    let a: [u8; 4] = b.try_into().unwrap_or_default();
                    if c.is_bigendian {
                        f32::from_be_bytes(a) as f64
                    } else {
                        f32::from_le_bytes(a) as f64
                    }
                } else {
                    let a: [u8; 8] = b.try_into().unwrap_or_default();
                    if c.is_bigendian {
                        f64::from_be_bytes(a)
                    } else {
                        f64::from_le_bytes(a)
                    }
                };
                vals.push(mm(x));
            }
            v.push((fld.name.clone(), vals));
            for i in 0..n {
                c.data[i * step + off..i * step + off + size].fill(0);
            }
        }
        Ok((v, record::to_cdr(&c)?))
    } else {
        Err(format!("{type_name}: no values to compare"))
    }
}

/// (log time, line, block) of every `/cnc/status`
fn status_lines(bag: &Bag) -> Vec<(u64, u32, i64)> {
    bag.topic(topics::STATUS)
        .map(|d| {
            d.messages
                .iter()
                .filter_map(|(t, data)| {
                    from_cdr::<ControllerStatus>(data)
                        .ok()
                        .map(|s| (*t, s.source_line, s.block_number))
                })
                .collect()
        })
        .unwrap_or_default()
}

struct Locator {
    lines: Vec<(u64, u32, i64)>,
    start_ns: u64,
}

impl Locator {
    fn at(&self, index: usize, point: Option<usize>, ns: u64) -> At {
        let k = self.lines.partition_point(|(t, _, _)| *t <= ns);
        At {
            index,
            point,
            t: ns.saturating_sub(self.start_ns) as f64 * 1e-9,
            line: k.checked_sub(1).map(|k| (self.lines[k].1, self.lines[k].2)),
        }
    }
}

fn compare_topic(
    topic: &str,
    a: Option<&TopicData>,
    b: Option<&TopicData>,
    tol: f64,
    loc: &Locator,
) -> TopicDiff {
    let type_name = b.or(a).map(|d| d.type_name.clone()).unwrap_or_default();
    let mut d = TopicDiff {
        topic: topic.to_string(),
        type_name: type_name.clone(),
        count_a: a.map(|d| d.messages.len()),
        count_b: b.map(|d| d.messages.len()),
        values: Vec::new(),
        payload_diffs: 0,
        first_payload_diff: None,
        other_diffs: 0,
        first_other_diff: None,
        time_diffs: 0,
        first_time_diff: None,
    };
    let (Some(a), Some(b)) = (a, b) else {
        return d;
    };
    let numeric = a.type_name == b.type_name && kind_has_values(&type_name);
    let mut index_of: BTreeMap<String, usize> = BTreeMap::new();
    let mut value = |d: &mut TopicDiff, name: &str| -> usize {
        *index_of.entry(name.to_string()).or_insert_with(|| {
            d.values.push(ValueDiff {
                name: name.to_string(),
                max_mm: 0.0,
                max_at: None,
                first_over: None,
                over: 0,
            });
            d.values.len() - 1
        })
    };
    // the value names, also when all messages are equal
    if numeric {
        for msg in [a.messages.first(), b.messages.first()]
            .into_iter()
            .flatten()
        {
            if let Ok((v, _)) = values(&type_name, &msg.1) {
                for (n, _) in v {
                    value(&mut d, &n);
                }
            }
        }
    }
    for (i, ((ta, pa), (tb, pb))) in a.messages.iter().zip(&b.messages).enumerate() {
        if ta != tb {
            d.time_diffs += 1;
            if d.first_time_diff.is_none() {
                d.first_time_diff = Some(loc.at(i, None, *tb));
            }
        }
        if pa == pb {
            continue;
        }
        d.payload_diffs += 1;
        if d.first_payload_diff.is_none() {
            d.first_payload_diff = Some(loc.at(i, None, *tb));
        }
        let parsed = if numeric {
            values(&type_name, pa)
                .and_then(|va| values(&type_name, pb).map(|vb| (va, vb)))
                .ok()
        } else {
            None
        };
        let Some(((va, ra), (vb, rb))) = parsed else {
            d.other_diffs += 1;
            if d.first_other_diff.is_none() {
                d.first_other_diff = Some(loc.at(i, None, *tb));
            }
            continue;
        };
        let names_a: Vec<&String> = va.iter().map(|(n, _)| n).collect();
        let names_b: Vec<&String> = vb.iter().map(|(n, _)| n).collect();
        if ra != rb || names_a != names_b {
            d.other_diffs += 1;
            if d.first_other_diff.is_none() {
                d.first_other_diff = Some(loc.at(i, None, *tb));
            }
        }
        let cloud = type_name == PointCloud2::schema_name();
        for ((name, xa), (_, xb)) in va.iter().zip(&vb) {
            let j = value(&mut d, name);
            let v = &mut d.values[j];
            let mut counted = false;
            for (p, (x, y)) in xa.iter().zip(xb).enumerate() {
                let dev = if x == y || x.to_bits() == y.to_bits() {
                    0.0
                } else {
                    (x - y).abs()
                };
                let point = cloud.then_some(p);
                if dev > v.max_mm || (dev.is_nan() && !v.max_mm.is_nan()) {
                    v.max_mm = dev;
                    v.max_at = Some(loc.at(i, point, *tb));
                }
                // NaN counts as over; tolerance 0: any difference
                if dev.is_nan() || dev > tol || (tol == 0.0 && x.to_bits() != y.to_bits()) {
                    if cloud || !counted {
                        v.over += 1;
                        counted = true;
                    }
                    if v.first_over.is_none() {
                        v.first_over = Some(loc.at(i, point, *tb));
                    }
                }
            }
        }
    }
    d
}

/// Compares recording `b` against recording `a` (see the module
/// documentation for what is compared). Errors only when a file cannot be
/// read as MCAP.
pub fn compare(a: &Path, b: &Path, tolerance_mm: f64) -> Result<CompareReport, String> {
    if !(tolerance_mm >= 0.0 && tolerance_mm.is_finite()) {
        return Err(format!(
            "tolerance must be a finite number >= 0, not {tolerance_mm}"
        ));
    }
    let ba = Bag::read(a)?;
    let bb = Bag::read(b)?;
    Ok(compare_bags(&ba, &bb, tolerance_mm))
}

/// [`compare`] of recordings already read.
pub fn compare_bags(a: &Bag, b: &Bag, tolerance_mm: f64) -> CompareReport {
    let mut lines = status_lines(b);
    if lines.is_empty() {
        lines = status_lines(a);
    }
    let loc = Locator {
        lines,
        start_ns: if b.topics.iter().any(|(_, d)| !d.messages.is_empty()) {
            b.start_ns
        } else {
            a.start_ns
        },
    };
    let mut names: Vec<&str> = a.topics.iter().map(|(t, _)| t.as_str()).collect();
    for (t, _) in &b.topics {
        if !names.contains(&t.as_str()) {
            names.push(t);
        }
    }
    let topics = names
        .iter()
        .map(|t| compare_topic(t, a.topic(t), b.topic(t), tolerance_mm, &loc))
        .collect();
    let mut notes = Vec::new();
    let empty = BTreeMap::new();
    let (ma, mb) = (
        a.metadata.get("cnc").unwrap_or(&empty),
        b.metadata.get("cnc").unwrap_or(&empty),
    );
    let mut keys: Vec<&String> = ma.keys().chain(mb.keys()).collect();
    keys.sort();
    keys.dedup();
    for k in keys {
        if ma.get(k) != mb.get(k) {
            notes.push(format!(
                "metadata cnc.{k}: A {:?}, B {:?}",
                ma.get(k).map_or("", |s| s.as_str()),
                mb.get(k).map_or("", |s| s.as_str())
            ));
        }
    }
    let mut att: Vec<&String> = a.attachments.keys().chain(b.attachments.keys()).collect();
    att.sort();
    att.dedup();
    for k in att {
        match (a.attachments.get(k), b.attachments.get(k)) {
            (Some(x), Some(y)) if x != y => notes.push(format!("attachment {k} differs")),
            (Some(_), None) => notes.push(format!("attachment {k} missing in B")),
            (None, Some(_)) => notes.push(format!("attachment {k} only in B")),
            _ => {}
        }
    }
    CompareReport {
        a: a.path.clone(),
        b: b.path.clone(),
        tolerance_mm,
        topics,
        notes,
        thread: thread_phases(a, b),
    }
}

/// The groove phases of both files; None when neither has a G33 thread
/// to measure (or the job to tell).
fn thread_phases(a: &Bag, b: &Bag) -> Option<ThreadPhases> {
    let (ma, mb) = (measure_bag(a), measure_bag(b));
    let quiet = |r: &Result<_, NotMeasured>| {
        matches!(r, Err(NotMeasured::NoJob(_) | NotMeasured::NoThread(_)))
    };
    if quiet(&ma) && quiet(&mb) {
        return None;
    }
    let phases =
        |r: Result<RecordingThreads, NotMeasured>| r.map(|t| t.phases()).map_err(String::from);
    Some(ThreadPhases {
        a: phases(ma),
        b: phases(mb),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Recorder, RecordingInfo};
    use cnc_msgs::Header;
    use std::io::Cursor;

    /// A recording of `/j` (JointState, joint `x`, positions in m, one
    /// every ms) and a `/cnc/status` at line 3 then line 4 from 2 ms on.
    fn bag(positions: &[f64]) -> Bag {
        let mut rec =
            Recorder::new(Cursor::new(Vec::new()), "m.mcap", RecordingInfo::default()).unwrap();
        let j = rec.channel::<JointState>("/j").unwrap();
        let st = rec.channel::<ControllerStatus>(topics::STATUS).unwrap();
        for (k, p) in positions.iter().enumerate() {
            let ns = 1_000_000_000 + k as u64 * 1_000_000;
            let js = JointState {
                header: Header {
                    stamp: record::time_from_ns(ns),
                    frame_id: String::new(),
                },
                name: vec!["x".into()],
                position: vec![*p],
                ..Default::default()
            };
            rec.write(j, ns, &js).unwrap();
            if k == 0 || k == 2 {
                let s = ControllerStatus {
                    source_line: 3 + (k as u32) / 2,
                    block_number: if k == 0 { -1 } else { 40 },
                    ..Default::default()
                };
                rec.write(st, ns, &s).unwrap();
            }
        }
        let (_, w) = rec.finish_into_inner().unwrap();
        Bag::from_bytes(Path::new("m.mcap"), &w.into_inner()).unwrap()
    }

    #[test]
    fn tolerance_zero_is_exact() {
        let a = bag(&[0.0, 0.0, 0.0]);
        let b = bag(&[0.0, 0.0, -0.0]);
        let r = compare_bags(&a, &b, 0.0);
        assert!(!r.within(), "{r}");
        let at = r.first_divergence().unwrap().2;
        assert_eq!((at.index, at.line), (2, Some((4, 40))));
        assert!((at.t - 0.002).abs() < 1e-12);
        assert!(compare_bags(&a, &b, 1e-9).within());
        assert!(compare_bags(&a, &a, 0.0).within());
    }

    #[test]
    fn nan_and_lines_without_block_numbers() {
        let a = bag(&[0.0, 0.001, 0.0]);
        let b = bag(&[0.0, f64::NAN, 0.0]);
        let r = compare_bags(&a, &b, 1.0);
        assert!(!r.within(), "{r}");
        let v = &r.topic("/j").unwrap().values[0];
        assert!(v.max_mm.is_nan());
        let at = v.first_over.as_ref().unwrap();
        assert_eq!((at.index, at.line), (1, Some((3, -1))));
        assert_eq!(at.to_string(), "t=0.001 s, line 3");
        // 1 mm at the second sample
        let b = bag(&[0.0, 0.0, 0.0]);
        let r = compare_bags(&a, &b, 0.5);
        let v = &r.topic("/j").unwrap().values[0];
        assert!((v.max_mm - 1.0).abs() < 1e-12);
        assert!(r.to_string().contains(
            "/j x: max 1.000000 mm at t=0.001 s (line 3); first over 0.5 mm at t=0.001 s, line 3; over in 1 message(s)"
        ), "{r}");
        assert!(compare_bags(&a, &b, 1.5).within());
    }

    #[test]
    fn a_job_needs_program_and_machine() {
        let e = bag(&[0.0]).job().unwrap_err();
        assert!(e.contains("machine.toml") || e.contains("program"), "{e}");
    }
}
