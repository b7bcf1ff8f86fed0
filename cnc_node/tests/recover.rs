//! Recordings survive a killed process: `cnc bag recover` on files cut at
//! chosen bytes, on the file a SIGKILLed `cnc simulate --mcap` leaves, on a
//! recorder that stops without closing (what a kill leaves in the OS), and
//! on files that are not MCAP.

use cnc_core::Machine;
use cnc_msgs::{ControllerStatus, Float64, JointState, StringMsg};
use cnc_node::record::{
    from_cdr, record_simulation, topics, Recorder, RecordingInfo, CHUNK_SIZE, EPOCH_NS,
    LIVE_CHUNK_SPAN_NS,
};
use cnc_node::recover::{recover, Recovery};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh directory for one test.
fn tmp(test: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("recover_{test}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// One message as a reader sees it: topic, sequence, log time, payload.
type Msg = (String, u32, u64, Vec<u8>);

/// The chunks of a complete recording from its summary, in file order:
/// (start offset, end offset, the chunk's messages in file order).
fn chunks(bytes: &[u8]) -> Vec<(u64, u64, Vec<Msg>)> {
    let s = mcap::Summary::read(bytes).unwrap().unwrap();
    let mut idx = s.chunk_indexes.clone();
    idx.sort_by_key(|c| c.chunk_start_offset);
    idx.iter()
        .map(|c| {
            let mut msgs = Vec::new();
            for m in s.stream_chunk(bytes, c).unwrap() {
                let m = m.unwrap();
                msgs.push((
                    m.channel.topic.clone(),
                    m.sequence,
                    m.log_time,
                    m.data.into_owned(),
                ));
            }
            (
                c.chunk_start_offset,
                c.chunk_start_offset + c.chunk_length,
                msgs,
            )
        })
        .collect()
}

/// Every message of a complete file, in file order, checked against its
/// summary's statistics.
fn messages(bytes: &[u8]) -> Vec<Msg> {
    let s = mcap::Summary::read(bytes).unwrap().expect("a summary");
    let v: Vec<Msg> = mcap::MessageStream::new(bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (
                m.channel.topic.clone(),
                m.sequence,
                m.log_time,
                m.data.into_owned(),
            )
        })
        .collect();
    assert_eq!(s.stats.unwrap().message_count, v.len() as u64);
    v
}

/// Every setpoint decodes, and they are 1 ms apart from EPOCH_NS on.
fn check_setpoints(msgs: &[Msg]) -> usize {
    let mut n = 0;
    for (topic, seq, t, data) in msgs {
        if topic == topics::JOINT_SETPOINTS {
            let js: JointState = from_cdr(data).unwrap();
            assert_eq!(js.name, ["x", "y", "z"]);
            assert_eq!(*t, EPOCH_NS + n as u64 * 1_000_000);
            assert_eq!(*seq, n as u32 + 1);
            n += 1;
        }
    }
    n
}

fn mill_pocket(dir: &Path) -> PathBuf {
    let m = Machine::builtin_mill();
    let text = std::fs::read_to_string(root().join("examples/mill_pocket.nc")).unwrap();
    let p = dir.join("mill_pocket.mcap");
    record_simulation(&m, "mill_pocket.nc", &text, m.dialect, &p).unwrap();
    p
}

/// `cnc bag recover INPUT -o OUT`
fn cnc_recover(input: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cnc"))
        .args(["bag", "recover"])
        .arg(input)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

fn metadata_names(bytes: &[u8]) -> Vec<String> {
    let s = mcap::Summary::read(bytes).unwrap().unwrap();
    s.metadata_indexes.iter().map(|m| m.name.clone()).collect()
}

#[test]
fn cut_recordings_keep_every_complete_chunk() {
    let dir = tmp("cut");
    let full_path = mill_pocket(&dir);
    let full = std::fs::read(&full_path).unwrap();
    let chunks = chunks(&full);
    // the schemas and channels, then message chunks of about CHUNK_SIZE
    // (8 of them since the tool path grows every second in recordings)
    assert_eq!(chunks.len(), 9);
    assert!(chunks[0].2.is_empty());
    let all = messages(&full);
    assert_eq!(all.len(), 63_745);
    assert_eq!(
        chunks.iter().map(|c| c.2.len()).sum::<usize>(),
        all.len(),
        "every message is in a chunk"
    );
    let data_end = chunks.last().unwrap().1;
    // (cut offset, what is dropped): just after a chunk, one byte into the
    // next record, in the middle of a chunk, inside a chunk's header, the
    // summary cut off, the whole file
    let mut cuts: Vec<(u64, Option<&str>)> = Vec::new();
    for c in &chunks[1..] {
        cuts.push((c.1, None));
        cuts.push(((c.0 + c.1) / 2, Some("an unfinished chunk")));
        cuts.push((c.0 + 20, Some("an unfinished chunk")));
    }
    cuts.push((
        chunks[3].1 + 1,
        Some("a record cut off in its opcode and length"),
    ));
    cuts.push((full.len() as u64 - 100, None));
    cuts.push((full.len() as u64, None));
    for (cut, dropped) in cuts {
        let cut_path = dir.join(format!("cut_{cut}.mcap"));
        std::fs::write(&cut_path, &full[..cut as usize]).unwrap();
        let out = dir.join(format!("rec_{cut}.mcap"));
        let r = recover(&cut_path, &out).unwrap();
        let got = std::fs::read(&out).unwrap();
        assert_eq!(r.bytes, got.len() as u64);
        let recovered = messages(&got);
        // exactly the messages of the chunks that end at or before the cut
        let complete: Vec<&(u64, u64, Vec<Msg>)> = chunks.iter().filter(|c| c.1 <= cut).collect();
        let want: Vec<Msg> = complete.iter().flat_map(|c| c.2.clone()).collect();
        assert_eq!(recovered.len(), want.len(), "cut at {cut}: {r}");
        assert!(recovered == want, "cut at {cut}: other messages");
        assert_eq!(r.messages, want.len() as u64);
        assert_eq!(r.chunks as usize, complete.len(), "cut at {cut}");
        let n = check_setpoints(&recovered);
        assert_eq!(
            n,
            want.iter()
                .filter(|m| m.0 == topics::JOINT_SETPOINTS)
                .count()
        );
        if let Some(last) = want.iter().map(|m| m.2).max() {
            assert_eq!(r.end_ns, Some(last));
            let line = r.to_string();
            let up_to = format!("recovered {} messages on ", want.len());
            assert!(line.contains(&up_to), "{line}");
            assert!(
                line.contains(&format!(
                    "up to t = {:.3} s",
                    (last - EPOCH_NS) as f64 * 1e-9
                )),
                "{line}"
            );
        }
        match dropped {
            Some(what) => {
                assert!(r.dropped.as_deref().unwrap().starts_with(what), "{r}");
                let start = if what == "an unfinished chunk" {
                    chunks.iter().find(|c| c.0 <= cut && cut < c.1).unwrap().0
                } else {
                    cut - 1
                };
                assert_eq!(r.dropped_bytes, cut - start, "cut at {cut}");
                assert!(
                    r.to_string()
                        .contains(&format!("dropped {} bytes of {what}", cut - start)),
                    "{r}"
                );
            }
            None => {
                assert_eq!((r.dropped_bytes, r.dropped.as_deref()), (0, None), "{r}");
                // the data end record is there unless the cut is inside the data
                assert_eq!(r.complete, cut >= full.len() as u64 - 100, "cut at {cut}");
            }
        }
        // the job is there whenever its chunk and attachments are: rerun
        // accepts the file
        assert_eq!(r.attachments, ["program.nc", "machine.toml"]);
        let job = cnc_node::bag::Bag::read(&out).unwrap().job().unwrap();
        assert_eq!(job.program_name, "mill_pocket.nc");
        // rosbag2's metadata: kept from a file that had it, else anew with
        // the recovered counts and the new file's name
        assert_eq!(metadata_names(&got), ["cnc", "rosbag2"]);
        let s = mcap::Summary::read(&got).unwrap().unwrap();
        let y = mcap::read::metadata(&got, &s.metadata_indexes[1]).unwrap();
        let y = &y.metadata["serialized_metadata"];
        if r.rosbag2_kept {
            assert!(cut > data_end, "cut at {cut}");
            assert!(y.contains("  - mill_pocket.mcap\n"), "{y}");
        } else {
            assert!(cut <= data_end, "cut at {cut}");
            assert!(y.contains(&format!("  - rec_{cut}.mcap\n")), "{y}");
            assert!(
                y.contains(&format!("\nmessage_count: {}\n", want.len())),
                "{y}"
            );
            assert!(y.ends_with("custom_data: ~\nros_distro: kilted"), "{y}");
        }
    }
    // recovering the complete file gives it back byte for byte: the same
    // writer, the same chunking
    let out = dir.join("again.mcap");
    let r = recover(&full_path, &out).unwrap();
    assert!(r.complete && r.rosbag2_kept, "{r}");
    assert!(std::fs::read(&out).unwrap() == full);
}

#[test]
fn a_recorder_that_never_closes_loses_only_the_open_chunk() {
    // what a kill leaves: the file as the OS has it while the recorder
    // still runs (nothing closed, the file buffer not flushed). Live
    // recordings close a chunk every second of log time.
    let dir = tmp("open");
    let path = dir.join("live.mcap");
    let mut rec = Recorder::create(
        &path,
        RecordingInfo {
            program_name: "p.nc".into(),
            program_text: "G0 X1\n".into(),
            ..Default::default()
        },
    )
    .unwrap();
    rec.set_max_chunk_span(Some(LIVE_CHUNK_SPAN_NS));
    let ch = rec.channel::<Float64>("/a").unwrap();
    // 3.5 s at 1 kHz: chunks 0..999, 1000..1999, 2000..2999 are closed by
    // the messages at 1000, 2000 and 3000 ms; 3000..3499 is open
    for k in 0..3500u64 {
        rec.write(ch, EPOCH_NS + k * 1_000_000, &Float64 { data: k as f64 })
            .unwrap();
    }
    let killed = std::fs::read(&path).unwrap();
    let cut = dir.join("killed.mcap");
    std::fs::write(&cut, &killed).unwrap();
    let out = dir.join("recovered.mcap");
    let r = recover(&cut, &out).unwrap();
    assert_eq!(r.chunks, 4, "{r}"); // schemas and channels, then 3 of messages
    assert_eq!(r.messages, 3002, "{r}"); // + /cnc/program, /cnc/machine_file
    assert_eq!(r.end_ns, Some(EPOCH_NS + 2_999_000_000));
    assert!(
        r.to_string().contains(
            "recovered 3002 messages on 3 channels from 4 complete chunks, up to t = 2.999 s (last log time 1700000002.999000000 s); dropped "
        ),
        "{r}"
    );
    assert!(r
        .dropped
        .as_deref()
        .unwrap()
        .starts_with("an unfinished chunk"));
    let got = std::fs::read(&out).unwrap();
    let mut k = 0u64;
    for (topic, _, t, data) in messages(&got) {
        match topic.as_str() {
            "/a" => {
                assert_eq!(from_cdr::<Float64>(&data).unwrap().data, k as f64);
                assert_eq!(t, EPOCH_NS + k * 1_000_000);
                k += 1;
            }
            topics::PROGRAM => {
                assert_eq!(from_cdr::<StringMsg>(&data).unwrap().data, "G0 X1\n")
            }
            _ => {}
        }
    }
    assert_eq!(k, 3000);
    // a quiet recorder closes its chunk when asked after the span
    rec.close_stale_chunk(EPOCH_NS + 3_000_000_000 + LIVE_CHUNK_SPAN_NS - 1)
        .unwrap();
    assert_eq!(std::fs::read(&path).unwrap().len(), killed.len());
    rec.close_stale_chunk(EPOCH_NS + 3_000_000_000 + LIVE_CHUNK_SPAN_NS)
        .unwrap();
    std::fs::write(&cut, std::fs::read(&path).unwrap()).unwrap();
    let r = recover(&cut, &out).unwrap();
    assert_eq!((r.messages, r.dropped_bytes), (3502, 0), "{r}");
    let s = rec.finish().unwrap();
    assert_eq!(s.messages, 3502);

    // offline recordings are chunked by size alone, so a run at 1 kHz of
    // small messages holds about CHUNK_SIZE per chunk
    let mut rec = Recorder::new(
        std::io::Cursor::new(Vec::new()),
        "x.mcap",
        RecordingInfo::default(),
    )
    .unwrap();
    let ch = rec.channel::<Float64>("/a").unwrap();
    for k in 0..100_000u64 {
        rec.write(ch, EPOCH_NS + k * 1_000_000, &Float64 { data: 0.0 })
            .unwrap();
    }
    let (s, _) = rec.finish_into_inner().unwrap();
    // 43 bytes a message record: 1 MiB holds 24386 of them
    assert_eq!(
        s.chunks,
        1 + 100_000u32.div_ceil((CHUNK_SIZE / 43 + 1) as u32)
    );
}

#[test]
fn a_node_job_recording_loses_at_most_its_last_second() {
    // the node's recorder (JobRecorder) as the node drives it: setpoints
    // at 1 kHz for 2.5 s, the file read while the job still runs
    let dir = tmp("job");
    let path = dir.join("job_1_p.nc.mcap");
    let m = Machine::builtin_mill();
    let info = RecordingInfo {
        program_name: "p.nc".into(),
        program_text: "G01 X10 F600\n".into(),
        ..Default::default()
    };
    let mut job = cnc_node::record::JobRecorder::create(&path, info, &m).unwrap();
    for k in 0..2500u64 {
        let ns = EPOCH_NS + k * 1_000_000;
        job.setpoints(&JointState {
            header: cnc_msgs::Header {
                stamp: cnc_node::record::time_from_ns(ns),
                frame_id: String::new(),
            },
            name: vec!["x".into(), "y".into(), "z".into()],
            position: vec![k as f64 * 1e-6, 0.0, 0.0],
            ..Default::default()
        })
        .unwrap();
    }
    let killed = dir.join("killed.mcap");
    std::fs::write(&killed, std::fs::read(&path).unwrap()).unwrap();
    let out = dir.join("recovered.mcap");
    let r = recover(&killed, &out).unwrap();
    // chunks closed at 1 s and 2 s: setpoints 0..1999 are on disk
    let got = messages(&std::fs::read(&out).unwrap());
    assert_eq!(check_setpoints(&got), 2000, "{r}");
    assert_eq!(r.end_ns, Some(EPOCH_NS + 1_999_000_000), "{r}");
    job.finish().unwrap();
}

/// A program of 48 h of motion: a pocket outline repeated 10000 times.
const LONG: &str = "N10 G17 G90 G94 M03 S3000 T1
N20 G00 X20 Y10 Z5
N30 G01 Z-2 F300
N40 G01 X80 F900
N50 G03 X90 Y20 I0 J10
N60 G01 Y60
N70 G03 X80 Y70 I-10 J0
N80 G01 X20
N90 G03 X10 Y60 I0 J-10
N100 G01 Y20
N110 G03 X20 Y10 I10 J0 G73 L40 Q9999
N120 G00 Z5
N130 M30
";

#[test]
fn a_killed_recording_is_recovered() {
    let dir = tmp("killed");
    let prog = dir.join("long.nc");
    std::fs::write(&prog, LONG).unwrap();
    let killed = dir.join("long.mcap");
    let mut child = Command::new(env!("CARGO_BIN_EXE_cnc"))
        .args(["simulate", prog.to_str().unwrap(), "--mcap"])
        .arg(&killed)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // SIGKILL once more than 3 chunks are on disk
    let start = Instant::now();
    loop {
        let len = std::fs::metadata(&killed).map_or(0, |m| m.len());
        if len > 3 * CHUNK_SIZE / 2 {
            break;
        }
        if let Some(st) = child.try_wait().unwrap() {
            panic!("cnc simulate ended ({st}) before it was killed");
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("cnc simulate wrote {len} bytes in 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let bytes = std::fs::read(&killed).unwrap();
    assert!(mcap::Summary::read(&bytes).is_err() || mcap::Summary::read(&bytes).unwrap().is_none());
    let out = dir.join("recovered.mcap");
    let o = cnc_recover(&killed, &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    // the killed file itself is refused by the other commands, with the way out
    let e = cnc_node::bag::Bag::read(&killed).unwrap_err();
    assert!(e.contains("`cnc bag recover "), "{e}");
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let got = messages(&std::fs::read(&out).unwrap());
    let line = format!(
        "long.mcap: recovered {} messages on 10 channels from",
        got.len()
    );
    assert!(stdout.contains(&line), "{stdout}");
    // (killed mid-chunk, as nearly always; or, rarely, just after one)
    assert!(
        stdout.contains("bytes of an unfinished chunk")
            || stdout.contains("the file ended after a whole record, nothing was cut"),
        "{stdout}"
    );

    // a shorter run of the same start, complete, in process: its chunks
    // that ended on disk before the kill are all recovered, and nothing
    // else. 4 loops (70 s of motion) hold more chunks than the killed file.
    let m = Machine::builtin_mill();
    let reference = dir.join("reference.mcap");
    let short = LONG.replace("Q9999", "Q3");
    record_simulation(&m, "long.nc", &short, m.dialect, &reference).unwrap();
    let full = std::fs::read(&reference).unwrap();
    let chunks = chunks(&full);
    let len = bytes.len() as u64;
    assert!(chunks.last().unwrap().1 > len);
    let on_disk = chunks.iter().filter(|c| c.1 <= len).count();
    // a kill between writing a chunk's data and patching its header leaves
    // the file ending exactly at that chunk's end
    let complete = if chunks[on_disk - 1].1 == len
        && got.len() < chunks[..on_disk].iter().map(|c| c.2.len()).sum()
    {
        on_disk - 1
    } else {
        on_disk
    };
    eprintln!(
        "killed at {len} bytes: {complete} of {} reference chunks complete, {} messages recovered",
        chunks.len(),
        got.len()
    );
    assert!(complete >= 3, "{complete} chunks");
    let want: Vec<Msg> = chunks[..complete]
        .iter()
        .flat_map(|c| c.2.clone())
        .collect();
    assert_eq!(got.len(), want.len());
    // the programs differ in Q, so the program text and the status's
    // progress (sample / samples of the run) differ; every other message
    // is the same
    for (g, w) in got.iter().zip(&want) {
        assert_eq!((&g.0, g.1, g.2), (&w.0, w.1, w.2));
        match g.0.as_str() {
            topics::PROGRAM => {
                assert_eq!(from_cdr::<StringMsg>(&g.3).unwrap().data, LONG)
            }
            topics::STATUS => {
                let mut a: ControllerStatus = from_cdr(&g.3).unwrap();
                let b: ControllerStatus = from_cdr(&w.3).unwrap();
                assert!(a.progress < 0.01, "{}", a.progress);
                a.progress = b.progress;
                assert_eq!(a, b);
            }
            _ => assert!(g == w, "{} #{} differs", g.0, g.1),
        }
    }
    let n = check_setpoints(&got);
    assert!(n > 3000, "{n} setpoints");
}

#[test]
fn not_mcap_is_refused_with_a_clear_error() {
    let dir = tmp("garbage");
    let out = dir.join("out.mcap");
    let cnc = |input: &Path| cnc_recover(input, &out);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "prog.nc",
            b"N10 G00 X10\n".to_vec(),
            "not an MCAP file: it starts with 4E 31 30 20 47 30 30 20 (an MCAP file starts with the 8 bytes 89 4D 43 41 50 30 0D 0A",
        ),
        ("empty.mcap", Vec::new(), "not an MCAP file: the file is empty"),
        (
            "short.mcap",
            vec![0x89, b'M', b'C'],
            "not an MCAP file: it starts with 89 4D 43 and ends there",
        ),
        (
            "noheader.mcap",
            [mcap::MAGIC, &[0x0c, 3, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3]].concat(),
            "not an MCAP file: the magic is not followed by a header record (opcode 0x0c)",
        ),
    ];
    for (name, bytes, want) in cases {
        let p = dir.join(name);
        std::fs::write(&p, &bytes).unwrap();
        let o = cnc(&p);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.starts_with(&format!("error: {}: ", p.display())),
            "{err}"
        );
        assert!(err.contains(want), "{name}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(o.stdout.is_empty());
        assert!(!out.exists(), "{name}: an output was left");
    }
    // a missing input, and the input as its own output
    let o = cnc(&dir.join("missing.mcap"));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.mcap: No such file"));
    let good = mill_pocket(&dir);
    let o = cnc_recover(&good, &good);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("the output must be another file than the input"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // random bytes behind a valid start are cut off, never a panic
    let full = std::fs::read(&good).unwrap();
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    for k in 0..20 {
        let mut b = full[..4000 + 50_000 * k].to_vec();
        let at = b.len() - 3000;
        for v in &mut b[at..] {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            *v = x as u8;
        }
        let p = dir.join("noise.mcap");
        std::fs::write(&p, &b).unwrap();
        let _ = std::fs::remove_file(&out);
        let r: Recovery = recover(&p, &out).unwrap();
        assert!(r.dropped_bytes > 0 || !r.damaged.is_empty(), "{r}");
        messages(&std::fs::read(&out).unwrap());
    }
}

/// The golden mill_pocket recording with `edit` applied, written to `dir`.
fn damaged_pocket(dir: &Path, name: &str, edit: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
    let mut b = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    edit(&mut b);
    let p = dir.join(name);
    std::fs::write(&p, &b).unwrap();
    p
}

/// `cnc ARGS` from the repository root: exit code, stdout, stderr.
fn cnc(args: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_cnc"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Every command that reads the recording `p` refuses it with `why` (and
/// the way out) and writes nothing: no abort on what a header claims.
fn every_reader_refuses(dir: &Path, p: &Path, why: &str) {
    let ps = p.to_str().unwrap();
    let want = format!(
        "error: {ps}: {why}; `cnc bag recover {ps} -o OUT.mcap` skips it and keeps the rest\n"
    );
    let out = dir.join("out.mcap");
    let svg = dir.join("out.svg");
    let runs: [&[&str]; 5] = [
        &["bag", "compare", "bags/mill_pocket.mcap", ps],
        &["plot", ps, "-o", svg.to_str().unwrap()],
        &["bag", "rerun", ps, "-o", out.to_str().unwrap()],
        &["bag", "replay", ps, "--domain", "201"],
        &["bag", "compare", ps, ps, "--tolerance", "1"],
    ];
    for args in runs {
        let (code, stdout, err) = cnc(args);
        assert_eq!(
            (code, stdout.as_str(), err.as_str()),
            (2, "", want.as_str()),
            "{args:?}"
        );
        assert!(!out.exists() && !svg.exists(), "{args:?} wrote an output");
    }
}

/// One flipped bit inside the zstd data of the fifth chunk (the tester's
/// file): the chunk decompresses to other bytes, which once made the mcap
/// reader allocate 1.2 EB and abort. Every reader names the damage;
/// `recover` skips that chunk, keeps every other message and says how
/// many were lost (exit 1).
#[test]
fn a_flipped_bit_in_a_chunk_is_named_and_the_rest_recovered() {
    let dir = tmp("flipped_bit");
    let p = damaged_pocket(&dir, "flipped.mcap", |b| b[862_404] ^= 64);
    let why = "a damaged chunk at byte 831491 (bad CRC: its records hash to 376b7897, its header gives ec35513d)";
    every_reader_refuses(&dir, &p, why);

    let out = dir.join("recovered.mcap");
    let o = cnc_recover(&p, &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stdout}{stderr}");
    assert_eq!(
        stdout.lines().next().unwrap(),
        format!(
            "{}: recovered 55808 messages on 10 channels from 8 complete chunks, up to t = 19.845 s (last log time 1700000019.845000000 s); the file ended properly; skipped {why}; LOST 7937 of the 63745 messages the file's summary counts",
            p.display()
        )
    );
    assert_eq!(
        stderr,
        format!(
            "{}: damaged records were skipped: their contents are not in {}\n",
            p.display(),
            out.display()
        )
    );
    // exactly the messages of the other chunks, as they were
    let golden = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    let want: Vec<Msg> = chunks(&golden)
        .into_iter()
        .filter(|c| c.0 != 831_491)
        .flat_map(|c| c.2)
        .collect();
    let got = messages(&std::fs::read(&out).unwrap());
    assert_eq!(got.len(), 55_808);
    assert!(got == want);
}

/// A flipped bit in the first chunk that holds messages: what the report
/// counts as t starts at the file's first message (from its summary), so
/// the report says from when on it recovered messages, not t = 0 at the
/// first message it kept (it said "up to t = 2.6 s" of a 5.6 s job whose
/// first seconds were lost).
#[test]
fn a_damaged_first_chunk_of_messages_shows_from_when_on_they_were_recovered() {
    let dir = tmp("flipped_first");
    let golden = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    let all = chunks(&golden);
    let (i, first) = all
        .iter()
        .enumerate()
        .find(|(_, c)| !c.2.is_empty())
        .expect("a chunk with messages");
    let (at, end) = (first.0 as usize, first.1 as usize);
    let p = damaged_pocket(&dir, "flipped_first.mcap", |b| b[(at + end) / 2] ^= 64);
    let out = dir.join("recovered.mcap");
    let o = cnc_recover(&p, &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    let t0 = first.2.iter().map(|m| m.2).min().unwrap();
    let kept = all[i + 1..].iter().flat_map(|c| c.2.iter().map(|m| m.2));
    let (from, to) = (kept.clone().min().unwrap(), kept.max().unwrap());
    let line = stdout.lines().next().unwrap();
    let want = format!(
        ", from t = {:.3} s, up to t = {:.3} s (last log time {}.{:09} s); ",
        (from - t0) as f64 * 1e-9,
        (to - t0) as f64 * 1e-9,
        to / 1_000_000_000,
        to % 1_000_000_000
    );
    assert!(line.contains(&want), "{line}\nwanted {want}");
    assert!(from - t0 > 1_000_000, "{}", from - t0);
}

/// The first chunk's `uncompressed_size` set to 2^60: refused by every
/// reader before anything is allocated. `recover` skips the chunk (it
/// holds the schemas and channels); with the file's summary it takes
/// their definitions from there and keeps every message (exit 0, the
/// skipped chunk named); the same file without its summary loses every
/// message, and says so (exit 1).
#[test]
fn a_chunk_header_that_claims_2_to_the_60_bytes_is_damage() {
    let dir = tmp("huge_chunk");
    let p = damaged_pocket(&dir, "huge.mcap", |b| {
        b[232..240].copy_from_slice(&(1u64 << 60).to_le_bytes())
    });
    let why = "a damaged chunk at byte 207 (its header gives an uncompressed size of 1152921504606846976 bytes, more than the 1073741824 bytes a chunk is read up to)";
    every_reader_refuses(&dir, &p, why);

    let out = dir.join("recovered.mcap");
    let o = cnc_recover(&p, &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}");
    assert!(o.stderr.is_empty());
    assert_eq!(
        stdout.lines().next().unwrap(),
        format!(
            "{}: recovered 63745 messages on 10 channels from 8 complete chunks, up to t = 19.845 s (last log time 1700000019.845000000 s); the file ended properly; skipped {why}; took the definitions of 10 channel(s) from the file's summary; all 63745 messages the file's summary counts were recovered",
            p.display()
        )
    );
    let golden = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    assert!(messages(&std::fs::read(&out).unwrap()) == messages(&golden));

    // without the summary (cut where it begins): nothing to define the
    // channels with, every message lost
    let data_end = chunks(&golden).last().unwrap().1 as usize;
    let cut = damaged_pocket(&dir, "huge_cut.mcap", |b| {
        b[232..240].copy_from_slice(&(1u64 << 60).to_le_bytes());
        // the message indexes after the last chunk, then the data end record
        let mut at = data_end;
        while b[at] != 0x0f {
            at += 9 + u64::from_le_bytes(b[at + 1..at + 9].try_into().unwrap()) as usize;
        }
        b.truncate(at);
    });
    let _ = std::fs::remove_file(&out);
    let o = cnc_recover(&cut, &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    assert_eq!(
        stdout.lines().next().unwrap(),
        format!(
            "{}: recovered 0 messages on 0 channels from 8 complete chunks; the file ended after a whole record, nothing was cut; skipped {why}; skipped 63745 message(s) of channels whose definition was lost",
            cut.display()
        )
    );
    assert!(!stdout.contains("nothing was lost"), "{stdout}");
}

/// [`chunk_records`] takes no size on trust: the tester's chunk header
/// variants and a record inside a chunk that claims more than the chunk.
#[test]
fn chunk_records_checks_every_size_of_a_chunk() {
    use cnc_node::chunks::chunk_records;
    use mcap::records::{ChunkHeader, Record};
    let golden = std::fs::read(root().join("bags/mill_pocket.mcap")).unwrap();
    // the first chunk: at byte 207, 3549 bytes of zstd, 15948 uncompressed
    let len = u64::from_le_bytes(golden[208..216].try_into().unwrap()) as usize;
    let Ok(Record::Chunk { header, data }) =
        mcap::read::parse_record(0x06, &golden[216..216 + len])
    else {
        panic!("no chunk at byte 207")
    };
    assert_eq!((header.uncompressed_size, data.len()), (15_948, 3_549));
    assert_eq!(chunk_records(&header, &data).unwrap().len(), 15_948);
    let with_size = |n: u64| ChunkHeader {
        uncompressed_size: n,
        ..header.clone()
    };
    for (size, want) in [
        (15_949, "it decompresses to 15948 bytes, its header gives 15949".to_string()),
        (15_947, "it decompresses to more than 15947 bytes, its header gives 15947".to_string()),
        (
            3_549 * 32_768 + 1,
            "its header gives an uncompressed size of 116293633 bytes, more than its 3549 bytes of zstd data can expand to (116293632)".to_string(),
        ),
        (
            u64::MAX,
            "its header gives an uncompressed size of 18446744073709551615 bytes, more than the 1073741824 bytes a chunk is read up to".to_string(),
        ),
    ] {
        assert_eq!(chunk_records(&with_size(size), &data), Err(want));
    }
    // an uncompressed chunk without a CRC whose one record claims 2^64 - 1 bytes
    let mut rec = vec![0x05];
    rec.extend_from_slice(&u64::MAX.to_le_bytes());
    rec.extend_from_slice(&[1, 2, 3]);
    let plain = ChunkHeader {
        message_start_time: 0,
        message_end_time: 0,
        uncompressed_size: 12,
        uncompressed_crc: 0,
        compression: String::new(),
        compressed_size: 12,
    };
    assert_eq!(
        chunk_records(&plain, &rec),
        Err("a message at byte 0 of its 12 bytes of records claims 18446744073709551615 bytes, more than the 3 left".into())
    );
    assert_eq!(
        chunk_records(&plain, &rec[..10]),
        Err(
            "it is not compressed, yet its header gives 12 bytes for its 10 bytes of records"
                .into()
        )
    );
    let mut bad_zstd = data.to_vec();
    bad_zstd[100] ^= 0xff;
    assert!(chunk_records(&header, &bad_zstd)
        .unwrap_err()
        .starts_with("bad "));
}
