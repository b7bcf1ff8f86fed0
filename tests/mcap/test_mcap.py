"""An offline recording (MCAP, ROS 2 profile) read by independent tools:

- the `mcap` and `mcap-ros2-support` PyPI packages decode every message
  from the schema texts in the file;
- the schema texts are rebuilt here from the installed ROS 2 Kilted `.msg`
  files with rosbag2's own algorithm and compared byte for byte;
- `rerun mcap convert` turns it into an .rrd with joint position series and
  3D entities for the tool (transform, pose, point cloud).

Run (the venv has the pinned packages of scripts/ros_peer/requirements.txt):

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/mcap

The recording is made by `cargo run -p cnc_node --example record_example`
(examples/mill_pocket.nc on the bundled mill); CNC_SKIP_BUILD=1 runs the
already built target/debug/examples/record_example instead.
"""
import collections
import os
import re
import shutil
import struct
import subprocess
import sys

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TARGET = os.environ.get("CNC_TARGET_DIR", os.path.join(ROOT, "target", "debug"))
PROGRAM = os.path.join(ROOT, "examples", "mill_pocket.nc")
EPOCH_NS = 1_700_000_000 * 10**9
DT_NS = 1_000_000  # the bundled mill runs at 1 kHz
END_M = (0.020, 0.010, 0.005)  # mill_pocket.nc ends at X20 Y10 Z5 (mm)

TOPICS = {
    "/cnc/joint_setpoints": "sensor_msgs/msg/JointState",
    "/sim/joint_states": "sensor_msgs/msg/JointState",
    "/cnc/spindle_command": "std_msgs/msg/Float64",
    "/cnc/status": "cnc_msgs/msg/ControllerStatus",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/cnc/tool_pose": "geometry_msgs/msg/PoseStamped",
    "/cnc/toolpath": "sensor_msgs/msg/PointCloud2",
    "/cnc/program": "std_msgs/msg/String",
    "/cnc/machine_file": "std_msgs/msg/String",
    # the simulated encoder: offline recordings of a machine with a spindle
    "/sim/spindle_encoder": "cnc_msgs/msg/SpindleEncoder",
}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("mcap") / "mill_pocket.mcap")
    if os.environ.get("CNC_SKIP_BUILD"):
        cmd = [os.path.join(TARGET, "examples", "record_example"), out]
    else:
        cmd = ["cargo", "run", "-q", "-p", "cnc_node", "--example", "record_example", "--", out]
    subprocess.run(cmd, cwd=ROOT, check=True)
    return out


def summary_of(path):
    with open(path, "rb") as f:
        r = make_reader(f)
        header = r.get_header()
        summary = r.get_summary()
        metadata = {m.name: dict(m.metadata) for m in r.iter_metadata()}
        attachments = {a.name: (a.media_type, bytes(a.data), a.log_time) for a in r.iter_attachments()}
    return header, summary, metadata, attachments


def decoded(path):
    """(schema, channel, message, decoded ROS message) of every message, in
    log time order, decoded by mcap-ros2-support from the file's schemas
    (what `mcap_ros2.reader.read_ros2_messages` does, without its
    deprecation warning)."""
    with open(path, "rb") as f:
        yield from make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(log_time_order=True)


def test_every_message_decodes_with_mcap_ros2(recording):
    header, summary, _, _ = summary_of(recording)
    assert header.profile == "ros2"
    assert header.library.startswith("cnc_node/")
    topics = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
    assert {t: s.name for t, s in topics.items()} == TOPICS
    assert all(s.encoding == "ros2msg" for s in topics.values())
    assert all(c.message_encoding == "cdr" for c in summary.channels.values())
    assert {ci.compression for ci in summary.chunk_indexes} == {"zstd"}

    counts = collections.Counter()
    setpoints, actual, status, tf, poses = [], [], [], [], []
    cloud = program = machine = None
    clouds = []  # (log time, cloud): the path so far every second, the whole path last
    for _, channel, m, msg in decoded(recording):
        topic = channel.topic
        counts[topic] += 1
        assert m.log_time == m.publish_time
        stamp = getattr(getattr(msg, "header", None), "stamp", None)
        if stamp is not None:
            assert stamp.sec * 10**9 + stamp.nanosec == m.log_time, topic
        if topic == "/cnc/joint_setpoints":
            assert list(msg.name) == ["x", "y", "z"]
            assert m.log_time == EPOCH_NS + len(setpoints) * DT_NS
            assert m.sequence == len(setpoints) + 1
            setpoints.append(list(msg.position))
        elif topic == "/sim/joint_states":
            assert len(msg.velocity) == 3
            actual.append(list(msg.position))
        elif topic == "/cnc/status":
            status.append(msg)
        elif topic == "/tf":
            (t,) = msg.transforms
            assert (t.header.frame_id, t.child_frame_id) == ("world", "tool")
            tf.append(t.transform.translation)
        elif topic == "/cnc/tool_pose":
            assert msg.header.frame_id == "world"
            poses.append(msg.pose.position)
        elif topic == "/cnc/toolpath":
            cloud = msg
            clouds.append((m.log_time, msg))
        elif topic == "/cnc/program":
            program = msg.data
        elif topic == "/cnc/machine_file":
            machine = msg.data

    # every message decoded, as many as the summary says
    stats = summary.statistics
    assert sum(counts.values()) == stats.message_count
    for cid, n in stats.channel_message_counts.items():
        assert counts[summary.channels[cid].topic] == n
    n = len(setpoints)
    assert n > 1000 and len(actual) == n
    assert counts["/cnc/spindle_command"] == 2
    assert counts["/cnc/program"] == counts["/cnc/machine_file"] == 1
    # the tool path so far at 1 s, 2 s, ... (not at the last sample), then
    # the whole path at the end
    assert counts["/cnc/toolpath"] == (n - 2) // 1000 + 1
    assert len(tf) == len(poses) == (n - 1) // 10 + 1 + ((n - 1) % 10 != 0)

    for got, want in zip(setpoints[-1], END_M):
        assert abs(got - want) <= 1e-9, setpoints[-1]
    assert setpoints[0] == [0.0, 0.0, 0.0]
    last_tf = tf[-1]
    for got, want in zip((last_tf.x, last_tf.y, last_tf.z), END_M):
        assert abs(got - want) <= 1e-9
    # the simulated axes follow within 1 mm and settle at the end point
    assert max(abs(a - s) for sp, ac in zip(setpoints, actual) for s, a in zip(sp, ac)) < 1e-3
    assert status[-1].state == 0 and status[-1].progress == 1.0
    assert all(s.state == 1 for s in status[:-1])
    assert status[0].spindle_speed_command == 3000.0

    for i, (t, c) in enumerate(clouds[:-1]):
        k = (i + 1) * 1000
        assert t == EPOCH_NS + k * DT_NS
        assert 0 < c.width <= 5000 and c.point_step == 12
        # from the start to where the tool is then
        end = struct.unpack_from("<3f", bytes(c.data), 12 * (c.width - 1))
        assert all(abs(g - w) < 1e-6 for g, w in zip(end, setpoints[k])), (end, setpoints[k])
        assert struct.unpack_from("<3f", bytes(c.data), 0) == (0.0, 0.0, 0.0)
    assert cloud.width == n and cloud.height == 1 and cloud.point_step == 12
    assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == [("x", 0, 7), ("y", 4, 7), ("z", 8, 7)]
    x, y, z = struct.unpack_from("<3f", bytes(cloud.data), 12 * (n - 1))
    assert all(abs(g - w) < 1e-6 for g, w in zip((x, y, z), END_M))

    with open(PROGRAM) as f:
        assert program == f.read()
    assert 'name = "mill"' in machine and "rate_hz = 1000.0" in machine


def test_rosbag2_metadata_and_job(recording):
    _, summary, meta, att = summary_of(recording)
    bag = meta["rosbag2"]
    assert bag["ROS_DISTRO"] == "kilted"
    info = yaml.safe_load(bag["serialized_metadata"])
    assert info["version"] == 9
    assert info["storage_identifier"] == "mcap"
    assert info["ros_distro"] == "kilted"
    assert info["message_count"] == summary.statistics.message_count
    assert info["starting_time"]["nanoseconds_since_epoch"] == summary.statistics.message_start_time
    assert info["duration"]["nanoseconds"] == summary.statistics.message_end_time - summary.statistics.message_start_time
    assert info["relative_file_paths"] == ["mill_pocket.mcap"]
    assert info["files"][0]["message_count"] == info["message_count"]
    assert info["compression_format"] == "" and info["compression_mode"] == ""
    assert info["custom_data"] is None
    counts = {summary.channels[c].topic: n for c, n in summary.statistics.channel_message_counts.items()}
    got = {}
    for t in info["topics_with_message_count"]:
        tm = t["topic_metadata"]
        got[tm["name"]] = (tm["type"], t["message_count"])
        assert tm["serialization_format"] == "cdr"
        (qos,) = tm["offered_qos_profiles"]
        assert qos["history"] == "keep_last" and qos["reliability"] == "reliable"
        latched = tm["name"] in ("/cnc/program", "/cnc/machine_file")
        assert qos["durability"] == ("transient_local" if latched else "volatile")
        assert qos["depth"] == (1 if latched else 10)
    assert got == {t: (ty, counts[t]) for t, ty in TOPICS.items()}
    for c in summary.channels.values():
        (qos,) = yaml.safe_load(c.metadata["offered_qos_profiles"])
        assert qos["deadline"] == {"sec": 9223372036, "nsec": 854775807}
        assert c.metadata["topic_type_hash"] == ""

    cnc = meta["cnc"]
    assert cnc["program_name"] == "mill_pocket.nc"
    assert cnc["dialect"] == "cnc836"
    assert cnc["machine_name"] == "mill"
    assert cnc["rate_hz"] == "1000"
    assert cnc["controller_version"]
    with open(PROGRAM, "rb") as f:
        assert att["program.nc"][:2] == ("text/plain", f.read())
    assert att["machine.toml"][0] == "text/plain"
    assert att["program.nc"][2] == EPOCH_NS


# ---------------------------------------------------------------------------
# rosbag2's complete message definition (LocalMessageDefinitionSource), from
# the installed share/<pkg>/msg/<Type>.msg files.

MSG_FIELD_TYPE_REGEX = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
              "int32", "uint32", "int64", "uint64", "string"}


def find_msg(name):
    pkg, ty = re.match(r"^([a-zA-Z0-9_]+)/(?:msg/)?([a-zA-Z0-9_]+)$", name).groups()
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        p = os.path.join(prefix, "share", pkg, "msg", ty + ".msg")
        if prefix and os.path.exists(p):
            with open(p) as f:
                return pkg, f.read()
    return pkg, None


def rosbag2_full_text(root):
    seen = set()

    def append(name):
        pkg, text = find_msg(name)
        if text is None:
            raise LookupError(name)
        deps = set()
        for t in MSG_FIELD_TYPE_REGEX.findall(text):
            if t not in PRIMITIVES:
                deps.add(t if "/" in t else pkg + "/" + t)
        out = text
        for d in sorted(deps):
            if d not in seen:
                seen.add(d)
                out += "\n" + "=" * 80 + "\nMSG: " + d + "\n" + append(d)
        return out

    return append(root)


def test_schemas_equal_rosbag2_text_from_installed_definitions(recording):
    _, summary, _, _ = summary_of(recording)
    checked = []
    for s in summary.schemas.values():
        try:
            want = rosbag2_full_text(s.name)
        except LookupError as e:  # tf2_msgs is not among the pinned wheels
            print(f"{s.name}: {e} not installed, not compared")
            continue
        assert s.data.decode() == want, s.name
        checked.append(s.name)
    if not os.environ.get("AMENT_PREFIX_PATH"):
        pytest.skip("no ROS 2 installation (AMENT_PREFIX_PATH) to compare with")
    assert "sensor_msgs/msg/JointState" in checked
    assert "cnc_msgs/msg/ControllerStatus" in checked
    assert "sensor_msgs/msg/PointCloud2" in checked


# ---------------------------------------------------------------------------
# Rerun


def rerun_cmd():
    exe = shutil.which("rerun")
    return [exe] if exe else [sys.executable, "-m", "rerun"]


def test_rerun_converts_it(recording, tmp_path):
    rrd = str(tmp_path / "mill_pocket.rrd")
    subprocess.run(rerun_cmd() + ["mcap", "convert", recording, "-o", rrd], check=True)
    import rerun.chunk

    comps = collections.defaultdict(set)
    rows = collections.Counter()
    last = {}
    for ch in rerun.chunk.RrdReader(rrd).stream().to_chunks():
        rb = ch.to_record_batch()
        names = [n for n in rb.schema.names if ":" in n]
        comps[ch.entity_path] |= set(names)
        if "message_log_time" in rb.schema.names:
            rows[ch.entity_path] += ch.num_rows
            for n in names:
                last[(ch.entity_path, n)] = rb.column(n)[-1].as_py()

    _, summary, _, _ = summary_of(recording)
    n = {summary.channels[c].topic: k for c, k in summary.statistics.channel_message_counts.items()}

    # joint position series, one scalar per joint, named by the joints
    for topic in ("/cnc/joint_setpoints", "/sim/joint_states"):
        e = topic + "/position"
        assert "Scalars:scalars" in comps[e], comps[e]
        assert rows[e] == n[topic]
        assert last[(e, "SeriesLines:names")] == ["x", "y", "z"]
    end = last[("/cnc/joint_setpoints/position", "Scalars:scalars")]
    assert all(abs(g - w) <= 1e-9 for g, w in zip(end, END_M)), end

    # the tool in 3D: /tf as a transform world -> tool, the pose, the path
    assert {"Transform3D:translation", "Transform3D:parent_frame", "Transform3D:child_frame"} <= comps["/tf"]
    assert rows["/tf"] == n["/tf"]
    assert last[("/tf", "Transform3D:parent_frame")] == ["world"]
    assert last[("/tf", "Transform3D:child_frame")] == ["tool"]
    (t,) = last[("/tf", "Transform3D:translation")]
    assert all(abs(g - w) < 1e-6 for g, w in zip(t, END_M)), t
    assert "InstancePoses3D:translations" in comps["/cnc/tool_pose"]
    assert rows["/cnc/tool_pose"] == n["/cnc/tool_pose"]
    assert "Points3D:positions" in comps["/cnc/toolpath"]
    pts = last[("/cnc/toolpath", "Points3D:positions")]
    assert len(pts) == n["/cnc/joint_setpoints"]
    assert all(abs(g - w) < 1e-6 for g, w in zip(pts[-1], END_M))
    # the job: program and machine file as text documents
    assert "TextDocument:text" in comps["/cnc/program"]
    assert "TextDocument:text" in comps["/cnc/machine_file"]


def blueprint_views(rbl):
    """(class, origin, name, contents query) of every view of a .rbl, and
    its application id."""
    import rerun.chunk
    r = rerun.chunk.RrdReader(rbl)
    (bp,) = r.blueprints()
    views, queries = {}, {}
    for ch in r.stream(store=bp).to_chunks():
        rb = ch.to_record_batch()
        col = {n.split(":")[-1]: rb.column(n)[0].as_py() for n in rb.schema.names if ":" in n}
        path = ch.entity_path
        if path.startswith("/view/") and "class_identifier" in col:
            views[path] = (col["class_identifier"][0], col["space_origin"][0], col["display_name"][0])
        elif path.startswith("/view/") and path.endswith("/ViewContents"):
            queries[path.rsplit("/", 1)[0]] = col["query"]
    return bp.application_id, sorted(v + (tuple(queries.get(p, ())),) for p, v in views.items())


def test_the_rerun_blueprint_lays_out_rerun_s_own_conversion(recording, tmp_path):
    """docs/rerun/cnc_mcap.rbl (scripts/rerun/mcap_blueprint.py) is for a
    recording converted by Rerun's own MCAP loader with the application id
    cnc_mcap (README): its views show entities the conversion has, the 3D
    view the growing tool path, the tool and its frame."""
    import rerun.chunk
    committed = os.path.join(ROOT, "docs", "rerun", "cnc_mcap.rbl")
    app, views = blueprint_views(committed)
    # the committed file is what the script makes (ids aside)
    fresh = str(tmp_path / "fresh.rbl")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "rerun", "mcap_blueprint.py"), "-o", fresh],
                   check=True, capture_output=True)
    assert blueprint_views(fresh) == (app, views)
    rrd = str(tmp_path / "mill_pocket_cnc_mcap.rrd")
    subprocess.run(rerun_cmd() + ["mcap", "convert", recording, "--application-id", app, "-o", rrd], check=True)
    (rec,) = rerun.chunk.RrdReader(rrd).recordings()
    assert app == "cnc_mcap" and rec.application_id == app
    entities = {ch.entity_path for ch in rerun.chunk.RrdReader(rrd).stream().to_chunks()}
    kinds = {c for c, _, _, _ in views}
    assert {"3D", "TimeSeries", "TextDocument", "Dataframe"} <= kinds, kinds
    for cls, origin, name, query in views:
        assert origin == "/" or origin in entities, (origin, sorted(entities))
        for q in query:
            if not q.startswith("$"):
                assert q in entities, (q, name)
    (q3d,) = [q for c, _, _, q in views if c == "3D"]
    assert set(q3d) == {"/cnc/toolpath", "/cnc/tool_pose", "/tf"}


def test_rosbags_reads_it_as_a_rosbag2_bag(recording):
    """rosbags (a pure-Python rosbag2 implementation, independent of ours and
    of the mcap packages) opens the file, reads the rosbag2 metadata and
    decodes every message with the schemas the file carries."""
    from pathlib import Path
    from rosbags.highlevel import AnyReader

    with AnyReader([Path(recording)]) as r:
        n, last = 0, None
        for conn, _t, raw in r.messages():
            msg = r.deserialize(raw, conn.msgtype)
            n += 1
            if conn.topic == "/cnc/joint_setpoints":
                last = [float(v) for v in msg.position]
        types = {c.topic: c.msgtype for c in r.connections}
    assert n == summary_of(recording)[1].statistics.message_count
    assert types["/cnc/status"] == "cnc_msgs/msg/ControllerStatus"
    assert types["/tf"] == "tf2_msgs/msg/TFMessage"
    for got, want in zip(last, [0.020, 0.010, 0.005]):
        assert abs(got - want) < 1e-9, last


def cnc_cmd():
    if os.environ.get("CNC_SKIP_BUILD"):
        return [os.path.join(TARGET, "cnc")]
    return ["cargo", "run", "-q", "-p", "cnc_node", "--bin", "cnc", "--"]


def test_a_cut_recording_is_recovered_for_independent_readers(recording, tmp_path):
    """The recording cut in the middle of its fourth chunk (what a killed
    recorder leaves, less the unpatched chunk header), then `cnc bag
    recover`: the mcap reader, mcap-ros2-support and rosbags read the
    result, and it holds the original's messages up to that chunk."""
    from pathlib import Path
    from rosbags.highlevel import AnyReader

    _, summary, _, _ = summary_of(recording)
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    c = chunks[3]
    with open(recording, "rb") as f:
        data = f.read()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: c.chunk_start_offset + c.chunk_length // 2])
    out = tmp_path / "recovered.mcap"
    r = subprocess.run(cnc_cmd() + ["bag", "recover", str(cut), "-o", str(out)],
                       cwd=ROOT, check=True, capture_output=True, text=True)
    # (every channel has messages by then: the growing tool path since 1 s)
    m = re.search(r"recovered (\d+) messages on 10 channels from 3 complete chunks", r.stdout)
    assert m, r.stdout
    assert f"dropped {c.chunk_length // 2} bytes of an unfinished chunk" in r.stdout, r.stdout

    def file_order(path):
        with open(path, "rb") as f:
            return [(ch.topic, msg.sequence, msg.log_time, bytes(msg.data))
                    for _, ch, msg in make_reader(f).iter_messages(log_time_order=False)]

    got, original = file_order(out), file_order(recording)
    assert len(got) == int(m.group(1)) > 8000
    assert got == original[: len(got)]
    # every one decodes; none is from the cut chunk
    _, rsum, meta, att = summary_of(out)
    assert rsum.statistics.message_count == len(got)
    assert sum(1 for _ in decoded(out)) == len(got)
    assert max(t for _, _, t, _ in got) <= c.message_start_time
    assert set(att) == {"program.nc", "machine.toml"}
    bag = yaml.safe_load(meta["rosbag2"]["serialized_metadata"])
    assert bag["message_count"] == len(got)
    assert bag["relative_file_paths"] == ["recovered.mcap"]
    with AnyReader([out]) as rd:
        assert sum(1 for _ in rd.messages()) == len(got)
