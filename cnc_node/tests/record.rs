//! An offline run of examples/mill_pocket.nc recorded to MCAP and read back
//! with the `mcap` crate's reader.

use cnc_core::source::StrSource;
use cnc_core::Machine;
use cnc_msgs::schema::RosSchema;
use cnc_msgs::*;
use cnc_node::offline::simulate;
use cnc_node::record::{self, from_cdr, record_simulation, topics, EPOCH_NS};
use std::collections::BTreeMap;
use std::path::PathBuf;

fn program() -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/mill_pocket.nc");
    std::fs::read_to_string(p).unwrap()
}

fn out(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name)
}

/// What simulate() gives for a program: samples, first and last setpoints
/// (mm), last source line and block number.
struct Sim {
    samples: u64,
    first: Vec<f64>,
    last: Vec<f64>,
    line: u32,
    block: i64,
}

fn simulated(m: &Machine, text: &str) -> Sim {
    let mut first = None;
    let mut last = Vec::new();
    let mut src = (0, -1);
    let s = simulate(StrSource::new(text), m.dialect, m, |st| {
        if first.is_none() {
            first = Some(st.setpoints.to_vec());
        }
        last = st.setpoints.to_vec();
        src = (
            st.sample.src.line,
            st.sample.src.block_no.map_or(-1, |b| b as i64),
        );
    });
    Sim {
        samples: s.samples,
        first: first.unwrap(),
        last,
        line: src.0,
        block: src.1,
    }
}

#[test]
fn mill_pocket_recording_reads_back() {
    let m = Machine::builtin_mill();
    let text = program();
    let path = out("mill_pocket.mcap");
    let summary = record_simulation(&m, "mill_pocket.nc", &text, m.dialect, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(summary.bytes, bytes.len() as u64);
    let sim = simulated(&m, &text);
    let (samples, first, last) = (sim.samples, &sim.first, &sim.last);

    // header: profile and library
    let mut header = None;
    let mut compressions = Vec::new();
    for r in mcap::read::LinearReader::new(&bytes).unwrap() {
        match r.unwrap() {
            mcap::records::Record::Header(h) => header = Some(h),
            mcap::records::Record::Chunk { header, .. } => compressions.push(header.compression),
            _ => {}
        }
    }
    let header = header.unwrap();
    assert_eq!(header.profile, "ros2");
    assert!(
        header.library.starts_with("cnc_node/"),
        "{}",
        header.library
    );
    assert!(!compressions.is_empty());
    assert!(compressions.iter().all(|c| c == "zstd"), "{compressions:?}");

    // schemas and channels
    let sum = mcap::Summary::read(&bytes).unwrap().unwrap();
    let mut schemas: Vec<(String, String)> = sum
        .schemas
        .values()
        .map(|s| (s.name.clone(), s.encoding.clone()))
        .collect();
    schemas.sort();
    let want: Vec<(String, String)> = [
        "cnc_msgs/msg/ControllerStatus",
        "cnc_msgs/msg/SpindleEncoder",
        "geometry_msgs/msg/PoseStamped",
        "sensor_msgs/msg/JointState",
        "sensor_msgs/msg/PointCloud2",
        "std_msgs/msg/Float64",
        "std_msgs/msg/String",
        "tf2_msgs/msg/TFMessage",
    ]
    .iter()
    .map(|n| (n.to_string(), "ros2msg".to_string()))
    .collect();
    assert_eq!(schemas, want);
    for s in sum.schemas.values() {
        assert_eq!(
            std::str::from_utf8(&s.data).unwrap(),
            cnc_msgs::schema::full_text(&s.name).unwrap()
        );
    }
    assert_eq!(sum.channels.len(), 10);
    let mut by_topic = BTreeMap::new();
    for c in sum.channels.values() {
        assert_eq!(c.message_encoding, "cdr");
        assert!(c.metadata["offered_qos_profiles"].starts_with("- history: keep_last\n"));
        by_topic.insert(c.topic.clone(), c.clone());
    }
    let ty = |t: &str| by_topic[t].schema.as_ref().unwrap().name.clone();
    assert_eq!(ty(topics::JOINT_SETPOINTS), JointState::schema_name());
    assert_eq!(ty(topics::TF), TFMessage::schema_name());
    assert!(by_topic[topics::PROGRAM].metadata["offered_qos_profiles"]
        .contains("durability: transient_local"));

    // message counts
    let stats = sum.stats.as_ref().unwrap();
    let count = |t: &str| {
        stats
            .channel_message_counts
            .get(&by_topic[t].id)
            .copied()
            .unwrap_or(0)
    };
    assert_eq!(count(topics::JOINT_SETPOINTS), samples);
    assert_eq!(count(topics::JOINT_STATES), samples);
    // the mill's spindle: its encoder at every sample
    assert_eq!(count(topics::SPINDLE_ENCODER), samples);
    let k_last = samples - 1;
    assert_eq!(
        count(topics::TF),
        k_last / 10 + 1 + u64::from(!k_last.is_multiple_of(10))
    );
    assert_eq!(count(topics::TOOL_POSE), count(topics::TF));
    // the path so far every second (not at the last sample), the whole
    // path at the end
    assert_eq!(count(topics::TOOLPATH), (k_last - 1) / 1000 + 1);
    assert_eq!(count(topics::PROGRAM), 1);
    assert_eq!(count(topics::MACHINE_FILE), 1);
    assert_eq!(count(topics::SPINDLE_COMMAND), 2); // M03 S3000, M05
    assert!(count(topics::STATUS) >= samples / 100);
    for (t, n) in &summary.topics {
        assert_eq!(count(t), *n, "{t}");
    }
    assert_eq!(stats.message_count, summary.messages);
    assert_eq!(stats.message_start_time, EPOCH_NS);

    // the messages, in order
    let mut setpoints = Vec::new();
    let mut last_status = None;
    let mut clouds: Vec<(u64, PointCloud2)> = Vec::new();
    let mut seq: BTreeMap<u16, u32> = BTreeMap::new();
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        let s = seq.entry(msg.channel.id).or_insert(0);
        *s += 1;
        assert_eq!(msg.sequence, *s, "{}", msg.channel.topic);
        assert_eq!(msg.log_time, msg.publish_time);
        assert_eq!(&msg.data[..4], &[0, 1, 0, 0]);
        match msg.channel.topic.as_str() {
            topics::JOINT_SETPOINTS => {
                let js: JointState = from_cdr(&msg.data).unwrap();
                let ns =
                    js.header.stamp.sec as u64 * 1_000_000_000 + js.header.stamp.nanosec as u64;
                assert_eq!(ns, msg.log_time);
                assert_eq!(msg.log_time, EPOCH_NS + setpoints.len() as u64 * 1_000_000);
                assert_eq!(js.name, ["x", "y", "z"]);
                setpoints.push(js.position);
            }
            topics::STATUS => last_status = Some(from_cdr::<ControllerStatus>(&msg.data).unwrap()),
            topics::TOOLPATH => clouds.push((msg.log_time, from_cdr(&msg.data).unwrap())),
            topics::PROGRAM => {
                assert_eq!(from_cdr::<StringMsg>(&msg.data).unwrap().data, text);
                assert_eq!(msg.log_time, EPOCH_NS);
            }
            topics::MACHINE_FILE => {
                let t = from_cdr::<StringMsg>(&msg.data).unwrap().data;
                assert_eq!(Machine::from_toml(&t).unwrap(), m);
            }
            _ => {}
        }
    }
    assert_eq!(setpoints.len() as u64, samples);
    for (got, want) in [(&setpoints[0], first), (setpoints.last().unwrap(), last)] {
        assert_eq!(got.len(), 3);
        for (g, w) in got.iter().zip(want.iter()) {
            assert!((g - w / 1000.0).abs() <= 1e-12, "{g} vs {w} mm");
        }
    }
    // the program ends at X20 Y10 Z5
    let end = setpoints.last().unwrap();
    for (g, w) in end.iter().zip([0.020, 0.010, 0.005]) {
        assert!((g - w).abs() <= 1e-9, "{end:?}");
    }
    let st = last_status.unwrap();
    assert_eq!(st.state, ControllerStatus::STATE_IDLE);
    assert_eq!(st.progress, 1.0);
    assert_eq!((st.source_line, st.block_number), (sim.line, sim.block));
    assert!(sim.line >= 15, "{}", sim.line);
    let (_, cloud) = clouds.pop().unwrap();
    let growing = clouds;
    // the growing clouds: one a second, each the path up to its time
    // (thinned to at most 5000 points) ending at that time's setpoint
    assert_eq!(growing.len() as u64, (k_last - 1) / 1000);
    for (i, (t, c)) in growing.iter().enumerate() {
        let k = (i as u64 + 1) * 1000;
        assert_eq!(*t, EPOCH_NS + k * 1_000_000);
        assert_eq!(c.header.frame_id, "world");
        assert!(c.width as usize <= record::GROWING_MAX_POINTS);
        assert_eq!(c.data.len(), 12 * c.width as usize);
        let x = |j: usize| f32::from_le_bytes(c.data[j..j + 4].try_into().unwrap());
        let end = c.data.len() - 12;
        let sp = &setpoints[k as usize];
        assert_eq!(
            (x(end), x(end + 4), x(end + 8)),
            (sp[0] as f32, sp[1] as f32, sp[2] as f32)
        );
        assert_eq!((x(0), x(4), x(8)), (0.0, 0.0, 0.0));
    }
    assert_eq!(cloud.header.frame_id, "world");
    assert_eq!(cloud.width as u64, samples);
    assert_eq!(cloud.data.len(), 12 * samples as usize);
    let f = |i: usize| f32::from_le_bytes(cloud.data[i..i + 4].try_into().unwrap());
    let n = cloud.data.len();
    assert_eq!((f(n - 12), f(n - 8), f(n - 4)), (0.020, 0.010, 0.005));

    // attachments and metadata
    assert_eq!(
        sum.attachment_indexes
            .iter()
            .map(|a| (a.name.as_str(), a.media_type.as_str()))
            .collect::<Vec<_>>(),
        [("program.nc", "text/plain"), ("machine.toml", "text/plain")]
    );
    let att = mcap::read::attachment(&bytes, &sum.attachment_indexes[0]).unwrap();
    assert_eq!(att.data.as_ref(), text.as_bytes());
    let mut meta = BTreeMap::new();
    for i in &sum.metadata_indexes {
        let m = mcap::read::metadata(&bytes, i).unwrap();
        meta.insert(m.name, m.metadata);
    }
    let cnc = &meta["cnc"];
    assert_eq!(cnc["program_name"], "mill_pocket.nc");
    assert_eq!(cnc["dialect"], "cnc836");
    assert_eq!(cnc["machine_name"], "mill");
    assert_eq!(cnc["rate_hz"], "1000");
    assert_eq!(cnc["controller_version"], env!("CARGO_PKG_VERSION"));
    let bag = &meta["rosbag2"];
    assert_eq!(bag["ROS_DISTRO"], record::ROS_DISTRO);
    let y = &bag["serialized_metadata"];
    assert!(
        y.starts_with("version: 9\nstorage_identifier: mcap\n"),
        "{y}"
    );
    assert!(y.contains(&format!("message_count: {}\n", summary.messages)));
    assert!(y.contains(
        "      name: /cnc/joint_setpoints\n      type: sensor_msgs/msg/JointState\n      serialization_format: cdr\n"
    ));
    assert!(y.contains(&format!("    message_count: {samples}\n")));
    assert!(y.contains("relative_file_paths:\n  - mill_pocket.mcap\n"));
    assert!(y.ends_with("custom_data: ~\nros_distro: kilted"));
}

#[test]
fn recordings_are_deterministic() {
    let m = Machine::builtin_mill();
    let text = program();
    let mut files = Vec::new();
    for dir in ["det_a", "det_b"] {
        let d = out(dir);
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("run.mcap");
        record_simulation(&m, "p.nc", &text, m.dialect, &p).unwrap();
        files.push(std::fs::read(p).unwrap());
    }
    assert!(files[0].len() > 10_000);
    assert!(
        files[0] == files[1],
        "recording the same run twice gave different bytes"
    );
}

#[test]
fn lathe_recording_has_two_joints() {
    let m = Machine::builtin_lathe();
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/lathe_profile.nc");
    let text = std::fs::read_to_string(p).unwrap();
    let path = out("lathe.mcap");
    let s = record_simulation(&m, "lathe_profile.nc", &text, m.dialect, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mut n = 0;
    for msg in mcap::MessageStream::new(&bytes).unwrap() {
        let msg = msg.unwrap();
        if msg.channel.topic == topics::JOINT_STATES {
            let js: JointState = from_cdr(&msg.data).unwrap();
            assert_eq!(js.name, ["x", "z"]);
            assert_eq!(js.position.len(), 2);
            assert_eq!(js.velocity.len(), 2);
            n += 1;
        }
    }
    assert_eq!(n, s.count(topics::JOINT_STATES));
}

#[test]
fn a_bad_program_records_nothing() {
    let m = Machine::builtin_mill();
    let path = out("bad.mcap");
    let _ = std::fs::remove_file(&path);
    let e = record_simulation(&m, "bad.nc", "G01 X10 W5 F100\n", m.dialect, &path).unwrap_err();
    assert!(e.contains("bad.nc"), "{e}");
    assert!(!path.exists());
    let e = record_simulation(
        &m,
        "p.nc",
        &program(),
        m.dialect,
        &out("no/such/dir/x.mcap"),
    )
    .unwrap_err();
    assert!(e.contains("x.mcap"), "{e}");
}
