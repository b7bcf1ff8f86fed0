"""A cnc recording (MCAP) as a Rerun file (.rrd) that opens on its own layout.

    cnc bag rrd IN.mcap -o OUT.rrd            # the usual way (adds the programmed path)
    python3 cnc_node/rerun/cnc_rrd.py IN.mcap -o OUT.rrd [--programmed FILE|-]

Needs Python 3.11+ with rerun-sdk 0.41, mcap and mcap-ros2-support
(scripts/ros_peer/requirements.txt pins them). `cnc bag rrd` runs this file
(built into the binary) and hands it the path *as programmed* on stdin: one
move a line, `LINE feed|rapid|thread x,y,z x,y,z ...` in mm.

What the .rrd holds (timeline `time`: seconds from the first setpoint):

- `world/programmed/{feed,rapid}`: every block's geometry as programmed,
  logged when the block starts (its line first shows in /cnc/status);
- `world/commanded`, `world/actual`: the setpoints and the simulated (or
  measured) actual positions, one 2-point segment every TICK samples
  (10 ms at 1 kHz), so the path so far is every segment up to the cursor;
- `world/tool`: a transform to the actual position at every tick, and
  under it the tool's shape (static);
- `joints/<j>/{setpoint,actual}` in mm (lathe X as the diameter),
  `following_error/<j>` in µm (the largest in each tick's window),
  `speed/path` (mm/min), `spindle/{command,measured}` (rpm),
  `status/line` (the line running), `program` (the program around the
  current line), `status/log` (line and state changes);
- a blueprint: 3D view with the path up to the cursor and a camera for the
  machine, plots, program, log; time panel on `time`.

Every 3D point and plot point is one tick (every TICK-th setpoint and the
last one); nothing else is thinned.
"""

import argparse
import bisect
import math
import os
import re
import struct
import sys
import tomllib

import numpy as np

try:
    import rerun as rr
    import rerun.blueprint as rrb
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
except ImportError as e:  # pragma: no cover - told to the user
    sys.stderr.write(
        f"cnc_rrd: {e}: needs rerun-sdk==0.41.0, mcap and mcap-ros2-support "
        "(pip install -r scripts/ros_peer/requirements.txt)\n"
    )
    sys.exit(2)

TICK = 10  # samples per 3D/plot point
SETPOINTS = "/cnc/joint_setpoints"
STATES = "/sim/joint_states"
SPINDLE = "/cnc/spindle_command"
STATUS = "/cnc/status"
ENCODER = "/sim/spindle_encoder"
PROGRAM = "/cnc/program"
MACHINE = "/cnc/machine_file"
STATE_NAMES = {0: "IDLE", 1: "RUNNING", 2: "HOLD", 3: "ERROR"}

# colours: the same quantity has the same colour in every view
C_PROG_FEED = (150, 150, 155)  # a band under the commanded path
C_PROG_RAPID = (120, 120, 130)
C_SET = (255, 150, 40)  # commanded: orange
C_ACT = (60, 170, 255)  # actual: blue
C_JOINT = {"x": (235, 80, 80), "y": (90, 200, 90), "z": (80, 140, 255)}
C_SPEED = (240, 200, 60)
C_SPINDLE = (200, 120, 255)
C_SPINDLE_MEAS = (120, 220, 200)
C_TOOL = (255, 230, 80)


def die(msg):
    sys.stderr.write(f"cnc_rrd: {msg}\n")
    sys.exit(2)


# ---------------------------------------------------------------- reading


class Cdr:
    """A little-endian CDR reader (after the 4-byte encapsulation header)."""

    def __init__(self, data):
        self.d = data
        self.o = 4

    def align(self, n):
        self.o += (-(self.o - 4)) % n

    def u32(self):
        self.align(4)
        (v,) = struct.unpack_from("<I", self.d, self.o)
        self.o += 4
        return v

    def string(self):
        n = self.u32()
        s = self.d[self.o : self.o + n - 1].decode("utf-8", "replace")
        self.o += n
        return s

    def f64s(self):
        n = self.u32()
        if n == 0:
            return np.zeros(0)
        self.align(8)
        v = np.frombuffer(self.d, "<f8", n, self.o)
        self.o += 8 * n
        return v


def joint_states(raw):
    """(names, positions m: N x joints) of sensor_msgs/JointState payloads.
    Messages laid out alike (same names, same frame) are read as one array
    at the offset of the first one's positions; any other one by itself."""
    if not raw:
        return None, np.zeros((0, 0))
    names, pos, _ = joint_state(raw[0])
    c = Cdr(raw[0])
    c.o += 8
    c.string()
    [c.string() for _ in range(c.u32())]
    c.u32()
    c.align(8)
    off, n, size = c.o, len(pos), len(raw[0])
    head = raw[0][8:off]  # after the stamp, up to the positions
    if all(len(d) == size and d[8:off] == head for d in raw):
        block = np.frombuffer(b"".join(raw), dtype=np.uint8).reshape(len(raw), size)
        return names, block[:, off : off + 8 * n].copy().view("<f8")
    return names, np.array([joint_state(d)[1] for d in raw])


def joint_state(data):
    """(names, positions m, velocities m/s) of a sensor_msgs/JointState."""
    c = Cdr(data)
    c.o += 8  # stamp
    c.string()  # frame_id
    names = [c.string() for _ in range(c.u32())]
    pos = c.f64s()
    vel = c.f64s()
    return names, pos, vel


class Recording:
    def __init__(self, path):
        self.names = None
        self.t_set, self.p_set = [], []
        self.t_act, self.p_act = [], []
        self.spindle = []  # (ns, rpm)
        self.encoder = []  # (ns, rpm)
        self.status = []  # (ns, state, line, tool, error)
        self.program = self.machine = None
        self.meta = {}
        dec = DecoderFactory()
        decoders = {}
        with open(path, "rb") as f:
            reader = make_reader(f)
            for m in reader.iter_metadata():
                self.meta[m.name] = dict(m.metadata)
            f.seek(0)
            raw_set, raw_act = [], []
            # file order (each topic is written in time order; sorted below)
            for schema, channel, msg in make_reader(f).iter_messages(log_time_order=False):
                topic = channel.topic
                if topic == SETPOINTS:
                    self.t_set.append(msg.log_time)
                    raw_set.append(msg.data)
                    continue
                if topic == STATES:
                    self.t_act.append(msg.log_time)
                    raw_act.append(msg.data)
                    continue
                if topic not in (SPINDLE, STATUS, ENCODER, PROGRAM, MACHINE) or schema is None:
                    continue
                d = decoders.get(channel.id)
                if d is None:
                    d = decoders[channel.id] = dec.decoder_for(channel.message_encoding, schema)
                m = d(msg.data)
                if topic == SPINDLE:
                    self.spindle.append((msg.log_time, m.data * 60 / (2 * math.pi)))
                elif topic == ENCODER:
                    self.encoder.append((msg.log_time, m.velocity * 60 / (2 * math.pi)))
                elif topic == STATUS:
                    self.status.append((msg.log_time, m.state, m.source_line, m.active_tool, m.last_error))
                elif topic == PROGRAM:
                    self.program = m.data
                elif topic == MACHINE:
                    self.machine = m.data
        if not self.t_set:
            die(f"{path}: no {SETPOINTS} messages")
        self.names, p_set = joint_states(raw_set)
        self.t_set, self.p_set = by_time(self.t_set, p_set * 1000.0)
        if self.t_act:
            _, p_act = joint_states(raw_act)
            self.t_act, self.p_act = by_time(self.t_act, p_act * 1000.0)
        else:
            self.t_act, self.p_act = self.t_set, self.p_set
        for lst in (self.spindle, self.encoder, self.status):
            lst.sort(key=lambda e: e[0])


def by_time(t, p):
    t = np.array(t, dtype=np.int64)
    order = np.argsort(t, kind="stable")
    return t[order], p[order]


def read_programmed(src):
    moves = []
    for ln in src:
        parts = ln.split()
        if len(parts) < 3:
            continue
        pts = np.array([[float(v) for v in p.split(",")] for p in parts[2:]])
        moves.append((int(parts[0]), parts[1], pts))
    return moves


# ---------------------------------------------------------------- geometry


def axis_index(name):
    return {"x": 0, "y": 1, "z": 2}.get(name.lower())


def to_xyz(p, names):
    """N x joints (mm) -> N x 3 machine X, Y, Z (mm)."""
    out = np.zeros((len(p), 3))
    for j, n in enumerate(names):
        i = axis_index(n)
        if i is not None:
            out[:, i] = p[:, j]
    return out


def ticks(n, tick=TICK):
    """Indices of every tick-th sample and the last one."""
    k = np.arange(0, n, tick)
    if k[-1] != n - 1:
        k = np.append(k, n - 1)
    return k


def interp_rows(t, t_src, p_src):
    if len(t_src) == len(t) and np.array_equal(t_src, t):
        return p_src
    return np.stack([np.interp(t, t_src, p_src[:, j]) for j in range(p_src.shape[1])], axis=1)


def camera(lo, hi, lathe):
    """(position, look target, up) for the box lo..hi (mm)."""
    c = (lo + hi) / 2
    size = max(float(np.max(hi - lo)), 10.0)
    if lathe:
        # looking along -Y at the X-Z plane: Z to the right, X up
        return c + np.array([0.0, 1.25 * size, 0.0]), c, (1.0, 0.0, 0.0)
    d = np.array([0.55, -1.0, 0.75])
    d /= np.linalg.norm(d)
    return c + d * 1.5 * size, c, (0.0, 0.0, 1.0)


# ---------------------------------------------------------------- writing


def program_window(lines, line, state, name, before=6, after=24):
    lo = max(1, line - before)
    hi = min(len(lines), max(line, 1) + after)
    out = []
    for n in range(lo, hi + 1):
        mark = "▶" if n == line else " "
        out.append(f"{mark}{n:5d}  {lines[n - 1]}")
    head = f"**{name}** — line **{line}** of {len(lines)} — {state}\n\n"
    return head + "```\n" + "\n".join(out) + "\n```\n"


def build(rec, programmed, out, app_id):
    machine = tomllib.loads(rec.machine) if rec.machine else {}
    lathe = machine.get("kind") == "lathe"
    axes = {a.get("name"): a for a in machine.get("axis", [])}
    names = rec.names
    diameter = [bool(axes.get(n, {}).get("diameter_mode")) and lathe for n in names]
    rate = float(machine.get("interpolation", {}).get("rate_hz", 1000.0))
    t0 = int(rec.t_set[0])
    sec = lambda ns: (np.asarray(ns, dtype=np.int64) - t0) / 1e9  # noqa: E731

    n = len(rec.t_set)
    k = ticks(n)
    t_k = sec(rec.t_set[k])
    set_all = rec.p_set
    act_all = interp_rows(rec.t_set, rec.t_act, rec.p_act)
    set_k, act_k = set_all[k], act_all[k]
    set_xyz, act_xyz = to_xyz(set_k, names), to_xyz(act_k, names)

    xyz_all = to_xyz(set_all, names)
    dist = np.linalg.norm(np.diff(xyz_all[k], axis=0), axis=1)
    dt = np.diff(t_k)
    speed = np.concatenate([[0.0], np.where(dt > 0, dist / np.where(dt > 0, dt, 1.0), 0.0) * 60.0])
    changes = line_changes(rec)
    # the fastest feed: the speed on ticks whose line programs no rapid
    rapid_lines = {line for line, kind, _ in programmed if kind == "rapid"}
    tick_line = held([(ns, float(line)) for ns, line in changes], rec.t_set[k])
    on_feed = np.array([int(x) not in rapid_lines and x > 0 for x in tick_line])
    feed_speed = float(speed[on_feed].max()) if programmed and on_feed.any() else 0.0
    max_rpm = max([abs(r) for _, r in rec.spindle] + [0.0])

    rr.init(app_id, recording_id=f"{app_id}-{t0}")
    rr.set_log_time_enabled(False)
    rr.send_recording_start_time_nanos(t0)
    bp = blueprint(rec, names, lathe, diameter, set_xyz, programmed, feed_speed, max_rpm)
    rr.save(out, default_blueprint=bp)
    time = lambda t: [rr.TimeColumn("time", duration=t)]  # noqa: E731

    # ---- 3D
    rr.log("world", rr.ViewCoordinates.UBR if lathe else rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for ent, pts, col, w in (("world/commanded", set_xyz, C_SET, 2.0), ("world/actual", act_xyz, C_ACT, 1.0)):
        rr.log(ent, rr.LineStrips3D.from_fields(colors=[col], radii=[rr.Radius.ui_points(w)]), static=True)
        if len(pts) > 1:
            segs = np.stack([pts[:-1], pts[1:]], axis=1)
            rr.send_columns(ent, indexes=time(t_k[1:]), columns=rr.LineStrips3D.columns(strips=segs))
    rr.send_columns("world/tool", indexes=time(t_k), columns=rr.Transform3D.columns(translation=act_xyz))
    tool_shape(machine, lathe, rec)

    # programmed moves, each when its line starts; drawn 0.1 mm behind the
    # commanded and actual paths (seen from the camera), so that they show
    # on top of its band
    behind = (0.0, -0.1, 0.0) if lathe else (0.0, 0.0, -0.1)
    rr.log("world/programmed", rr.Transform3D(translation=behind), static=True)
    if programmed:
        feed_t, feed_s, rapid_t, rapid_s = [], [], [], []
        ci = 0
        for line, kind, pts in programmed:
            j = ci
            while j < len(changes) and changes[j][1] != line:
                j += 1
            if j < len(changes):
                ci = j
            t = sec(changes[ci][0]) if changes else 0.0
            (rapid_t if kind == "rapid" else feed_t).append(max(float(t), 0.0))
            (rapid_s if kind == "rapid" else feed_s).append(pts)
        for ent, ts, ss, col, r in (
            ("world/programmed/feed", feed_t, feed_s, C_PROG_FEED, 5.0),
            ("world/programmed/rapid", rapid_t, rapid_s, C_PROG_RAPID, 1.0),
        ):
            rr.log(ent, rr.LineStrips3D.from_fields(colors=[col], radii=[rr.Radius.ui_points(r)]), static=True)
            if ts:
                rr.send_columns(ent, indexes=time(np.array(ts)), columns=rr.LineStrips3D.columns(strips=ss))

    # ---- plots
    for j, name in enumerate(names):
        f = 2.0 if diameter[j] else 1.0
        label = name.upper() + (" ⌀" if diameter[j] else "")
        rr.log(f"joints/{name}/setpoint", rr.SeriesLines(colors=[C_SET], names=[f"{label} setpoint (mm)"], widths=[2.0]), static=True)
        rr.log(f"joints/{name}/actual", rr.SeriesLines(colors=[C_ACT], names=[f"{label} actual (mm)"], widths=[1.5]), static=True)
        rr.send_columns(f"joints/{name}/setpoint", indexes=time(t_k), columns=rr.Scalars.columns(scalars=f * set_k[:, j]))
        rr.send_columns(f"joints/{name}/actual", indexes=time(t_k), columns=rr.Scalars.columns(scalars=f * act_k[:, j]))
        err = f * (set_all[:, j] - act_all[:, j]) * 1000.0  # µm
        win = window_extreme(err, k)
        rr.log(f"following_error/{name}", rr.SeriesLines(colors=[C_JOINT.get(name.lower(), (200, 200, 200))], names=[f"{label} (µm)"]), static=True)
        rr.send_columns(f"following_error/{name}", indexes=time(t_k), columns=rr.Scalars.columns(scalars=win))
    rr.log("speed/path", rr.SeriesLines(colors=[C_SPEED], names=["path speed, commanded (mm/min)"], widths=[1.5]), static=True)
    rr.send_columns("speed/path", indexes=time(t_k), columns=rr.Scalars.columns(scalars=speed))

    # spindle: the command held at every tick (a step plot), the encoder's speed
    rr.log("spindle/command", rr.SeriesLines(colors=[C_SPINDLE], names=["spindle command (rpm)"], widths=[2.0]), static=True)
    rr.send_columns("spindle/command", indexes=time(t_k), columns=rr.Scalars.columns(scalars=held(rec.spindle, rec.t_set[k])))
    if rec.encoder:
        te = np.array([e[0] for e in rec.encoder], dtype=np.int64)
        ke = ticks(len(te))
        rr.log("spindle/measured", rr.SeriesLines(colors=[C_SPINDLE_MEAS], names=["spindle measured (rpm)"]), static=True)
        rr.send_columns("spindle/measured", indexes=time(sec(te[ke])), columns=rr.Scalars.columns(scalars=np.array([e[1] for e in rec.encoder])[ke]))

    # ---- program and status
    lines = (rec.program or "").split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    name = rec.meta.get("cnc", {}).get("program_name", "program")
    rr.log("status/line", rr.SeriesLines(colors=[(200, 200, 200)], names=["program line"]), static=True)
    if rec.status:
        rr.send_columns(
            "status/line",
            indexes=time(sec([s[0] for s in rec.status])),
            columns=rr.Scalars.columns(scalars=np.array([float(s[2]) for s in rec.status])),
        )
    last = None
    for ns, state, line, tool, error in rec.status:
        st = STATE_NAMES.get(state, str(state))
        if (line, st) == last:
            continue
        rr.set_time("time", duration=float(sec(ns)))
        if lines:
            rr.log("program", rr.TextDocument(program_window(lines, line, st, name), media_type=rr.MediaType.MARKDOWN))
        text = lines[line - 1].strip() if 0 < line <= len(lines) else ""
        if last is None or st != last[1]:
            level = rr.TextLogLevel.ERROR if state == 3 else rr.TextLogLevel.WARN
            rr.log("status/log", rr.TextLog(f"{st}" + (f": {error}" if error else ""), level=level))
        if last is None or line != last[0]:
            rr.log("status/log", rr.TextLog(f"{line:>4}  {text}", level=rr.TextLogLevel.INFO))
        last = (line, st)
    rr.log("machine_file", rr.TextDocument(f"```toml\n{rec.machine or ''}\n```", media_type=rr.MediaType.MARKDOWN), static=True)
    rr.disconnect()
    return n, len(k), float(t_k[-1])


def window_extreme(v, k):
    """For each tick k[i], the value of largest magnitude in (k[i-1], k[i]]."""
    out = np.empty(len(k))
    prev = -1
    for i, ki in enumerate(k):
        w = v[prev + 1 : ki + 1]
        out[i] = w[np.argmax(np.abs(w))] if len(w) else v[ki]
        prev = ki
    return out


def held(changes, t_ns):
    """The value of the latest change at or before each time (0 before the first)."""
    ts = [c[0] for c in changes]
    return np.array([changes[i - 1][1] if (i := bisect.bisect_right(ts, int(t))) > 0 else 0.0 for t in t_ns])


def line_changes(rec):
    out, last = [], None
    for ns, _state, line, _tool, _err in rec.status:
        if line != last and line > 0:
            out.append((ns, line))
            last = line
    return out


def tool_shape(machine, lathe, rec):
    tools = {t.get("number"): t for t in machine.get("tool", [])}
    used = [s[3] for s in rec.status if s[3]]
    r = 3.0
    if used:
        n = used[0] % 100 if lathe else used[0]
        r = float(tools.get(n, {}).get("radius_mm") or r)
    r = max(r, 0.5)
    if lathe:
        # an insert: a nose circle at the tip and a shank along +X
        rr.log("world/tool/shape", rr.Capsules3D(lengths=[12.0], radii=[max(r, 0.8)], translations=[[0.0, 0.0, 0.0]],
                                                  rotation_axis_angles=[rr.RotationAxisAngle(axis=[0, 1, 0], degrees=90.0)],
                                                  colors=[C_TOOL]), static=True)
    else:
        rr.log("world/tool/shape", rr.Cylinders3D(lengths=[40.0], radii=[r], centers=[[0.0, 0.0, 20.0]], colors=[C_TOOL + (110,)]), static=True)
    rr.log("world/tool/tip", rr.Points3D([[0.0, 0.0, 0.0]], radii=[rr.Radius.ui_points(5.0)], colors=[C_TOOL]), static=True)


def blueprint(rec, names, lathe, diameter, xyz, programmed, feed_speed, max_rpm):
    # the camera frames the cut (the feed moves), not the rapids to and from home
    feeds = [p for _, kind, p in programmed if kind != "rapid"]
    allp = np.concatenate(feeds) if feeds else xyz
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pos, target, up = camera(lo, hi, lathe)
    path_range = rrb.VisibleTimeRange("time", start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.cursor_relative())
    view3d = rrb.Spatial3DView(
        origin="/world",
        name="tool path (mm): programmed grey (rapids thin), commanded orange, actual blue, tool yellow",
        time_ranges=[path_range],
        eye_controls=rrb.EyeControls3D(kind=rrb.Eye3DKind.Orbital, position=pos, look_target=target, eye_up=up),
        background=(24, 26, 30),
        line_grid=rrb.LineGrid3D(visible=not lathe, spacing=10.0, color=(70, 70, 70, 80)),
    )
    plots = []
    for j, n in enumerate(names):
        label = n.upper() + (" diameter" if diameter[j] else "")
        plots.append(rrb.TimeSeriesView(origin=f"/joints/{n}", name=f"{label}: setpoint and actual (mm)", plot_legend=rrb.PlotLegend(visible=True, corner=rrb.Corner2D.RightBottom)))
    plots.append(rrb.TimeSeriesView(origin="/following_error", name="following error (µm)" + (", X on the diameter" if any(diameter) else ""), plot_legend=rrb.PlotLegend(visible=True, corner=rrb.Corner2D.RightTop)))
    plots.append(rrb.Horizontal(
        rrb.TimeSeriesView(origin="/speed", name="path speed (mm/min)" + (", rapids off scale" if feed_speed else ""),
                           plot_legend=rrb.PlotLegend(visible=False),
                           axis_y=rrb.ScalarAxis(range=(0.0, 1.3 * feed_speed)) if feed_speed else None),
        rrb.TimeSeriesView(origin="/spindle", name="spindle (rpm)", plot_legend=rrb.PlotLegend(visible=False),
                           axis_y=rrb.ScalarAxis(range=(0.0, 1.1 * max_rpm)) if max_rpm > 0 else None),
    ))
    left = rrb.Vertical(
        view3d,
        rrb.Horizontal(
            rrb.TextDocumentView(origin="/program", name="program"),
            rrb.TextLogView(origin="/status/log", name="lines and state", columns=rrb.TextLogColumns(text_log_columns=["Body"])),
            column_shares=[3, 2],
        ),
        row_shares=[3, 1.4],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, rrb.Vertical(*plots), column_shares=[1.15, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="time"),
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("recording")
    ap.add_argument("-o", "--out", required=True)
    ap.add_argument("--programmed", help="the programmed path (cnc bag rrd hands it on stdin: -)")
    ap.add_argument("--app-id", help="application id (default cnc_<program name>)")
    a = ap.parse_args(argv)
    if not os.path.exists(a.recording):
        die(f"{a.recording}: no such file")
    rec = Recording(a.recording)
    programmed = []
    if a.programmed == "-":
        programmed = read_programmed(sys.stdin)
    elif a.programmed:
        with open(a.programmed) as f:
            programmed = read_programmed(f)
    name = rec.meta.get("cnc", {}).get("program_name") or os.path.splitext(os.path.basename(a.recording))[0]
    # an entry name: letters, digits, - and _ (Rerun mangles anything else)
    app_id = a.app_id or "cnc_" + re.sub(r"[^A-Za-z0-9_-]+", "_", os.path.splitext(name)[0])
    n, points, end = build(rec, programmed, a.out, app_id)
    print(f"{a.out}: {n} samples, {points} path points a path, {len(programmed)} programmed moves, {end:.3f} s")


if __name__ == "__main__":
    main()
