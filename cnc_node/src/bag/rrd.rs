//! `cnc bag rrd`: a recording as a Rerun file (`.rrd`) that opens on a
//! layout made for it (its blueprint is in the file).
//!
//! The file is written by the converter `cnc_node/rerun/cnc_rrd.py`
//! (Python, rerun-sdk; embedded in this binary as [`CONVERTER`] and run
//! with the interpreter given, `python3` by default): it reads the MCAP
//! itself. What only the controller knows, the path *as programmed*
//! (every block's geometry before compensation, blending and the jerk
//! filter, with its source line), comes from here: the recorded program is
//! run through the interpreter ([`programmed_moves`]) and handed to the
//! converter on its standard input ([`programmed_text`]).

use super::reader::{Bag, Extent};
use crate::record::{from_cdr, topics};
use cnc_core::canon::{Event, Feed, Src};
use cnc_core::geom::Geom;
use cnc_core::interp::Interpreter;
use cnc_core::pipeline::Watcher;
use cnc_core::source::StrSource;
use cnc_core::{Dialect, Machine, V3};
use cnc_msgs::JointState;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};

/// The converter (`cnc_node/rerun/cnc_rrd.py`): `python3 - IN.mcap -o
/// OUT.rrd [--programmed FILE|-]`.
pub const CONVERTER: &str = include_str!("../../rerun/cnc_rrd.py");

/// Largest angle of one chord of an arc of the programmed path, rad (2°).
const ARC_STEP_RAD: f64 = std::f64::consts::PI / 90.0;

/// The most points of the programmed path; a longer program's arcs get
/// fewer chords (at least 4 each).
const MAX_PROGRAMMED_POINTS: usize = 2_000_000;

/// One block's motion as programmed.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgrammedMove {
    /// source line (1-based)
    pub line: u32,
    /// G00
    pub rapid: bool,
    /// G33
    pub thread: bool,
    /// mm, machine coordinates (lathe X the radius), in the setpoints'
    /// frame (less the tool's geometry offset)
    pub points: Vec<V3>,
}

/// The watcher of the pipeline's front: every move as programmed, on its
/// way into compensation.
struct Watch {
    offset: V3,
    moves: Vec<ProgrammedMove>,
    points: usize,
}

impl Watch {
    fn push(&mut self, src: Src, rapid: bool, thread: bool, points: Vec<V3>) {
        self.points += points.len();
        let off = self.offset;
        self.moves.push(ProgrammedMove {
            line: src.line,
            rapid,
            thread,
            points: points.into_iter().map(|p| p - off).collect(),
        });
    }
}

fn geom_points(geom: &Geom, fine: bool) -> Vec<V3> {
    let n = match geom {
        Geom::Line { .. } => 1,
        Geom::Arc(a) if fine => ((a.sweep.abs() / ARC_STEP_RAD).ceil() as usize).clamp(4, 10_000),
        Geom::Arc(_) => 4,
    };
    let len = geom.length();
    std::iter::once(geom.start())
        .chain((1..=n).map(|i| geom.eval(len * i as f64 / n as f64)))
        .collect()
}

impl Watcher for Watch {
    fn command(&mut self, cmd: &Event) {
        match cmd {
            Event::Move { geom, feed, src } => {
                let pts = geom_points(geom, self.points < MAX_PROGRAMMED_POINTS);
                self.push(*src, matches!(feed, Feed::Rapid), false, pts);
            }
            Event::Thread(t) => {
                let s = &t.seg;
                let mut pts = vec![s.start];
                if let Some(r) = s.runout.filter(|r| s.len > 0.0 && r.from < s.len) {
                    pts.push(s.start + (s.prog_end - s.start) * (r.from / s.len));
                } else {
                    pts.push(s.prog_end);
                }
                pts.push(s.end);
                pts.dedup();
                self.push(t.src, false, true, pts);
            }
            _ => {}
        }
    }
    fn tool_offset(&mut self, offset: V3) {
        self.offset = offset;
    }
}

/// Every move of a program as programmed, in the order it runs (a loop's
/// blocks once per pass), from one run of the interpreter. Lines are
/// their end points, arcs chords of at most 2°, threads their start, the
/// start of the runout and their end.
pub fn programmed_moves(machine: &Machine, dialect: Dialect, text: &str) -> Vec<ProgrammedMove> {
    let watch = Watch {
        offset: V3::zeros(),
        moves: Vec::new(),
        points: 0,
    };
    let mut interp = Interpreter::watched(StrSource::new(text), dialect, machine, watch);
    for ev in interp.by_ref() {
        if matches!(ev, Event::End { .. }) {
            break;
        }
    }
    interp.watcher().moves.clone()
}

/// The moves as the converter reads them: one a line, `LINE KIND x,y,z
/// x,y,z ...` with KIND `feed`, `rapid` or `thread` and mm.
pub fn programmed_text(moves: &[ProgrammedMove]) -> String {
    let mut out = String::new();
    for m in moves {
        let kind = if m.thread {
            "thread"
        } else if m.rapid {
            "rapid"
        } else {
            "feed"
        };
        let _ = write!(out, "{} {kind}", m.line);
        for p in &m.points {
            let _ = write!(out, " {},{},{}", p.x, p.y, p.z);
        }
        out.push('\n');
    }
    out
}

/// Writes `out` (.rrd) from the recording `recording` with the converter
/// run by `python` (an interpreter with rerun-sdk, mcap and
/// mcap-ros2-support). Returns what the converter printed.
pub fn write_rrd(recording: &Path, out: &Path, python: &str) -> Result<String, String> {
    let mut first_setpoint = true;
    let bag = Bag::scan(recording, Extent::AsFarAsItGoes, |m| {
        let first = m.topic == topics::JOINT_SETPOINTS && first_setpoint;
        first_setpoint &= !first;
        Ok(first || m.topic == topics::PROGRAM || m.topic == topics::MACHINE_FILE)
    })?;
    let job = bag
        .job()
        .map_err(|e| format!("{}: {e}", recording.display()))?;
    // the job ran from its first setpoint (a live job: where the machine stood)
    let start = bag
        .topic(topics::JOINT_SETPOINTS)
        .and_then(|t| t.messages.first())
        .and_then(|(_, data)| from_cdr::<JointState>(data).ok())
        .map(|js| js.position.iter().map(|m| m * 1000.0).collect::<Vec<_>>());
    let machine = match start {
        Some(p) if p.len() == job.machine.axes.len() => job.machine.starting_at(&p),
        _ => job.machine.clone(),
    };
    let moves = programmed_moves(&machine, job.dialect, &job.program_text);
    let text = programmed_text(&moves);
    // CNC_RRD_CONVERTER: a converter file to run instead (while changing it)
    let mut cmd = Command::new(python);
    match std::env::var_os("CNC_RRD_CONVERTER") {
        Some(file) => cmd.arg(file),
        None => cmd.arg("-c").arg(CONVERTER),
    };
    let mut child = cmd
        .arg(recording)
        .arg("-o")
        .arg(out)
        .arg("--programmed")
        .arg("-")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| {
            format!("{python}: {e} (the converter needs Python 3 with rerun-sdk 0.41, mcap and mcap-ros2-support: --python PY or CNC_PYTHON)")
        })?;
    if let Some(mut stdin) = child.stdin.take() {
        // a converter that stopped early closes its end: its exit status tells why
        let _ = stdin.write_all(text.as_bytes());
    }
    let output = child
        .wait_with_output()
        .map_err(|e| format!("{python}: {e}"))?;
    let printed = String::from_utf8_lossy(&output.stdout).into_owned();
    if output.status.success() {
        Ok(printed)
    } else {
        Err(format!(
            "{}: the converter failed ({}){}",
            recording.display(),
            output.status,
            if printed.is_empty() {
                String::new()
            } else {
                format!(": {}", printed.trim_end())
            }
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn programmed_moves_of_a_pocket_and_a_thread() {
        let m = Machine::builtin_mill();
        let text =
            "G90 G17 M03 S1000\nG00 X10 Y0 Z5\nG01 Z-1 F300\nG03 X0 Y10 I-10 J0\nG00 Z5\nM30\n";
        let moves = programmed_moves(&m, Dialect::Cnc836, text);
        assert_eq!(moves.len(), 4);
        assert_eq!(
            moves.iter().map(|m| (m.line, m.rapid)).collect::<Vec<_>>(),
            [(2, true), (3, false), (4, false), (5, true)]
        );
        // a quarter circle: 45 chords of 2°, from (10, 0) to (0, 10)
        let arc = &moves[2].points;
        assert_eq!(arc.len(), 46);
        assert!((arc[0] - V3::new(10.0, 0.0, -1.0)).norm() < 1e-9);
        assert!((arc[45] - V3::new(0.0, 10.0, -1.0)).norm() < 1e-9);
        assert!(arc.iter().all(|p| (p.xy().norm() - 10.0).abs() < 1e-9));
        let text = programmed_text(&moves);
        assert_eq!(text.lines().count(), 4);
        assert!(text.starts_with("2 rapid 0,0,0 10,0,5\n"), "{text}");

        let lathe = Machine::builtin_lathe();
        let thread = "G18 G90 M03 S800\nG00 X20 Z5\nG33 Z-30 F1.5\nG00 X30\nM30\n";
        let moves = programmed_moves(&lathe, Dialect::Cnc836, thread);
        let t = moves.iter().find(|m| m.thread).unwrap();
        assert_eq!(t.line, 3);
        // X is the radius: 10 mm for the diameter 20
        assert_eq!(t.points.first().map(|p| (p.x, p.z)), Some((10.0, 5.0)));
        assert_eq!(t.points.last().map(|p| (p.x, p.z)), Some((10.0, -30.0)));
    }
}
