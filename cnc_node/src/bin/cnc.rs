//! `cnc`: check and simulate CNC programs offline.

use clap::{Parser, Subcommand};
use cnc_core::{check, CheckReport, Dialect, Machine, V3};
use cnc_node::files::{dialect_for, dialect_of_name, load_machine, machine_hint_for, open_program};
use cnc_node::offline::{run, CsvSink, SimSummary, Sink, Step};
use cnc_node::record::{RecordingInfo, SimRecorder};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "cnc",
    version,
    about = "CNC controller: check and simulate lathe and mill programs"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Check a program before motion: every error with line and column, or a
    /// one-line summary (blocks, estimated cycle time, bounding box).
    Check {
        /// the program file
        file: PathBuf,
        /// cnc836 or heidenhain (default: the machine file's)
        #[arg(long)]
        dialect: Option<Dialect>,
        /// machine file, or a bundled machine: mill, lathe
        #[arg(long, default_value = "mill")]
        machine: String,
    },
    /// Run a program offline against the simulated axes and spindle.
    Simulate {
        file: PathBuf,
        #[arg(long)]
        dialect: Option<Dialect>,
        #[arg(long, default_value = "mill")]
        machine: String,
        /// interpolation rate, Hz (default: the machine file's)
        #[arg(long)]
        rate: Option<f64>,
        /// write one row per sample: t, setpoint per joint, actual per joint (mm)
        #[arg(long)]
        csv: Option<PathBuf>,
        /// record the run to an MCAP file (ROS 2 profile, as `ros2 bag record -s mcap`)
        #[arg(long)]
        mcap: Option<PathBuf>,
    },
    /// Plot the programmed path, the setpoints and the simulated actual path
    /// of a program or a recording (.mcap) to SVG or PNG (with G41/G42 also
    /// the programmed contour, the nose- or cutter-centre path and the
    /// imaginary tip's path); with --thread, the lead error of a G33 thread
    /// pass against the spindle angle.
    Plot {
        /// a program, or a recording (.mcap)
        file: PathBuf,
        /// output file of the path plot, .svg or .png; a program with
        /// G41/G42 adds the programmed contour (tool radius 0), the nose-
        /// (cutter-) centre path, on a lathe the imaginary tip's path, the
        /// tool at the ends of the compensated blocks, and the compensated
        /// part zoomed when it is small in the whole view
        #[arg(short, long, required_unless_present = "thread")]
        out: Option<PathBuf>,
        /// (G33) output file, .svg or .png, of the lead error of a thread
        /// pass against the spindle angle: of a program, its offline run
        /// against the simulated spindle; of a recording, its setpoints and
        /// joint states against its recorded spindle encoder
        #[arg(long)]
        thread: Option<PathBuf>,
        /// which G33 pass --thread plots, 1 = the first
        #[arg(long, default_value_t = 1, requires = "thread")]
        pass: usize,
        /// (programs) cnc836 or heidenhain (default: the machine file's)
        #[arg(long)]
        dialect: Option<Dialect>,
        /// (programs) machine file, or a bundled machine: mill, lathe
        #[arg(long, default_value = "mill")]
        machine: String,
    },
    /// MCAP recordings: record, compare, replay, rerun, recover.
    Bag {
        #[command(subcommand)]
        cmd: BagCmd,
    },
    /// Send a program to a running controller node (ROS 2 service
    /// <namespace>/run_program), follow its status to the end, print a summary.
    Run {
        /// the program file (sent as text)
        file: Option<PathBuf>,
        /// send this path (inside the node's program directory) instead of text
        #[arg(long, conflicts_with = "file")]
        path: Option<String>,
        #[arg(long)]
        dialect: Option<Dialect>,
        #[arg(long, default_value = "/cnc")]
        namespace: String,
        /// DDS domain (default: ROS_DOMAIN_ID, else 0)
        #[arg(long)]
        domain: Option<u16>,
        /// check and estimate only
        #[arg(long)]
        dry_run: bool,
        /// ask the node to record the job (MCAP, in its recording directory)
        #[arg(long)]
        record: bool,
        /// seconds to wait for the node
        #[arg(long, default_value_t = 30.0, value_parser = seconds, allow_hyphen_values = true)]
        wait: f64,
    },
    /// Abort the running job (<namespace>/abort): it decelerates along its
    /// path and ends.
    Abort {
        #[command(flatten)]
        at: Controller,
    },
    /// Feed hold (<namespace>/feed_hold): the job decelerates along its path
    /// and waits.
    Hold {
        #[command(flatten)]
        at: Controller,
    },
    /// Resume a held job.
    Resume {
        #[command(flatten)]
        at: Controller,
    },
    /// Set the feed override, percent (0..200), on <namespace>/feed_override,
    /// and wait until the controller shows it.
    Override {
        percent: f64,
        #[command(flatten)]
        at: Controller,
    },
    /// Print the controller's status (state, job, line, modal codes, tool,
    /// spindle, override, progress, last error).
    Status {
        #[command(flatten)]
        at: Controller,
    },
    /// Print the machine's URDF, as cnc_node publishes it (robot_description).
    Urdf {
        /// machine file, or a bundled machine: mill, lathe
        #[arg(long, default_value = "mill")]
        machine: String,
    },
}

/// Which running controller a command talks to.
#[derive(clap::Args)]
struct Controller {
    #[arg(long, default_value = "/cnc")]
    namespace: String,
    /// DDS domain (default: ROS_DOMAIN_ID, else 0)
    #[arg(long)]
    domain: Option<u16>,
    /// seconds to wait for the node
    #[arg(long, default_value_t = 10.0, value_parser = seconds, allow_hyphen_values = true)]
    wait: f64,
}

impl Controller {
    fn target(self) -> cnc_node::client::Target {
        cnc_node::client::Target {
            namespace: self.namespace,
            domain: self.domain.unwrap_or_else(cnc_msgs::ros::domain_from_env),
            wait: std::time::Duration::from_secs_f64(self.wait.clamp(0.1, 3600.0)),
        }
    }
}

#[derive(Subcommand)]
enum BagCmd {
    /// Record the live topics of a controller and its simulator (like
    /// `ros2 bag record`) until Ctrl-C or --duration.
    Record {
        #[arg(short, long)]
        out: PathBuf,
        #[arg(long, default_value = "/cnc")]
        namespace: String,
        #[arg(long, default_value = "/sim")]
        sim_namespace: String,
        #[arg(long)]
        domain: Option<u16>,
        /// seconds (more than 0)
        #[arg(long, value_parser = positive_seconds, allow_hyphen_values = true)]
        duration: Option<f64>,
    },
    /// Compare two recordings: per topic and joint the largest deviation,
    /// where it first exceeds the tolerance (time, source line), missing or
    /// extra messages; for a program with G33, each pass's groove phase in
    /// both files (against each file's recorded encoder) and the
    /// difference. Exit 0 only when within tolerance (the phase does not
    /// count).
    Compare {
        a: PathBuf,
        b: PathBuf,
        /// mm; 0 means identical
        #[arg(long, default_value_t = 0.0)]
        tolerance: f64,
    },
    /// Republish a recording on DDS at its own pace.
    Replay {
        file: PathBuf,
        /// playback speed factor, 0.001..1000 (2 plays twice as fast)
        #[arg(long, default_value_t = 1.0, value_parser = replay_rate, allow_hyphen_values = true)]
        rate: f64,
        #[arg(long)]
        domain: Option<u16>,
    },
    /// Run the controller again on the recorded program and machine file and
    /// write a new recording (identical setpoints for the same code).
    Rerun {
        file: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Write a recording as a Rerun file (.rrd) that opens on its own
    /// layout: the path growing as the tool moves (programmed, commanded,
    /// actual), the tool, every joint's setpoint and actual in mm with the
    /// following error, path and spindle speed, the program at its current
    /// line, time in seconds from the start. Runs the converter
    /// (cnc_node/rerun/cnc_rrd.py, built in) with Python and rerun-sdk.
    Rrd {
        file: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        /// Python 3 with rerun-sdk 0.41, mcap and mcap-ros2-support
        /// (default: $CNC_PYTHON, else python3)
        #[arg(long)]
        python: Option<String>,
    },
    /// Make a complete recording from one that was cut short (a killed
    /// recorder: no summary, an unfinished last chunk): every whole chunk's
    /// messages, the schemas, channels, metadata and attachments, written
    /// with a summary.
    Recover {
        file: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
    },
}

/// A number of seconds (`--wait`): finite, 0 or more.
fn seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err("must be a number of seconds, 0 or more".into()),
    }
}

/// A number of seconds (`--duration`): finite, more than 0.
fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("must be a number of seconds, more than 0".into()),
    }
}

/// A playback speed factor (`cnc bag replay --rate`).
fn replay_rate(s: &str) -> Result<f64, String> {
    let (lo, hi) = cnc_node::live::REPLAY_RATES;
    match s.trim().parse::<f64>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!("must be a speed factor from {lo} to {hi}")),
    }
}

/// Refuses, before anything is written, an output that is the input
/// (`recover`'s wording) or the same file as another output.
fn distinct_outputs(input: &Path, outs: &[(&str, Option<&Path>)]) -> Result<(), String> {
    use cnc_node::files::same_file;
    // (the outputs asked for, by their option's name)
    let given: Vec<(&str, &Path)> = outs.iter().filter_map(|&(n, p)| Some((n, p?))).collect();
    for (i, &(name, out)) in given.iter().enumerate() {
        if same_file(input, out) {
            return Err(format!(
                "{}: the output must be another file than the input",
                out.display()
            ));
        }
        if let Some((other, _)) = given[..i].iter().find(|(_, o)| same_file(o, out)) {
            return Err(format!(
                "{}: the outputs of {other} and {name} must be different files",
                out.display()
            ));
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let r = match cli.cmd {
        Cmd::Check {
            file,
            dialect,
            machine,
        } => cmd_check(&file, dialect, &machine),
        Cmd::Simulate {
            file,
            dialect,
            machine,
            rate,
            csv,
            mcap,
        } => cmd_simulate(
            &file,
            dialect,
            &machine,
            rate,
            csv.as_deref(),
            mcap.as_deref(),
        ),
        Cmd::Plot {
            file,
            out,
            thread,
            pass,
            dialect,
            machine,
        } => cmd_plot(
            &file,
            out.as_deref(),
            thread.as_deref().map(|t| (t, pass)),
            dialect,
            &machine,
        ),
        Cmd::Bag { cmd } => cmd_bag(cmd),
        Cmd::Run {
            file,
            path,
            dialect,
            namespace,
            domain,
            dry_run,
            record,
            wait,
        } => cmd_run(
            file.as_deref(),
            path,
            dialect,
            namespace,
            domain,
            (dry_run, record),
            wait,
        ),
        Cmd::Abort { at } => cmd_service(cnc_node::client::abort(&at.target())),
        Cmd::Hold { at } => cmd_service(cnc_node::client::hold(&at.target(), true)),
        Cmd::Resume { at } => cmd_service(cnc_node::client::hold(&at.target(), false)),
        Cmd::Override { percent, at } => {
            cnc_node::client::set_override(&at.target(), percent).map(|s| {
                println!(
                    "feed override {} %",
                    cnc_core::diag::num(s.feed_override * 100.0)
                );
                ExitCode::SUCCESS
            })
        }
        Cmd::Urdf { machine } => cnc_node::urdf::print(&machine).map(|()| ExitCode::SUCCESS),
        Cmd::Status { at } => cnc_node::client::status(&at.target()).map(|s| {
            println!("{}", fmt_status(&s));
            ExitCode::SUCCESS
        }),
    };
    match r {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// A service's answer: its message, exit 0 if it succeeded, 1 if refused.
fn cmd_service(answer: Result<(bool, String), String>) -> Result<ExitCode, String> {
    let (ok, message) = answer?;
    if ok {
        println!("{}", if message.is_empty() { "ok" } else { &message });
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("refused: {message}");
        Ok(ExitCode::from(1))
    }
}

/// The status in one line.
fn fmt_status(s: &cnc_msgs::ControllerStatus) -> String {
    let mut line = format!(
        "{} job {} line {}{} {} T{} S{} override {} % progress {:.1} %",
        cnc_node::client::state_name(s.state),
        s.job_id,
        s.source_line,
        if s.block_number >= 0 {
            format!(" (N{})", s.block_number)
        } else {
            String::new()
        },
        s.active_g_codes.join(" "),
        s.active_tool,
        cnc_core::diag::num(s.spindle_speed_command),
        cnc_core::diag::num(s.feed_override * 100.0),
        s.progress * 100.0
    );
    if !s.last_error.is_empty() {
        line.push_str(&format!(": {}", s.last_error));
    }
    line
}

fn load(machine: &str, rate: Option<f64>) -> Result<Machine, String> {
    let mut m = load_machine(machine)?;
    if let Some(r) = rate {
        if !(r.is_finite() && (10.0..=100_000.0).contains(&r)) {
            return Err(format!("--rate {r}: must be between 10 and 100000 Hz"));
        }
        m.interpolation.rate_hz = r;
        // (the machine's limits hold at this rate too: its jerk filter's
        // length in samples)
        m.validate()
            .map_err(|e| format!("--rate {}: {e}", cnc_core::diag::num(r)))?;
    }
    Ok(m)
}

fn run_check(file: &Path, dialect: Dialect, m: &Machine) -> Result<CheckReport, String> {
    let src = open_program(file, m)?;
    Ok(check(src, dialect, m))
}

/// Prints every error with a snippet (and a hint when the machine does not
/// seem to fit the program); true when the program is good.
fn report_errors(file: &Path, r: &CheckReport, m: &Machine) -> bool {
    if r.ok() {
        return true;
    }
    let origin = file.display().to_string();
    let mut err = std::io::stderr().lock();
    for d in &r.errors {
        let _ = writeln!(err, "{}", d.render(Some(&origin)));
    }
    let more = r.error_count - r.errors.len();
    if more > 0 {
        let _ = writeln!(err, "... and {more} more errors");
    }
    let _ = writeln!(
        err,
        "{}: {} error{}; the program is refused and nothing moves",
        origin,
        r.error_count,
        if r.error_count == 1 { "" } else { "s" }
    );
    if let Some(hint) = machine_hint_for(file, m, r) {
        let _ = writeln!(err, "{hint}");
    }
    false
}

fn fmt_duration(s: f64) -> String {
    let total = s.max(0.0);
    let h = (total / 3600.0).floor();
    let m = ((total - h * 3600.0) / 60.0).floor();
    let sec = total - h * 3600.0 - m * 60.0;
    if h > 0.0 {
        format!("{h:.0}h {m:02.0}m {sec:06.3}s")
    } else if m > 0.0 {
        format!("{m:.0}m {sec:06.3}s")
    } else {
        format!("{sec:.3}s")
    }
}

fn fmt_bbox(m: &Machine, bbox: Option<(V3, V3)>) -> String {
    let Some((lo, hi)) = bbox else {
        return "no motion".into();
    };
    let mut parts = Vec::new();
    for i in m.joint_indices() {
        let (k, name) = if i == 0 && m.diameter_mode() {
            (2.0, "X(dia)")
        } else {
            (1.0, ["X", "Y", "Z"][i])
        };
        parts.push(format!(
            "{name} {}..{}",
            cnc_core::diag::num(lo[i] * k),
            cnc_core::diag::num(hi[i] * k)
        ));
    }
    format!("{} mm", parts.join(" "))
}

fn cmd_check(file: &Path, dialect: Option<Dialect>, machine: &str) -> Result<ExitCode, String> {
    let m = load(machine, None)?;
    let d = dialect_for(Some(file), dialect, &m);
    let r = run_check(file, d, &m)?;
    if !report_errors(file, &r, &m) {
        return Ok(ExitCode::from(1));
    }
    println!(
        "{}: ok ({d}, {}): {} blocks, {} moves, estimated cycle time {} ({} s), bounding box {}",
        file.display(),
        m.name,
        r.blocks,
        r.moves,
        fmt_duration(r.duration_s),
        cnc_core::diag::num(r.duration_s),
        fmt_bbox(&m, r.bbox)
    );
    Ok(ExitCode::SUCCESS)
}

fn cmd_simulate(
    file: &Path,
    dialect: Option<Dialect>,
    machine: &str,
    rate: Option<f64>,
    csv: Option<&Path>,
    mcap: Option<&Path>,
) -> Result<ExitCode, String> {
    distinct_outputs(file, &[("--csv", csv), ("--mcap", mcap)])?;
    let m = load(machine, rate)?;
    let d = dialect_for(Some(file), dialect, &m);
    // checked once; every output is a sink of the one run
    let r = run_check(file, d, &m)?;
    if !report_errors(file, &r, &m) {
        return Ok(ExitCode::from(1));
    }
    let mut recording = match mcap {
        Some(out) => {
            let text =
                std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
            let name = file
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let info = RecordingInfo::offline(&m, &name, &text, d)?;
            Some((SimRecorder::create(out, info, &m, r.ticks)?, out))
        }
        None => None,
    };
    let mut table = match csv {
        Some(p) => Some(CsvSink::create(p, &m)?),
        None => None,
    };
    // a progress bar for runs of more than a few seconds of motion, on a terminal
    let mut bar = (std::io::stdout().is_terminal() && r.ticks > 200_000).then(|| {
        let b = indicatif::ProgressBar::new(r.ticks);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {percent:>3}% sample {pos}/{len} {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Progress(b)
    });
    let mut sinks: Vec<&mut dyn Sink> = Vec::new();
    if let Some((rec, _)) = recording.as_mut() {
        sinks.push(rec);
    }
    if let Some(t) = table.as_mut() {
        sinks.push(t);
    }
    if let Some(b) = bar.as_mut() {
        sinks.push(b);
    }
    let src = open_program(file, &m)?;
    let result = run(src, d, &m, &mut sinks);
    if let Some(Progress(b)) = bar {
        b.finish_and_clear();
    }
    let summary = result?;
    if let Some((rec, out)) = recording {
        let sum = rec.into_summary()?;
        println!(
            "{}: recorded {} messages on {} topics to {} ({} bytes)",
            file.display(),
            sum.messages,
            sum.topics.len(),
            out.display(),
            sum.bytes
        );
    }
    let errs: Vec<String> = m
        .axes
        .iter()
        .zip(&summary.max_following_error)
        .map(|(a, e)| format!("{} {:.4}", a.name, e))
        .collect();
    println!(
        "{}: cycle time {} ({} s, {} samples at {} Hz), largest following error {} mm",
        file.display(),
        fmt_duration(summary.cycle_time),
        cnc_core::diag::num(summary.cycle_time),
        summary.samples,
        m.interpolation.rate_hz,
        errs.join(", ")
    );
    // a run that stopped early (the spindle encoder lost, a thread whose
    // spindle never came to speed) ends as a failed run
    if let Some(f) = &summary.fault {
        eprintln!("{}: the run stopped: {f}", file.display());
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// The progress bar as a sink of the run.
struct Progress(indicatif::ProgressBar);

impl Sink for Progress {
    fn step(&mut self, st: &Step) -> Result<(), String> {
        if st.sample.k.is_multiple_of(10_000) {
            self.0.set_position(st.sample.k);
        }
        Ok(())
    }

    fn finish(&mut self, _: &SimSummary) -> Result<(), String> {
        Ok(())
    }
}

fn cmd_run(
    file: Option<&Path>,
    path: Option<String>,
    dialect: Option<Dialect>,
    namespace: String,
    domain: Option<u16>,
    (dry_run, record): (bool, bool),
    wait: f64,
) -> Result<ExitCode, String> {
    use cnc_node::client::{run, RunOutcome, RunRequest};
    let program = match file {
        Some(f) => std::fs::read_to_string(f).map_err(|e| format!("{}: {e}", f.display()))?,
        None if path.is_some() => String::new(),
        None => return Err("give a program FILE or --path".into()),
    };
    let what = file
        .map(|f| f.display().to_string())
        .or(path.clone())
        .unwrap_or_default();
    // the dialect: given, else the file name's, else the node's machine's
    let dialect = dialect
        .or_else(|| file.and_then(dialect_of_name))
        .or_else(|| path.as_deref().map(Path::new).and_then(dialect_of_name));
    // a progress bar on a terminal
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(1000);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let outcome = run(
        RunRequest {
            namespace,
            domain: domain.unwrap_or_else(cnc_msgs::ros::domain_from_env),
            program,
            program_path: path.unwrap_or_default(),
            dialect: dialect.map(|d| d.to_string()).unwrap_or_default(),
            dry_run,
            record,
            connect_timeout: std::time::Duration::from_secs_f64(wait.clamp(0.1, 3600.0)),
        },
        |s| {
            if let Some(b) = &bar {
                b.set_position((s.progress.clamp(0.0, 1.0) * 1000.0) as u64);
                b.set_message(format!(
                    "line {} {}",
                    s.source_line,
                    cnc_node::client::state_name(s.state)
                ));
            }
        },
    );
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let outcome = outcome?;
    match outcome {
        RunOutcome::Refused(m) => {
            eprintln!("{what}: refused by the controller:\n{m}");
            Ok(ExitCode::from(1))
        }
        RunOutcome::Checked { estimated } => {
            println!(
                "{what}: accepted (dry run), estimated cycle time {}",
                fmt_duration(estimated)
            );
            Ok(ExitCode::SUCCESS)
        }
        RunOutcome::Done {
            job_id,
            estimated,
            wall,
            lines,
            recording,
        } => {
            println!(
                "{what}: job {job_id} done: estimated {}, took {} on the node, up to line {lines}{}",
                fmt_duration(estimated),
                fmt_duration(wall),
                if recording.is_empty() { String::new() } else { format!(", recorded to {recording}") }
            );
            Ok(ExitCode::SUCCESS)
        }
        RunOutcome::Failed { job_id, error } => {
            eprintln!("{what}: job {job_id} failed: {error}");
            Ok(ExitCode::from(1))
        }
        RunOutcome::Aborted { job_id, lines } => {
            eprintln!("{what}: job {job_id} aborted (Ctrl-C) at line {lines}; the axes stopped on the path");
            Ok(ExitCode::from(130))
        }
    }
}

fn cmd_plot(
    file: &Path,
    out: Option<&Path>,
    thread: Option<(&Path, usize)>,
    dialect: Option<Dialect>,
    machine: &str,
) -> Result<ExitCode, String> {
    // both outputs' formats before any work, so a bad one writes nothing
    for o in out.iter().copied().chain(thread.map(|t| t.0)) {
        cnc_node::plot::Format::from_path(o)?;
    }
    distinct_outputs(file, &[("-o", out), ("--thread", thread.map(|t| t.0))])?;
    if file.extension().is_some_and(|e| e == "mcap") {
        // the thread first: a recording it cannot measure writes nothing
        let measured = match thread {
            Some((tout, pass)) => Some((
                cnc_node::plot::plot_recording_thread(file, pass, tout)?,
                tout,
                pass,
            )),
            None => None,
        };
        if let Some(out) = out {
            cnc_node::plot::plot_recording(file, out)?;
            println!("{}: plotted to {}", file.display(), out.display());
        }
        if let Some((r, tout, pass)) = measured {
            println!(
                "{}: thread pass {pass} of {} plotted to {} (measured against the recorded spindle encoder; the program cuts {})",
                file.display(),
                r.series.passes.len(),
                tout.display(),
                r.programmed_passes
            );
            print!("{}", r.describe());
            print_thread_summary(file, &r.series);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let m = load(machine, None)?;
    let d = dialect_for(Some(file), dialect, &m);
    let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // checked once and run once for both figures
    let run =
        cnc_node::plot::ProgramRun::new(&m, d, &name, &text, out.is_some(), thread.is_some())?;
    if let Some(out) = out {
        cnc_node::plot::render(&cnc_node::plot::run_figure(&run)?, out)?;
        println!("{}: plotted to {}", file.display(), out.display());
    }
    if let Some((tout, pass)) = thread {
        let s = cnc_node::plot::plot_run_thread(&run, pass, tout)?;
        println!(
            "{}: thread pass {pass} of {} plotted to {}",
            file.display(),
            s.passes.len(),
            tout.display()
        );
        print_thread_summary(file, s);
    }
    Ok(ExitCode::SUCCESS)
}

/// The numbers of every thread pass, and the fault that stopped the run.
fn print_thread_summary(file: &Path, s: &cnc_node::plot::ThreadErrorSeries) {
    print!("{}", cnc_node::plot::thread_summary(s));
    if let Some(f) = &s.fault {
        eprintln!("{}: the run stopped: {f}", file.display());
    }
}

fn cmd_bag(cmd: BagCmd) -> Result<ExitCode, String> {
    let domain = |d: Option<u16>| d.unwrap_or_else(cnc_msgs::ros::domain_from_env);
    match cmd {
        BagCmd::Record {
            out,
            namespace,
            sim_namespace,
            domain: d,
            duration,
        } => {
            let opts = cnc_node::live::LiveOpts {
                namespace,
                sim_namespace,
                domain: domain(d),
                // (finite and > 0: the argument's parser)
                duration: duration.map(|s| std::time::Duration::from_secs_f64(s.min(1e9))),
            };
            let s = cnc_node::live::record_live(&opts, &out)?;
            println!(
                "{}: {} messages on {} topics, {} bytes",
                out.display(),
                s.messages,
                s.topics.len(),
                s.bytes
            );
            Ok(ExitCode::SUCCESS)
        }
        BagCmd::Compare { a, b, tolerance } => {
            let r = cnc_node::bag::compare(&a, &b, tolerance)?;
            println!("{r}");
            Ok(if r.within() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
        BagCmd::Replay {
            file,
            rate,
            domain: d,
        } => {
            let n = cnc_node::live::replay(&file, rate, domain(d))?;
            println!("{}: {n} messages republished", file.display());
            Ok(ExitCode::SUCCESS)
        }
        BagCmd::Rerun { file, out } => {
            distinct_outputs(&file, &[("-o", Some(&out))])?;
            let s = cnc_node::bag::rerun(&file, &out)?;
            println!(
                "{}: rerun recorded to {} ({} messages)",
                file.display(),
                out.display(),
                s.messages
            );
            Ok(ExitCode::SUCCESS)
        }
        BagCmd::Rrd { file, out, python } => {
            let python = python
                .or_else(|| std::env::var("CNC_PYTHON").ok())
                .unwrap_or_else(|| "python3".into());
            distinct_outputs(&file, &[("-o", Some(&out))])?;
            let printed = cnc_node::bag::write_rrd(&file, &out, &python)?;
            print!("{printed}");
            Ok(ExitCode::SUCCESS)
        }
        BagCmd::Recover { file, out } => {
            let r = cnc_node::recover::recover(&file, &out)?;
            println!("{r}");
            if r.lost() {
                // the output holds what was whole; the rest is named above
                eprintln!(
                    "{}: damaged records were skipped: their contents are not in {}",
                    file.display(),
                    out.display()
                );
                return Ok(ExitCode::from(1));
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}
