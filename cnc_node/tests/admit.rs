//! Job admission as the node's check worker does it, without DDS: the
//! refusals and their texts, the dry run's estimate, programs by path, the
//! recording's file, and the start a job is checked from (a job admitted
//! while the machine stood elsewhere is refused by the controller, never
//! run from a start it was not checked from).

use cnc_core::Machine;
use cnc_msgs::RunProgramRequest;
use cnc_node::admit::{admit, recorder, recording_file, Admitted, RecordOpts, Refusal};
use cnc_node::controller::{Controller, State};
use std::path::Path;

const MS: i64 = 1_000_000;
const T0: i64 = 1_795_000_000 * 1_000_000_000;

fn text(program: &str) -> RunProgramRequest {
    RunProgramRequest {
        program: program.into(),
        ..Default::default()
    }
}

fn path(program_path: &str) -> RunProgramRequest {
    RunProgramRequest {
        program_path: program_path.into(),
        ..Default::default()
    }
}

/// Admission on the mill at home, programs by path from `dir`.
fn admit_at_home(req: &RunProgramRequest, m: &Machine, dir: &Path) -> Result<Admitted, Refusal> {
    admit(req, m, &[0.0, 0.0, 0.0], dir)
}

/// Ticks the controller until its job ends; the cycles it took.
fn run_out(ctl: &mut Controller, k: &mut i64) -> u64 {
    let mut n = 0;
    while ctl.state() == State::Running && n < 100_000 {
        *k += 1;
        n += 1;
        ctl.tick(T0 + *k * MS);
    }
    n
}

#[test]
fn a_program_over_max_program_bytes_is_refused_as_text_and_by_path() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = Machine::builtin_mill();
    m.limits.max_program_bytes = 20;
    let prog = "G01 X10 Y10 F600\nG01 X20\n"; // 25 bytes
    std::fs::write(dir.path().join("long.nc"), prog).unwrap();
    let e = admit_at_home(&text(prog), &m, dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "the program is 25 bytes, over the machine's limit of 20 bytes (limits.max_program_bytes)"
    );
    let e = admit_at_home(&path("long.nc"), &m, dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "the program is 25 bytes, over the machine's limit of 20 bytes (limits.max_program_bytes)"
    );
    // the reply to a refusal
    let r = e.reply();
    assert!(!r.accepted);
    assert_eq!(r.message, e.0);
    assert_eq!((r.job_id, r.estimated_duration), (0, 0.0));
    assert_eq!(r.recording, "");
    // at the limit: admitted
    m.limits.max_program_bytes = 25;
    assert!(admit_at_home(&text(prog), &m, dir.path()).is_ok());
    assert!(admit_at_home(&path("long.nc"), &m, dir.path()).is_ok());
}

#[test]
fn exactly_one_of_program_and_program_path() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    std::fs::write(dir.path().join("a.nc"), "G01 X10 F600\n").unwrap();
    let both = RunProgramRequest {
        program: "G01 X10 F600\n".into(),
        program_path: "a.nc".into(),
        ..Default::default()
    };
    for req in [both, RunProgramRequest::default()] {
        let e = admit_at_home(&req, &m, dir.path()).unwrap_err();
        assert_eq!(e.0, "exactly one of program and program_path must be set");
    }
}

#[test]
fn a_program_path_stays_in_the_program_directory() {
    let dir = tempfile::tempdir().unwrap();
    let progs = dir.path().join("programs");
    std::fs::create_dir_all(&progs).unwrap();
    std::fs::write(progs.join("a.nc"), "G01 X10 F600\n").unwrap();
    std::fs::write(dir.path().join("outside.nc"), "G01 X10 F600\n").unwrap();
    let m = Machine::builtin_mill();
    let a = admit_at_home(&path("a.nc"), &m, &progs).unwrap();
    assert_eq!(a.name, "a.nc");
    assert_eq!(a.text, b"G01 X10 F600\n");
    let e = admit_at_home(&path("../outside.nc"), &m, &progs).unwrap_err();
    assert_eq!(e.0, "program_path '../outside.nc' may not contain '..'");
    let e = admit_at_home(&path("nope.nc"), &m, &progs).unwrap_err();
    assert_eq!(
        e.0,
        "program_path 'nope.nc': no such file in the program directory"
    );
}

#[test]
fn an_unknown_dialect_is_refused_and_none_means_the_machines() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let req = RunProgramRequest {
        dialect: "fanuc".into(),
        ..text("G01 X10 F600\n")
    };
    let e = admit_at_home(&req, &m, dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "unknown dialect 'fanuc' (expected \"cnc836\" or \"heidenhain\")"
    );
    let a = admit_at_home(&text("G01 X10 F600\n"), &m, dir.path()).unwrap();
    assert_eq!(a.dialect, m.dialect);
    // a block of the HEIDENHAIN dialect (ends in '*'): named in any case
    let req = RunProgramRequest {
        dialect: "HEIDENHAIN".into(),
        ..text("N10 G01 X+10 F600 *\n")
    };
    let a = admit_at_home(&req, &m, dir.path()).unwrap();
    assert_eq!(a.dialect, cnc_core::Dialect::Heidenhain);
    // the same as the mill's own dialect, cnc836
    let e = admit_at_home(&text("N10 G01 X+10 F600 *\n"), &m, dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "line 1, column 19: block N10: unexpected character '*': expected an address letter and a number; '*' ends a block only in heidenhain, not in cnc836"
    );
}

#[test]
fn a_check_error_is_refused_with_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let prog = "G01 X10 F600\nG01 X`5\nG01 X20\nG01 X600\n";
    let e = admit_at_home(&text(prog), &m, dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "line 2, column 6: expected a number after address 'X', found '`'\n\
         line 4, column 5: travel limit: the move ends at X 600, outside the axis range 0..500"
    );
}

#[test]
fn a_dry_run_is_admitted_with_the_checks_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let req = RunProgramRequest {
        dry_run: true,
        ..text("G01 X100 F6000\n")
    };
    let a = admit_at_home(&req, &m, dir.path()).unwrap();
    assert!(a.dry_run);
    // 100 mm at 100 mm/s, 50 ms more to reach the speed and to stop at
    // 2000 mm/s², then the line's own path filter settles on the end (a
    // line from rest to rest: 10 samples at the bundled 200 m/s³, a tick's
    // wait before it and a hold of 10 ticks): whole ticks of 1 ms
    assert!(
        (1.060..1.062).contains(&a.estimated_duration_s),
        "{}",
        a.estimated_duration_s
    );
    assert_eq!(a.estimated_duration_s, a.ticks as f64 * m.dt());
    assert_eq!(a.start, [0.0, 0.0, 0.0]);
    let r = a.reply(0, String::new());
    assert!(r.accepted);
    assert_eq!(r.message, "");
    assert_eq!(r.job_id, 0);
    assert_eq!(r.estimated_duration, a.estimated_duration_s);
}

#[test]
fn a_job_checked_before_the_machine_moved_is_refused_not_run_from_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let mut ctl = Controller::new(m.clone());
    let mut k = 0;
    // a relative program admitted while the machine stands at home: its
    // check went from X0 to X10
    let rel = text("G91 G01 X10 F600\n");
    let checked = admit(&rel, &m, ctl.positions(), dir.path()).unwrap();
    assert_eq!(checked.start, [0.0, 0.0, 0.0]);
    // before it starts, another job moves the machine to X50 Y20
    let other = admit(
        &text("G01 X50 Y20 F6000\n"),
        &m,
        ctl.positions(),
        dir.path(),
    )
    .unwrap();
    ctl.start(other.job(1)).unwrap();
    assert!(run_out(&mut ctl, &mut k) > 500);
    assert_eq!(ctl.positions(), [50.0, 20.0, 0.0]);
    // the relative job now would go from X50 to X60: refused, both starts named
    let e = ctl.start(checked.job(2)).unwrap_err();
    assert_eq!(
        e,
        "the machine moved since the program was checked: checked from X0 Y0 Z0, now at X50 Y20 Z0 (mm); send it again"
    );
    // nothing runs: the machine stays where it stands, idle, and the
    // status still shows job 1
    for _ in 0..100 {
        k += 1;
        let t = ctl.tick(T0 + k * MS);
        assert_eq!(t.positions, [50.0, 20.0, 0.0]);
        assert_eq!(t.state, State::Idle);
    }
    assert_eq!(ctl.status().job_id, 1);
    assert_eq!(ctl.status().last_error, "");
    // sent again, it is checked from X50 Y20 and runs from there, to X60
    let again = admit(&rel, &m, ctl.positions(), dir.path()).unwrap();
    assert_eq!(again.start, [50.0, 20.0, 0.0]);
    ctl.start(again.job(2)).unwrap();
    assert!(run_out(&mut ctl, &mut k) > 500);
    assert_eq!(ctl.positions(), [60.0, 20.0, 0.0]);
    assert_eq!(ctl.status().job_id, 2);
}

#[test]
fn a_job_checked_at_home_never_leaves_the_travel_range_from_where_the_machine_moved() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let mut ctl = Controller::new(m.clone());
    let mut k = 0;
    let rel = text("G91 G01 X10 F600\n");
    let checked = admit(&rel, &m, ctl.positions(), dir.path()).unwrap();
    // another job moves X to 495, 5 mm short of its end of travel (500)
    let other = admit(&text("G01 X495 F15000\n"), &m, ctl.positions(), dir.path()).unwrap();
    ctl.start(other.job(1)).unwrap();
    run_out(&mut ctl, &mut k);
    assert_eq!(ctl.positions(), [495.0, 0.0, 0.0]);
    // from there the program would end at X505: never started ...
    let e = ctl.start(checked.job(2)).unwrap_err();
    assert!(
        e.contains("checked from X0 Y0 Z0, now at X495 Y0 Z0 (mm)"),
        "{e}"
    );
    k += 1;
    assert_eq!(ctl.tick(T0 + k * MS).positions, [495.0, 0.0, 0.0]);
    // ... and sent again, the check from X495 refuses it
    let e = admit(&rel, &m, ctl.positions(), dir.path()).unwrap_err();
    assert_eq!(
        e.0,
        "line 1, column 9: travel limit: the move ends at X 505, outside the axis range 0..500"
    );
}

#[test]
fn a_position_short_of_the_machines_joints_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    let e = admit(&text("G01 X10 F600\n"), &m, &[0.0, 0.0], dir.path()).unwrap_err();
    assert_eq!(e.0, "the machine's position has 2 joints, the machine 3");
    // entries past the joints are not part of the start
    let lathe = Machine::builtin_lathe();
    let a = admit(
        &text("G01 Z10 F600\n"),
        &lathe,
        &[100.0, 20.0, 0.0],
        dir.path(),
    )
    .unwrap();
    assert_eq!(a.start, [100.0, 20.0]);
}

#[test]
fn recordings_are_made_when_asked_for_named_after_the_job_and_program() {
    let dir = tempfile::tempdir().unwrap();
    let m = Machine::builtin_mill();
    assert_eq!(
        recording_file(Path::new("rec"), 3, "sub/my part (1).nc"),
        Path::new("rec/job_3_mypart1.mcap")
    );
    assert_eq!(
        recording_file(Path::new("rec"), 1, "program.nc"),
        Path::new("rec/job_1_program.mcap")
    );
    let opts = RecordOpts {
        dir: dir.path().join("recordings/new"),
        all: false,
        machine_toml: "name = \"mill\"\n".into(),
    };
    let plain = admit_at_home(&text("G01 X10 F600\n"), &m, dir.path()).unwrap();
    assert_eq!(plain.name, "program.nc");
    assert!(recorder(&plain, 1, &m, &opts).unwrap().is_none());
    assert!(!opts.dir.exists(), "nothing made for a job not recorded");
    // asked for: the directory and the file are made
    let req = RunProgramRequest {
        record: true,
        ..text("G01 X10 F600\n")
    };
    let asked = admit_at_home(&req, &m, dir.path()).unwrap();
    let rec = recorder(&asked, 7, &m, &opts).unwrap().expect("a recorder");
    assert_eq!(rec.file, opts.dir.join("job_7_program.mcap"));
    assert!(rec.file.is_file());
    let r = asked.reply(7, rec.file.display().to_string());
    assert!(r.accepted);
    assert_eq!(r.job_id, 7);
    assert_eq!(r.recording, rec.file.display().to_string());
    let file = rec.file.clone();
    rec.finish().unwrap();
    // the recording says how far G33 led the setpoints: the machine's
    // setpoint delay (`cnc plot --thread` of the recording pairs them so)
    let bag = cnc_node::bag::Bag::read(&file).unwrap();
    assert_eq!(
        bag.metadata["cnc"]
            .get("setpoint_delay_ms")
            .map(String::as_str),
        Some(m.interpolation.setpoint_delay_ms.to_string().as_str())
    );
    // every job with the node's --record-all
    let all = RecordOpts {
        all: true,
        ..opts.clone()
    };
    assert!(recorder(&plain, 8, &m, &all).unwrap().is_some());
    // a directory that cannot be made: refused with the reason
    std::fs::write(dir.path().join("file"), "").unwrap();
    let bad = RecordOpts {
        dir: dir.path().join("file/sub"),
        ..all
    };
    let Err(e) = recorder(&plain, 9, &m, &bad) else {
        panic!("a recorder in {}", bad.dir.display());
    };
    assert!(
        e.0.starts_with(&format!("cannot record the job: {}: ", bad.dir.display())),
        "{e}"
    );
}
