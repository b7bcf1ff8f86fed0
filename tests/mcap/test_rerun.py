"""Recordings as Rerun shows them: `cnc bag rrd` writes an .rrd, and Rerun's
own reader (rerun-sdk's chunk store and its DataFusion dataframe API) reads
it back. At 10 %, 50 % and 90 % of the timeline of a mill, a lathe and a
thread recording:

- the tool's transform is there and equals the actual position then (mm);
- the commanded and actual paths so far have exactly the points up to
  then (one every 10th setpoint, from the start), ending where the
  setpoint and the actual position are;
- each joint's setpoint and actual series are in mm (lathe X on the
  diameter);
- the spindle speed (rpm) and the program line are those of the
  recording's last /cnc/spindle_command and /cnc/status then, and the
  program view marks that line.

The expected values come from the MCAP itself, decoded by mcap-ros2-support.

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/mcap/test_rerun.py
"""
import bisect
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TARGET = os.environ.get("CNC_TARGET_DIR", os.path.join(ROOT, "target", "debug"))
TICK = 10

CASES = {
    # name: (recording or program, machine, joints)
    "mill": ("bags/mill_pocket.mcap", None),
    "lathe": ("bags/lathe_profile.mcap", None),
    "thread": ("examples/lathe_thread.nc", "lathe"),
}


def cnc_cmd():
    if os.environ.get("CNC_SKIP_BUILD"):
        return [os.path.join(TARGET, "cnc")]
    return ["cargo", "run", "-q", "-p", "cnc_node", "--bin", "cnc", "--"]


@pytest.fixture(scope="module", params=sorted(CASES))
def converted(request, tmp_path_factory):
    name = request.param
    src, machine = CASES[name]
    d = tmp_path_factory.mktemp("rrd_" + name)
    mcap = os.path.join(ROOT, src)
    if machine:
        mcap = str(d / (name + ".mcap"))
        subprocess.run(cnc_cmd() + ["simulate", os.path.join(ROOT, src), "--machine", machine, "--mcap", mcap],
                       cwd=ROOT, check=True, capture_output=True)
    rrd = str(d / (name + ".rrd"))
    r = subprocess.run(cnc_cmd() + ["bag", "rrd", mcap, "-o", rrd, "--python", sys.executable],
                       cwd=ROOT, check=True, capture_output=True, text=True)
    assert rrd in r.stdout
    return name, mcap, rrd


def oracle(path):
    """What the recording holds, decoded by mcap-ros2-support: times (ns),
    positions (mm), the spindle commands (rpm) and the status lines."""
    set_t, set_p, act_t, act_p, spindle, status = [], [], [], [], [], []
    names = machine = None
    with open(path, "rb") as f:
        for _, ch, m, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(log_time_order=True):
            if ch.topic == "/cnc/joint_setpoints":
                names = list(msg.name)
                set_t.append(m.log_time)
                set_p.append([v * 1000 for v in msg.position])
            elif ch.topic == "/sim/joint_states":
                act_t.append(m.log_time)
                act_p.append([v * 1000 for v in msg.position])
            elif ch.topic == "/cnc/spindle_command":
                spindle.append((m.log_time, msg.data * 60 / (2 * math.pi)))
            elif ch.topic == "/cnc/status":
                status.append((m.log_time, msg.source_line))
            elif ch.topic == "/cnc/machine_file":
                machine = msg.data
    return dict(names=names, set_t=np.array(set_t), set_p=np.array(set_p), act_t=np.array(act_t),
                act_p=np.array(act_p), spindle=spindle, status=status, lathe='kind = "lathe"' in machine)


def latest(pairs, t):
    i = bisect.bisect_right([p[0] for p in pairs], t)
    assert i > 0
    return pairs[i - 1][1]


def xyz(names, p):
    out = [0.0, 0.0, 0.0]
    for n, v in zip(names, p):
        out["xyz".index(n)] = v
    return out


def store_of(rrd):
    from rerun.chunk import ChunkStore, RrdReader

    r = RrdReader(rrd)
    (rec,) = r.recordings()
    assert r.blueprints(), "the .rrd carries its blueprint"
    return rec, ChunkStore.from_chunks(list(r.stream(store=rec).to_chunks()))


def col(table, name):
    return table.column(name).to_pylist()


def test_rerun_shows_the_cut_at_every_moment(converted):
    name, mcap, rrd = converted
    o = oracle(mcap)
    rec, store = store_of(rrd)
    assert rec.application_id == {"mill": "cnc_mill_pocket", "lathe": "cnc_lathe_profile", "thread": "cnc_lathe_thread"}[name]
    names, t0 = o["names"], int(o["set_t"][0])
    n = len(o["set_t"])
    ticks = list(range(0, n, TICK)) + ([n - 1] if (n - 1) % TICK else [])
    assert np.array_equal(o["act_t"], o["set_t"])  # offline: the same stamps

    # the whole paths, as Rerun reads them: one 2-point segment a tick
    paths = {}
    for ent in ("commanded", "actual"):
        t = store.reader(index="time", contents=[f"/world/{ent}"]).to_arrow_table()
        t = t.filter(t.column(f"/world/{ent}:LineStrips3D:strips").is_valid())
        times = np.array(t.column("time").cast("int64").to_pylist())
        strips = [s[0] for s in col(t, f"/world/{ent}:LineStrips3D:strips")]
        order = np.argsort(times, kind="stable")
        paths[ent] = (times[order], [strips[i] for i in order])
        assert len(times) == len(ticks) - 1, ent

    for frac in (0.1, 0.5, 0.9):
        t_ns = int(round(frac * (o["set_t"][-1] - t0)))
        at = np.array([t_ns], dtype=np.int64)
        row = store.reader(index="time", fill_latest_at=True, using_index_values=at).to_arrow_table()
        got = {c: row.column(c).to_pylist()[0] for c in row.column_names}
        # the last tick at or before the cursor
        k = max(i for i in ticks if o["set_t"][i] - t0 <= t_ns)
        set_mm, act_mm = o["set_p"][k], o["act_p"][k]

        # the tool: its transform is the actual position (float32 in the file)
        (tr,) = got["/world/tool:Transform3D:translation"]
        assert np.allclose(tr, xyz(names, act_mm), atol=2e-3), (name, frac, tr, act_mm)

        # the paths so far: every tick up to k, ending at the setpoint and the actual position
        for ent, want in (("commanded", set_mm), ("actual", act_mm)):
            times, strips = paths[ent]
            so_far = [s for tt, s in zip(times, strips) if tt <= t_ns]
            points = len(so_far) + 1
            assert points == ticks.index(k) + 1 == k // TICK + 1, (name, frac, ent, points)
            assert np.allclose(so_far[-1][1], xyz(names, want), atol=2e-3), (name, frac, ent)
            assert np.allclose(so_far[0][0], xyz(names, o["set_p"][0] if ent == "commanded" else o["act_p"][0]), atol=2e-3)

        # setpoint and actual per joint, mm (lathe X: diameter), following error in µm
        for j, jn in enumerate(names):
            f = 2.0 if (o["lathe"] and jn == "x") else 1.0
            (s,) = got[f"/joints/{jn}/setpoint:Scalars:scalars"]
            (a,) = got[f"/joints/{jn}/actual:Scalars:scalars"]
            assert s == pytest.approx(f * set_mm[j], abs=1e-9), (name, frac, jn)
            assert a == pytest.approx(f * act_mm[j], abs=1e-9), (name, frac, jn)
            unit = " ⌀ setpoint (mm)" if f == 2.0 else " setpoint (mm)"
            assert got[f"/joints/{jn}/setpoint:SeriesLines:names"] == [jn.upper() + unit]
            (e,) = got[f"/following_error/{jn}:Scalars:scalars"]
            window = f * (o["set_p"][max(k - TICK + 1, 0) : k + 1, j] - o["act_p"][max(k - TICK + 1, 0) : k + 1, j]) * 1000
            assert abs(e) == pytest.approx(np.max(np.abs(window)), abs=1e-9)
        # a job that moves: the simulated axes lag the setpoints somewhere
        assert len(o["set_p"]) > 1000

        # spindle speed and program line then
        (rpm,) = got["/spindle/command:Scalars:scalars"]
        want_rpm = latest(o["spindle"], int(o["set_t"][k]))
        assert rpm == pytest.approx(want_rpm, abs=1e-6) and rpm > 0, (name, frac, rpm)
        (line,) = got["/status/line:Scalars:scalars"]
        want_line = latest(o["status"], t0 + t_ns)
        assert line == want_line > 0, (name, frac, line, want_line)
        (doc,) = got["/program:TextDocument:text"]
        assert f"line **{want_line}** of" in doc
        assert f"▶{want_line:5d}  " in doc

        # the programmed path up to then: the blocks begun so far
        prog = store.reader(index="time", contents=["/world/programmed/**"]).to_arrow_table()
        ptimes = np.array(prog.column("time").cast("int64").to_pylist())
        assert (ptimes <= t_ns).sum() >= 1


def test_time_is_seconds_from_the_start_and_lathe_x_is_a_diameter(converted):
    name, mcap, rrd = converted
    o = oracle(mcap)
    _, store = store_of(rrd)
    t = store.reader(index="time", contents=["/joints/**"]).to_arrow_table()
    assert t.schema.field("time").type.__str__().startswith("duration")
    times = np.array(t.column("time").cast("int64").to_pylist())
    assert times.min() == 0
    assert times.max() == o["set_t"][-1] - o["set_t"][0]
    if o["lathe"]:
        x = [v for v in col(t, "/joints/x/setpoint:Scalars:scalars") if v is not None]
        # the program's diameters (lathe_profile: X20..X60, thread: X20/X30), not the slide's radius
        assert max(x[0] for x in x) == pytest.approx(2 * o["set_p"][:, 0].max(), abs=1e-9)
