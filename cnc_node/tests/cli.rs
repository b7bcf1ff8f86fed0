//! The `cnc` binary as a user runs it.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cnc(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_cnc"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run cnc");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `cnc check examples/mill_pocket.nc` on the machine file `text`
/// (written to a temporary `name`): exit code, stdout, stderr.
fn check_pocket_on(name: &str, text: &str) -> (i32, String, String) {
    let p = tmp(name, text);
    cnc(&[
        "check",
        "examples/mill_pocket.nc",
        "--machine",
        p.to_str().unwrap(),
    ])
}

#[test]
fn check_good_program_prints_one_line_summary() {
    let (code, out, err) = cnc(&["check", "examples/mill_pocket.nc", "--machine", "mill"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(
        out.contains("ok (cnc836, mill): 15 blocks, 11 moves, estimated cycle time 19.845s (19.845 s), bounding box X 0..90 Y 0..70 Z -2..5 mm"),
        "{out}"
    );
    let (code, out, _) = cnc(&["check", "examples/lathe_profile.nc", "--machine", "lathe"]);
    assert_eq!(code, 0);
    assert!(
        out.contains("bounding box X(dia) 20..200 Z -45..20 mm"),
        "{out}"
    );
    let (code, out, _) = cnc(&[
        "check",
        "examples/heidenhain_slot.h",
        "--dialect",
        "heidenhain",
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains("ok (heidenhain, mill): 10 blocks, 7 moves"),
        "{out}"
    );
}

#[test]
fn check_bad_program_lists_every_error_with_snippets() {
    let p = tmp(
        "bad.nc",
        "N10 G00 X10 Y10\nN20 G01 X20\nN30 G02 X30 Y12 I5 J0 F100\nN40 G01 X20 W1\nN50 G00 X900\n",
    );
    let (code, out, err) = cnc(&["check", p.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(out.is_empty());
    for want in [
        "line 2, column 5: block N20: missing feed",
        "line 3, column 5: block N30: arc radius mismatch: start radius 5 mm, end radius 5.3852 mm (difference 0.3852 mm, at most 0.002 mm)",
        "line 4, column 13: block N40: unknown address 'W'",
        "line 5, column 9: block N50: travel limit: the move ends at X 900, outside the axis range 0..500",
        "4 errors; the program is refused and nothing moves",
    ] {
        assert!(err.contains(want), "missing {want:?} in\n{err}");
    }
    // snippets show the offending line and point at the column
    assert!(err.contains("4 | N40 G01 X20 W1"), "{err}");
    assert!(err.contains("bad.nc:4:13"), "{err}");
}

#[test]
fn simulate_prints_cycle_time_and_following_error_and_writes_csv() {
    let csv = std::env::temp_dir().join(format!("cnc-sim-{}.csv", std::process::id()));
    let (code, out, err) = cnc(&[
        "simulate",
        "examples/mill_pocket.nc",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains(
            "cycle time 19.845s (19.845 s, 19846 samples at 1000 Hz), largest following error x "
        ),
        "{out}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows[0], "t,x_set,y_set,z_set,x_act,y_act,z_act");
    assert_eq!(rows.len(), 19846 + 1);
    assert_eq!(rows[1], "0.0,0.0,0.0,0.0,0.0,0.0,0.0");
    // t = k*dt; the last setpoint is the program's end point (X20 Y10 Z5)
    let last: Vec<f64> = rows[19846].split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(last[0], 19845.0 * 0.001);
    assert_eq!(&last[1..4], &[20.0, 10.0, 5.0]);
    // the simulated axis lags but arrives within a micrometre after the dwell
    for j in 0..3 {
        assert!((last[4 + j] - last[1 + j]).abs() < 1e-3, "{last:?}");
    }
    std::fs::remove_file(csv).ok();
}

/// A program whose first motion follows the spindle (G33, G95) runs to
/// its end offline: the executor waits for the simulated encoder's first
/// reading (it once ended the run at its first sample, silently).
#[test]
fn simulate_runs_a_program_that_starts_with_g33_or_g95() {
    for (name, text, col, end, secs) in [
        // Z from 20 to -40 at 1 mm/rev and 200 rpm: 18 s, and the
        // spindle's ramp to speed before it
        (
            "g33.nc",
            "N10 M03 S200\nN20 G33 Z-40 F1\n",
            2,
            -40.0,
            18.0..19.5,
        ),
        // X from radius 100 to 5 at 0.1 mm/rev and 1000 rpm: 57 s
        (
            "g95.nc",
            "N10 M03 S1000\nN20 G95 G01 X10 F0.1\n",
            1,
            5.0,
            57.0..58.5,
        ),
    ] {
        let p = tmp(name, text);
        let csv = p.with_extension("csv");
        let (code, out, err) = cnc(&[
            "simulate",
            p.to_str().unwrap(),
            "--machine",
            "lathe",
            "--csv",
            csv.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{name}: {out}{err}");
        let text = std::fs::read_to_string(&csv).unwrap();
        let last: Vec<f64> = text
            .lines()
            .last()
            .unwrap()
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(last[col], end, "{name}: {last:?}");
        assert!(secs.contains(&last[0]), "{name}: ended at {} s", last[0]);
    }
}

/// A run that stops early offline (here: a spindle too noisy ever to be
/// at speed for G33) says why and fails, as it does on the node.
#[test]
fn simulate_fails_a_run_that_stopped_and_says_why() {
    let machine = std::fs::read_to_string(root().join("config/lathe.toml")).unwrap();
    let noisy = machine.replace("sim_noise_rpm = 0.0", "sim_noise_rpm = 400.0");
    assert_ne!(noisy, machine);
    let m = tmp("noisy_lathe.toml", &noisy);
    let p = tmp("thread.nc", "N10 M03 S200\nN20 G33 Z-40 F1\n");
    let (code, out, err) = cnc(&[
        "simulate",
        p.to_str().unwrap(),
        "--machine",
        m.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(out.contains("cycle time"), "{out}");
    assert!(
        err.contains(
            "thread.nc: the run stopped: line 2: G33 needs the spindle at S200 but it turns at"
        ),
        "{err}"
    );
    // an encoder too coarse for the speed to settle: at speed, never for
    // long enough (it once read "needs S800 but it turns at 802 rpm")
    let coarse = machine.replace(
        "encoder_counts_per_rev = 4096",
        "encoder_counts_per_rev = 64",
    );
    assert_ne!(coarse, machine);
    let m = tmp("coarse_lathe.toml", &coarse);
    let (code, _, err) = cnc(&[
        "simulate",
        "examples/lathe_thread.nc",
        "--machine",
        m.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("the run stopped: line 7: G33 needs the spindle steady at S800: its measured speed (now ")
            && err.contains(" rpm) did not stay within 5 % of it for 90 ms"),
        "{err}"
    );
}

/// `--mcap` and `--csv` together: one run feeds both; the recording is the
/// golden byte for byte (as `record_simulation` writes it) and the CSV the
/// same as a run with `--csv` alone.
#[test]
fn simulate_with_mcap_and_csv_writes_the_golden_and_the_csv() {
    let dir = std::env::temp_dir().join(format!("cnc-cli-both-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (mcap, csv, alone) = (
        dir.join("mill_pocket.mcap"),
        dir.join("both.csv"),
        dir.join("alone.csv"),
    );
    let (code, out, err) = cnc(&[
        "simulate",
        "examples/mill_pocket.nc",
        "--mcap",
        mcap.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2, "{out}");
    assert!(
        // (19 846 setpoints and as many joint states and encoder readings,
        // /tf and poses at 10 Hz, the tool path growing each second)
        lines[0].contains("recorded 63745 messages on 10 topics to"),
        "{out}"
    );
    assert!(lines[1].contains("cycle time 19.845s"), "{out}");
    let golden = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    assert!(std::fs::read(&mcap).unwrap() == golden, "not the golden");
    let (code, _, err) = cnc(&[
        "simulate",
        "examples/mill_pocket.nc",
        "--csv",
        alone.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::read(&csv).unwrap() == std::fs::read(&alone).unwrap());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn simulate_at_ten_kilohertz() {
    let (code, out, err) = cnc(&[
        "simulate",
        "examples/heidenhain_slot.h",
        "--dialect",
        "heidenhain",
        "--rate",
        "10000",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("samples at 10000 Hz"), "{out}");
    let (code, _, err) = cnc(&["simulate", "examples/heidenhain_slot.h", "--rate", "5"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("--rate 5: must be between 10 and 100000 Hz"),
        "{err}"
    );
}

#[test]
fn bad_machine_file_names_the_key() {
    let m = std::fs::read_to_string(root().join("config/mill.toml")).unwrap();
    // the bundled mill with one line changed: the check's exit code and
    // what it printed on stderr
    let with = |from: &str, to: &str| {
        let (code, _, err) = check_pocket_on("m.toml", &m.replacen(from, to, 1));
        (code, err)
    };
    let (code, err) = with(
        "max_acceleration_mm_s2 = 2000.0",
        "max_acceleration_mm_s2 = 0.0",
    );
    assert_eq!(code, 2);
    assert!(
        err.contains(
            "key `axis[0].max_acceleration_mm_s2`: must be between 1 and 10000000 (got 0)"
        ),
        "{err}"
    );
    // a limit no machine has (its estimate was 3 s, its run never ended)
    let (code, err) = with("max_velocity_mm_s = 250.0", "max_velocity_mm_s = 1e-300");
    assert_eq!(code, 2);
    assert!(
        err.contains(
            "key `axis[0].max_velocity_mm_s`: must be between 0.01 and 100000 (got 1e-300)"
        ),
        "{err}"
    );
    // not a regular file: read until the memory ran out
    let (code, _, err) = cnc(&["check", "examples/mill_pocket.nc", "--machine", "/dev/zero"]);
    assert_eq!(
        (code, err.trim()),
        (2, "error: /dev/zero: not a regular file")
    );
    // --rate is held to the machine file's rules: at 100 kHz the bundled
    // mill's jerk filter would need 4000 samples
    let (code, out, err) = cnc(&["simulate", "examples/mill_pocket.nc", "--rate", "100000"]);
    assert_eq!(code, 2, "{out}");
    assert!(
        err.contains("--rate 100000: machine file: key `axis.max_jerk_mm_s3`: too low for the acceleration: the jerk filter would need 4000 samples (at most 1000)"),
        "{err}"
    );
    let (code, _, err) = cnc(&["check", "examples/mill_pocket.nc", "--machine", "drill"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("drill: no such machine file (bundled machines: mill, lathe)"),
        "{err}"
    );
}

#[test]
fn program_over_the_size_limit_is_refused_unread() {
    let m = std::fs::read_to_string(root().join("config/mill.toml")).unwrap();
    let p = tmp(
        "small.toml",
        &m.replacen("max_program_bytes = 67108864", "max_program_bytes = 100", 1),
    );
    let prog = tmp("long.nc", &"G00 X1\n".repeat(20));
    let (code, _, err) = cnc(&[
        "check",
        prog.to_str().unwrap(),
        "--machine",
        p.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains(
            "140 bytes is over the machine's limit of 100 bytes (limits.max_program_bytes)"
        ),
        "{err}"
    );
}

/// `cnc plot REC.mcap --thread` and `cnc bag compare` on a recording of a
/// G33 thread (the measurement itself: `tests/thread_recording.rs`).
#[test]
fn plot_thread_and_compare_of_a_recording() {
    // the thread, recorded offline
    let prog = tmp(
        "groove.nc",
        "N5 G00 X20 Z5\nN10 M03 S800\nN20 G33 Z-40 F1.5 I90\nN30 G00 X30\nN40 Z5\nN50 M30\n",
    );
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("groove.mcap");
    let rec_s = rec.to_str().unwrap();
    let (code, _, err) = cnc(&[
        "simulate",
        prog.to_str().unwrap(),
        "--machine",
        "lathe",
        "--mcap",
        rec_s,
    ]);
    assert_eq!(code, 0, "{err}");
    let svg = dir.path().join("thread.svg");
    let (code, out, err) = cnc(&["plot", rec_s, "--thread", svg.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    eprintln!("{out}");
    assert!(
        out.contains("thread pass 1 of 1 plotted to") && out.contains("the program cuts 1"),
        "{out}"
    );
    assert!(
        out.contains("  pass 1: I90 against the recorded encoder, setpoints at their stamp + 0.000 ms (2287 paired), joint states at their own (2287 paired); synchronized Z 4.640923..-39.640923 mm"),
        "{out}"
    );
    assert!(
        out.contains("  pass 1 (N20, line 3): F1.5 synchronized 87.6..10710.0° (2214 samples); largest error there: setpoint 0.2560 µm (0.699 counts)"),
        "{out}"
    );
    assert!(
        out.contains("    groove phase there (0 = the programmed start angle): setpoint mean +0.0000°, worst 0.0614°, spread 0.1188° (2214 samples); actual mean -0.0256°"),
        "{out}"
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    assert!(text.contains(
        "groove.nc on lathe: G33 Z lead error, pass 1 of 1, recording groove.mcap against its encoder"
    ));
    // both figures of a recording at once
    let path_svg = dir.path().join("path.svg");
    let (code, out, err) = cnc(&[
        "plot",
        rec_s,
        "-o",
        path_svg.to_str().unwrap(),
        "--thread",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        path_svg.exists() && out.contains("groove phase there"),
        "{out}"
    );
    // a pass it does not have, a recording without G33: errors, nothing written
    let none = dir.path().join("none.svg");
    let (code, _, err) = cnc(&[
        "plot",
        rec_s,
        "--thread",
        none.to_str().unwrap(),
        "--pass",
        "2",
    ]);
    assert_eq!(code, 2);
    assert!(
        err.contains("thread pass 2 asked for, the program cuts 1"),
        "{err}"
    );
    let plain = dir.path().join("plain.mcap");
    let plain_nc = tmp("plain.nc", "N5 G00 X20 Z5\nN10 M30\n");
    let (code, _, err) = cnc(&[
        "simulate",
        plain_nc.to_str().unwrap(),
        "--machine",
        "lathe",
        "--mcap",
        plain.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_file(&path_svg).unwrap();
    let (code, _, err) = cnc(&[
        "plot",
        plain.to_str().unwrap(),
        "--thread",
        none.to_str().unwrap(),
        "-o",
        path_svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("cuts no G33 thread"), "{err}");
    assert!(!none.exists() && !path_svg.exists());

    // `cnc bag compare`: the phase of both files, exit code as before
    let (code, out, err) = cnc(&["bag", "compare", rec_s, rec_s]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("thread pass 1 (N20, line 3, I90) groove phase, setpoints: A mean +0.0000° worst 0.0614° (2214 samples), B mean +0.0000° worst 0.0614° (2214 samples), B - A mean +0.0000° worst +0.0000°"),
        "{out}"
    );
    assert!(
        out.contains("thread pass 1 (N20, line 3, I90) groove phase, actual: A mean -0.0256° worst 3.8800° (2213 samples)"),
        "{out}"
    );
    assert!(
        out.trim_end().ends_with("result: within tolerance"),
        "{out}"
    );
}

/// `--wait` and `--duration` that are not a number of seconds (NaN, inf,
/// negative) are usage errors at parsing (exit 2), never a panic in
/// `Duration::from_secs_f64` nor a recording of nothing with exit 0.
#[test]
fn waits_and_durations_must_be_numbers_of_seconds() {
    let wait_err = |v: &str| {
        format!(
            "error: invalid value '{v}' for '--wait <WAIT>': must be a number of seconds, 0 or more\n\nFor more information, try '--help'.\n"
        )
    };
    for v in ["nan", "NaN", "inf", "-inf", "-1", "1e400", "soon"] {
        let eq = format!("--wait={v}");
        let runs: [Vec<&str>; 8] = [
            vec!["status", "--domain", "201", &eq],
            vec!["abort", "--domain", "201", &eq],
            vec!["hold", "--domain", "201", &eq],
            vec!["resume", "--domain", "201", &eq],
            vec!["override", "50", "--domain", "201", &eq],
            vec!["run", "examples/mill_pocket.nc", "--domain", "201", &eq],
            vec!["status", "--domain", "201", "--wait", v],
            vec!["run", "examples/mill_pocket.nc", "--wait", v],
        ];
        for args in runs {
            let (code, out, err) = cnc(&args);
            assert_eq!((code, out.as_str()), (2, ""), "{args:?}: {err}");
            assert_eq!(err, wait_err(v), "{args:?}");
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("x.mcap");
    for v in ["nan", "inf", "-1", "0", "-0"] {
        let (code, out, err) = cnc(&[
            "bag",
            "record",
            "-o",
            rec.to_str().unwrap(),
            "--domain",
            "201",
            "--duration",
            v,
        ]);
        assert_eq!((code, out.as_str()), (2, ""), "{v}: {err}");
        assert_eq!(
            err,
            format!("error: invalid value '{v}' for '--duration <DURATION>': must be a number of seconds, more than 0\n\nFor more information, try '--help'.\n")
        );
        assert!(!rec.exists(), "--duration {v} created the recording");
    }
}

/// `cnc bag replay --rate` outside 0.001..1000 (where a recording's times
/// divided by the rate would not fit a `Duration`, e.g. 1e-25) is a usage
/// error, not a panic.
#[test]
fn replay_rates_outside_their_range_are_usage_errors() {
    for v in [
        "1e-25", "1e-300", "0", "-1", "nan", "inf", "0.0009", "1000.5",
    ] {
        let (code, out, err) = cnc(&[
            "bag",
            "replay",
            "bags/mill_pocket.mcap",
            "--domain",
            "200",
            "--rate",
            v,
        ]);
        assert_eq!((code, out.as_str()), (2, ""), "{v}: {err}");
        assert_eq!(
            err,
            format!("error: invalid value '{v}' for '--rate <RATE>': must be a speed factor from 0.001 to 1000\n\nFor more information, try '--help'.\n")
        );
    }
}

/// An output that is the input, or two outputs that are one file, are
/// refused before anything is written (the program is left as it was).
#[test]
fn outputs_must_be_other_files_than_the_input_and_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = std::fs::read(root().join("examples/mill_pocket.nc")).unwrap();
    let prog = d.join("self.nc");
    std::fs::write(&prog, &text).unwrap();
    let p = prog.to_str().unwrap();
    // the same file spelt another way, and a hard link to it
    let dotted = d.join(".").join("self.nc");
    let linked = d.join("linked.nc");
    std::fs::hard_link(&prog, &linked).unwrap();
    let same_as_input = |out: &Path| {
        format!(
            "error: {}: the output must be another file than the input\n",
            out.display()
        )
    };
    for out in [prog.as_path(), dotted.as_path(), linked.as_path()] {
        let o = out.to_str().unwrap();
        for args in [
            vec!["simulate", p, "--csv", o],
            vec!["simulate", p, "--mcap", o],
            vec!["simulate", p, "--csv", o, "--mcap", o],
        ] {
            let (code, stdout, err) = cnc(&args);
            assert_eq!((code, stdout.as_str()), (2, ""), "{args:?}: {err}");
            assert_eq!(err, same_as_input(out), "{args:?}");
            assert_eq!(
                std::fs::read(&prog).unwrap(),
                text,
                "{args:?} changed the program"
            );
        }
    }
    // two outputs that are one file: neither is written
    let a = d.join("a.csv");
    let a_again = d.join(".").join("a.csv");
    let (code, stdout, err) = cnc(&[
        "simulate",
        p,
        "--csv",
        a.to_str().unwrap(),
        "--mcap",
        a_again.to_str().unwrap(),
    ]);
    assert_eq!((code, stdout.as_str()), (2, ""), "{err}");
    assert_eq!(
        err,
        format!(
            "error: {}: the outputs of --csv and --mcap must be different files\n",
            a_again.display()
        )
    );
    assert!(!a.exists());
    let t = d.join("t.svg");
    let (code, stdout, err) = cnc(&[
        "plot",
        "examples/lathe_thread.nc",
        "--machine",
        "lathe",
        "-o",
        t.to_str().unwrap(),
        "--thread",
        t.to_str().unwrap(),
    ]);
    assert_eq!((code, stdout.as_str()), (2, ""), "{err}");
    assert_eq!(
        err,
        format!(
            "error: {}: the outputs of -o and --thread must be different files\n",
            t.display()
        )
    );
    assert!(!t.exists());
    // a plot onto its own program, a rerun or rrd onto its own recording
    let svg_prog = d.join("prog.svg");
    std::fs::write(&svg_prog, &text).unwrap();
    let s = svg_prog.to_str().unwrap();
    let rec = d.join("rec.mcap");
    std::fs::copy(root().join("bags/mill_pocket.mcap"), &rec).unwrap();
    let r = rec.to_str().unwrap();
    for (args, out) in [
        (vec!["plot", s, "-o", s], &svg_prog),
        (vec!["plot", s, "--thread", s], &svg_prog),
        (vec!["bag", "rerun", r, "-o", r], &rec),
        (vec!["bag", "rrd", r, "-o", r], &rec),
    ] {
        let (code, stdout, err) = cnc(&args);
        assert_eq!((code, stdout.as_str()), (2, ""), "{args:?}: {err}");
        assert_eq!(err, same_as_input(out), "{args:?}");
    }
    assert_eq!(std::fs::read(&svg_prog).unwrap(), text);
    assert_eq!(
        std::fs::read(&rec).unwrap(),
        std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap()
    );
    // distinct files still work
    let csv = d.join("run.csv");
    let (code, _, err) = cnc(&["simulate", p, "--csv", csv.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(csv.exists());
}

/// `[planner] method = "auto"` (the default) as a user meets it: the
/// bundled mill (200 m/s³) runs the filters; the same machine file at
/// 50 m/s³ plans with the path planner unless it says `"filters"`.
#[test]
fn a_machine_under_200_m_s3_plans_with_the_path_planner_unless_it_says_filters() {
    let mill = std::fs::read_to_string(root().join("config/mill.toml")).unwrap();
    let at_50 = mill.replace("max_jerk_mm_s3 = 2.0e5", "max_jerk_mm_s3 = 5.0e4");
    assert_eq!(at_50.matches("5.0e4").count(), 3);
    let with = |name: &str, method: &str| {
        let text = at_50.replace(
            "lookahead_blocks = 200",
            &format!("lookahead_blocks = 200\n{method}"),
        );
        let (code, out, err) = check_pocket_on(name, &text);
        assert_eq!(code, 0, "{err}");
        let t = out.split("estimated cycle time ").nth(1).unwrap_or("");
        t.split('s').next().unwrap_or("").to_string()
    };
    let (auto, path, filters) = (
        with("auto50.toml", ""),
        with("path50.toml", "method = \"path\""),
        with("filters50.toml", "method = \"filters\""),
    );
    // ("auto" is the path planner's estimate to the millisecond, 0.7 %
    // shorter than the filters' on this program of rests and a G61
    // contour, on blended CAM paths at 50 m/s³ 16 % shorter: README)
    assert_eq!(
        (auto.as_str(), path.as_str(), filters.as_str()),
        ("19.916", "19.916", "20.052")
    );
    // the bundled mill, "auto" or not said: the filters' 19.845 s
    let (code, out, _) = cnc(&["check", "examples/mill_pocket.nc", "--machine", "mill"]);
    assert_eq!(code, 0);
    assert!(out.contains("estimated cycle time 19.845s"), "{out}");
}

/// `[planner] contour_error_mm` (the path planner): what the simulated
/// drive does on a circle of R10 at F6000 under the bundled mill at 50
/// m/s³ (its servo model lags 33 µm per 1000 mm/s² of acceleration). The
/// actual positions' distance from the circle while cutting (the middle
/// half of the circle): 32.8 µm without the budget (1.522 s), 5.26 µm with
/// `contour_error_mm = 0.005`, which slows the circle to keep it (2.469 s;
/// the drive within the budget of the planned path, which G61 keeps
/// within 1 µm of the circle).
#[test]
fn a_contour_error_budget_keeps_the_simulated_drive_on_the_circle() {
    let mill = std::fs::read_to_string(root().join("config/mill.toml")).unwrap();
    let at_50 = mill.replace("max_jerk_mm_s3 = 2.0e5", "max_jerk_mm_s3 = 5.0e4");
    let prog = tmp(
        "circle.nc",
        "N10 G17 G90 G61 G00 X50 Y50 Z0\nN20 G01 X60 F6000\nN30 G02 X60 Y50 I-10 J0\n\
         N40 G01 X70\nN50 M30\n",
    );
    // (the circle's largest actual distance from R10 in its middle half,
    // and the cycle time)
    let run = |name: &str, budget: &str| -> (f64, f64) {
        let text = at_50.replace(
            "lookahead_blocks = 200",
            &format!("lookahead_blocks = 200\n{budget}"),
        );
        let m = tmp(name, &text);
        let csv = m.with_extension("csv");
        let (code, _, err) = cnc(&[
            "simulate",
            prog.to_str().unwrap(),
            "--machine",
            m.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        let rows: Vec<Vec<f64>> = std::fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        // on the circle (centre X50 Y50; under G61 within 1 µm): the
        // setpoints on it and off the lines on Y50
        let r = |x: f64, y: f64| (x - 50.0).hypot(y - 50.0);
        let on: Vec<&Vec<f64>> = rows
            .iter()
            .filter(|p| (r(p[1], p[2]) - 10.0).abs() <= 0.001 + 1e-9 && (p[2] - 50.0).abs() > 1e-9)
            .collect();
        let mid = &on[on.len() / 4..3 * on.len() / 4];
        let worst = mid
            .iter()
            .map(|p| (r(p[4], p[5]) - 10.0).abs())
            .fold(0.0, f64::max);
        (worst, rows.last().unwrap()[0])
    };
    let (free, t_free) = run("free.toml", "");
    let (kept, t_kept) = run("kept.toml", "contour_error_mm = 0.005");
    assert!(free > 0.030, "{free} mm without the budget");
    // (the budget is the drive's error from the planned path, which
    // G61 keeps within 1 µm of the circle)
    assert!(kept <= 0.005 + 0.001, "{kept} mm with a budget of 0.005");
    assert!(t_kept > t_free, "{t_kept} s against {t_free}");
    // refused: not over 0 (at 50 m/s³); on the bundled mill (200 m/s³),
    // which plans with the filters, that do not keep it
    for (file, text, budget, why) in [
        (
            "zero.toml",
            &at_50,
            "0",
            "must be over 0 and at most 10 (got 0)",
        ),
        (
            "filters.toml",
            &mill,
            "0.01",
            "only the path planner keeps it",
        ),
    ] {
        let (code, _, err) = check_pocket_on(
            file,
            &text.replace(
                "lookahead_blocks = 200",
                &format!("lookahead_blocks = 200\ncontour_error_mm = {budget}"),
            ),
        );
        assert_eq!(code, 2, "{file}");
        assert!(
            err.contains(&format!("key `planner.contour_error_mm`: {why}")),
            "{err}"
        );
    }
}
