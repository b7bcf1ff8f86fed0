//! Job admission: what the node decides about a `run_program` request
//! before its control loop sees it. No DDS and no threads: the node's
//! check worker calls these and sends the job on; tests call them directly.
//!
//! [`admit`] takes the program (from the request, or read from
//! `program_path` inside the program directory), its dialect, and checks it
//! from the position the machine stood at when the request arrived; the
//! [`Admitted`] program carries that position, and [`Admitted::job`] hands
//! it to the job, whose [`Controller::start`](crate::controller::Controller::start)
//! refuses it if the machine has moved since. [`recorder`] opens the job's
//! recording when it is recorded. Every refusal is a [`Refusal`] whose text
//! is the reply's message; [`fit_run_reply`] cuts a reply's text to what
//! one DDS datagram carries.

use crate::controller::Job;
use crate::program::{read_limited, resolve_in};
use crate::record::{JobRecorder, RecordingInfo};
use cnc_core::source::StrSource;
use cnc_core::{check, Dialect, Machine};
use cnc_msgs::{RunProgramRequest, RunProgramResponse};
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a request was refused; the text is the reply's message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal(pub String);

impl Refusal {
    /// The reply to the refused request: not accepted, with this text.
    pub fn reply(&self) -> RunProgramResponse {
        RunProgramResponse {
            accepted: false,
            message: self.0.clone(),
            job_id: 0,
            estimated_duration: 0.0,
            recording: String::new(),
        }
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<String> for Refusal {
    fn from(s: String) -> Self {
        Refusal(s)
    }
}

/// A request that passed admission: its program, checked without error
/// from `start`.
#[derive(Clone, Debug, PartialEq)]
pub struct Admitted {
    /// the program's name: its `program_path`, or `program.nc` for a
    /// program sent as text
    pub name: String,
    pub text: Vec<u8>,
    pub dialect: Dialect,
    /// the joint positions the check ran from, mm, in joint order
    pub start: Vec<f64>,
    /// the check's estimate, ticks
    pub ticks: u64,
    /// the check's estimate, s
    pub estimated_duration_s: f64,
    /// the request asked for the check only: nothing is to run
    pub dry_run: bool,
    /// the request asked for a recording of the job
    pub record: bool,
}

impl Admitted {
    /// The job to start, numbered `id`, with its checked start.
    pub fn job(self, id: u32) -> Job {
        Job {
            id,
            text: self.text,
            dialect: self.dialect,
            ticks: self.ticks,
            start: self.start,
        }
    }

    /// The reply to an accepted request: job `job_id` (0 for a dry run),
    /// the check's estimate, and the recording's file ("" when none).
    pub fn reply(&self, job_id: u32, recording: String) -> RunProgramResponse {
        RunProgramResponse {
            accepted: true,
            message: String::new(),
            job_id,
            estimated_duration: self.estimated_duration_s,
            recording,
        }
    }
}

/// Admits a `run_program` request on `machine` standing at `position`
/// (joint positions, mm, in joint order, as
/// [`Controller::positions`](crate::controller::Controller::positions)):
/// - the program: `program` (at most `limits.max_program_bytes`) or
///   `program_path`, exactly one of them. A path is resolved inside
///   `program_dir` (no absolute paths, no `..`, no symlinks leading out)
///   and the file is read here, refused unread when over the limit: this
///   is the one I/O of admission;
/// - the dialect: the request's, else the machine's;
/// - the check from `position`: every error, `line L, column C: ...`;
/// - a dry run is admitted like a job ([`Admitted::dry_run`]); the caller
///   starts nothing.
///
/// A `position` with fewer entries than the machine has joints is
/// refused; entries past them are ignored.
pub fn admit(
    req: &RunProgramRequest,
    machine: &Machine,
    position: &[f64],
    program_dir: &Path,
) -> Result<Admitted, Refusal> {
    let text = program_text(req, machine.limits.max_program_bytes, program_dir)?;
    let dialect = if req.dialect.is_empty() {
        machine.dialect
    } else {
        req.dialect.parse::<Dialect>()?
    };
    let joints = machine.joint_indices().len();
    let Some(start) = position.get(..joints) else {
        return Err(Refusal(format!(
            "the machine's position has {} joints, the machine {joints}",
            position.len()
        )));
    };
    let m = machine.starting_at(start);
    let src = StrSource::from_bytes(&text).with_max_line(machine.limits.max_line_bytes);
    let report = check(src, dialect, &m);
    if !report.ok() {
        return Err(Refusal(report.message()));
    }
    let name = if req.program_path.is_empty() {
        "program.nc".to_string()
    } else {
        req.program_path.clone()
    };
    Ok(Admitted {
        name,
        text,
        dialect,
        start: start.to_vec(),
        ticks: report.ticks,
        estimated_duration_s: report.duration_s,
        dry_run: req.dry_run,
        record: req.record,
    })
}

/// The request's program: its text, or the file at `program_path` inside
/// `program_dir` (read here); at most `max` bytes.
fn program_text(req: &RunProgramRequest, max: u64, program_dir: &Path) -> Result<Vec<u8>, Refusal> {
    match (req.program.is_empty(), req.program_path.is_empty()) {
        (false, true) => {
            if req.program.len() as u64 > max {
                return Err(Refusal(format!(
                    "the program is {} bytes, over the machine's limit of {max} bytes (limits.max_program_bytes)",
                    req.program.len()
                )));
            }
            Ok(req.program.clone().into_bytes())
        }
        (true, false) => {
            Ok(resolve_in(program_dir, &req.program_path).and_then(|p| read_limited(&p, max))?)
        }
        _ => Err(Refusal(
            "exactly one of program and program_path must be set".into(),
        )),
    }
}

/// Where and what the node records.
#[derive(Clone, Debug)]
pub struct RecordOpts {
    /// directory of the recordings
    pub dir: PathBuf,
    /// record every job, not only those whose request asks
    pub all: bool,
    /// the machine file's text (what recordings attach)
    pub machine_toml: String,
}

/// The recording of job `id` running the program `name`:
/// `job_<id>_<stem>.mcap` in `dir`, of the name's file stem only its ASCII
/// letters, digits, `_` and `-`.
pub fn recording_file(dir: &Path, id: u32, name: &str) -> PathBuf {
    let stem: String = Path::new(name)
        .file_stem()
        .map(|s| {
            s.to_string_lossy()
                .chars()
                .filter(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-')
                .collect()
        })
        .unwrap_or_default();
    dir.join(format!("job_{id}_{stem}.mcap"))
}

/// The recorder of job `id` when it is recorded (its request asked, or
/// `opts.all`), else `None`. Creates `opts.dir` and the file
/// ([`recording_file`]): file I/O, to be done off the control loop; the
/// recorder travels with the job, so the recording starts with its first
/// sample.
pub fn recorder(
    admitted: &Admitted,
    id: u32,
    machine: &Machine,
    opts: &RecordOpts,
) -> Result<Option<JobRecorder>, Refusal> {
    if !(admitted.record || opts.all) {
        return Ok(None);
    }
    let file = recording_file(&opts.dir, id, &admitted.name);
    let info = RecordingInfo {
        program_name: admitted.name.clone(),
        program_text: String::from_utf8_lossy(&admitted.text).into_owned(),
        dialect: admitted.dialect.id().to_string(),
        machine_toml: opts.machine_toml.clone(),
        machine_name: machine.name.clone(),
        rate_hz: machine.interpolation.rate_hz,
        // G33 leads by it (the controller's executor), so the recording
        // says by how much (`cnc plot --thread` of the recording)
        setpoint_delay_ms: Some(machine.interpolation.setpoint_delay_ms),
    };
    std::fs::create_dir_all(&opts.dir)
        .map_err(|e| format!("{}: {e}", opts.dir.display()))
        .and_then(|_| JobRecorder::create(&file, info, machine))
        .map(Some)
        .map_err(|e| Refusal(format!("cannot record the job: {e}")))
}

/// The most bytes of text (message and recording path) a reply carries.
///
/// A reply is kept in one DDS datagram: rustdds 0.15 writes a fragmented
/// reply with inline QoS (every service reply: the request's identity)
/// with one stray byte (`DataFrag` writes the `Option` of its parameter
/// list), which a debug build's DDS thread dies on (a `debug_assert`: the
/// node then neither publishes nor answers); a release build sends that
/// byte too. Datagrams to a Fast DDS peer hold about 1,300 bytes of reply;
/// 1,000 leaves room for the rest.
pub const MAX_REPLY_TEXT: usize = 1000;

/// `reply` with its message cut ([`fit_reply`]) so that message and
/// recording path (counted up to 500 bytes) fit in [`MAX_REPLY_TEXT`].
pub fn fit_run_reply(mut reply: RunProgramResponse) -> RunProgramResponse {
    reply.message = fit_reply(
        &reply.message,
        MAX_REPLY_TEXT - reply.recording.len().min(500),
    );
    reply
}

/// `text` cut to at most `max` bytes: whole lines while they fit, then
/// `... and N more errors` for the error lines left out (counting those a
/// trailing `... and N more errors` already stood for); a single line
/// that does not fit is cut at a character boundary and ends in `...`.
pub fn fit_reply(text: &str, max: usize) -> String {
    if text.len() <= max {
        return text.to_string();
    }
    let more_of = |l: &str| {
        l.strip_prefix("... and ")
            .and_then(|r| r.strip_suffix(" more errors"))
            .and_then(|n| n.parse::<u64>().ok())
    };
    let mut out = String::new();
    let mut left_out = 0u64;
    // room for the summary line
    let room = max.saturating_sub(40);
    for l in text.split('\n') {
        let sep = usize::from(!out.is_empty());
        if left_out == 0 && out.len() + sep + l.len() <= room {
            if sep == 1 {
                out.push('\n');
            }
            out.push_str(l);
            continue;
        }
        left_out += more_of(l).unwrap_or(1);
    }
    if out.is_empty() {
        // one line longer than the room: cut it
        let mut end = room.min(text.len());
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let first = text.split('\n').next().unwrap_or_default();
        return format!("{}...", &first[..end.min(first.len())]);
    }
    out.push_str(&format!("\n... and {left_out} more errors"));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_fit_in_one_datagram() {
        let errors: Vec<String> = (1..=30)
            .map(|l| format!("line {l}, column 1: unexpected character '`': expected an address letter and a number"))
            .collect();
        let text = errors.join("\n");
        assert_eq!(fit_reply(&text, 10_000), text);
        let short = fit_reply(&text, 1000);
        assert!(short.len() <= 1000, "{}", short.len());
        let lines: Vec<&str> = short.lines().collect();
        let kept = lines.len() - 1;
        assert_eq!(lines[..kept], errors[..kept]);
        assert_eq!(lines[kept], format!("... and {} more errors", 30 - kept));
        // a summary of errors not kept by the check counts too
        let text = format!("{}\n... and 500 more errors", errors.join("\n"));
        let short = fit_reply(&text, 1000);
        assert!(
            short.ends_with(&format!("... and {} more errors", 530 - kept)),
            "{short}"
        );
        // one long line (a long program_path): cut at a character boundary
        let long = format!("program_path '{}' may not contain '..'", "é".repeat(2000));
        let cut = fit_reply(&long, 1000);
        assert!(cut.len() <= 1000 && cut.ends_with("..."), "{}", cut.len());
        assert!(cut.starts_with("program_path 'éé"));
    }

    #[test]
    fn a_reply_with_a_recording_keeps_room_for_its_path() {
        let errors: Vec<String> = (1..=30)
            .map(|l| format!("line {l}, column 1: unexpected character '`': expected an address letter and a number"))
            .collect();
        let reply = RunProgramResponse {
            accepted: false,
            message: errors.join("\n"),
            job_id: 0,
            estimated_duration: 0.0,
            recording: "r".repeat(300),
        };
        let r = fit_run_reply(reply.clone());
        assert!(r.message.len() <= 700, "{}", r.message.len());
        assert_eq!(r.message, fit_reply(&reply.message, 700));
        assert_eq!(r.recording, reply.recording);
        // a recording path counts up to 500 bytes
        let r = fit_run_reply(RunProgramResponse {
            recording: "r".repeat(5000),
            ..reply.clone()
        });
        assert_eq!(r.message, fit_reply(&reply.message, 500));
        // a short message is kept as it is
        let r = fit_run_reply(RunProgramResponse {
            message: "ok".into(),
            ..reply
        });
        assert_eq!(r.message, "ok");
    }
}
