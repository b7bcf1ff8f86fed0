#!/usr/bin/env python3
"""Motion quality of one run, from the program geometry and the 1 ms samples.

usage:
  analyse.py PROGRAM SAMPLES [--json OUT.json] [--limits config/mill.toml]
  analyse.py --table MANIFEST.tsv        (markdown table of many runs)
  analyse.py --jerk-table MANIFEST.tsv   (bench/motion/jerk.sh: a sixth column
                                          names the machine file of each run;
                                          adds the curvature bound)
  analyse.py --explain

PROGRAM is the G-code that was run (either dialect: "(...)", ";..." and
'"...' comments are dropped); only the common subset is understood:
G00 G01 G02 G03 (XY plane, I J centre offsets, Z linear along an arc),
G17 G90 G94, X Y Z I J F; N, M, G61, G64 and P words are ignored. G91,
G18/G19, R-format arcs and anything else make it stop. The start point is
X0 Y0 Z0 (home on both controllers' mill).

SAMPLES is a LinuxCNC TSV of bench/linuxcnc/run.sh (columns t_s x_mm y_mm
z_mm ...) or a CSV of `cnc simulate --csv` (t, x_set, y_set, z_set, ...:
the setpoints are used, not the simulated actual positions). Samples must
be 1 ms apart (checked).

MANIFEST.tsv: one run per line, tab-separated: program label, controller
label, mode label, program file, samples file. Lines starting with # are
skipped.

Python 3 stdlib only.
"""
import json
import math
import os
import re
import sys

EXPLAIN = """\
Definitions (all from the commanded joint positions p[k], one per 1 ms servo
cycle / interpolation sample, dt = 1 ms):

* cycle time: from the last sample before the first change of any axis to
  the first sample after which no axis changes any more, i.e. the motion
  time; (k_last - k_first) * dt. The stationary rows before and after do
  not count (LinuxCNC's TSV keeps one at each end, ours starts at t = 0).
* deviation of a sample: its 3D distance to the nearest point of the
  programmed path, i.e. all G00/G01 lines and G02/G03 arcs of the program
  from X0 Y0 Z0 on, computed here from the program text (a spatial grid over
  the segments finds every segment within reach; the search widens until
  the nearest one is certain). Rapids count as path: both controllers move
  G00 along the straight line. Max deviation = the largest over all samples;
  "line" is the program line of the nearest segment, "t" the sample's time.
  An arc is centre = start + (I, J), its radius going linearly from the
  start radius to the end radius (they differ by < 0.0002 mm in the
  generated programs), Z linear.
* velocity per axis: (p[k+1] - p[k]) / dt; the largest magnitude.
* acceleration per axis: (p[k+1] - 2 p[k] + p[k-1]) / dt^2; the largest
  magnitude, and the number of samples over the axis's limit by more than
  2 mm/s^2 (LinuxCNC's TSV has positions to 1 nm, so its second
  differences are only good to about +-2 mm/s^2; ours are full doubles).
* stops: how many times the path speed |p[k+1] - p[k-1]| / (2 dt) falls
  under 3 mm/s between the first and the last sample (a run of such samples
  counts once). At an exact stop at 1500-2000 mm/s^2 the samples on either
  side are under 2 mm/s; the slowest feed in the programs is 10 mm/s.
* end error: distance of the last sample from the program's last point.
"""


STOP_SPEED = 3.0  # mm/s: a sample slower than this (central difference) is part of a stop

# ----------------------------------------------------------------- program --

def strip_comments(line):
    """Drop "(...)" (LinuxCNC), and everything from ';' (LinuxCNC) or '"'
    (cnc836) outside parentheses to the end of the line."""
    out, depth = [], 0
    for ch in line:
        if depth:
            depth += ch == "("
            depth -= ch == ")"
            continue
        if ch == "(":
            depth = 1
            out.append(" ")
        elif ch in ';"\n':
            break
        else:
            out.append(ch)
    return "".join(out)


def parse_program(path):
    """Segments of the program: dicts with kind 'line'/'arc', start, end (3D),
    line number, rapid flag; arcs also centre (x, y), sweep (signed rad),
    r0, r1, a0."""
    segs = []
    pos = [0.0, 0.0, 0.0]
    mode = None
    feed = None
    with open(path) as f:
        for ln, raw in enumerate(f, 1):
            s = strip_comments(raw).upper().strip()
            if not s:
                continue
            words = re.findall(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))", s)
            rest = re.sub(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))", "", s).strip()
            if rest:
                raise SystemExit(f"{path}:{ln}: cannot read {rest!r}")
            w = {}
            for letter, num in words:
                v = float(num)
                if letter == "G":
                    g = v
                    if g in (0, 1, 2, 3):
                        mode = int(g)
                    elif g in (17, 90, 94, 61, 64, 21, 40, 49, 54):
                        pass
                    else:
                        raise SystemExit(f"{path}:{ln}: G{num} is not in the common subset this tool reads")
                elif letter in "XYZIJFNMPQ":
                    w[letter] = v
                else:
                    raise SystemExit(f"{path}:{ln}: word {letter}{num} is not understood")
            if "F" in w:
                feed = w["F"] / 60.0
            if not any(k in w for k in "XYZ"):
                continue
            if mode is None:
                raise SystemExit(f"{path}:{ln}: motion without G00/G01/G02/G03")
            end = [w.get("X", pos[0]), w.get("Y", pos[1]), w.get("Z", pos[2])]
            if mode in (0, 1):
                if end != pos:
                    segs.append(dict(kind="line", a=tuple(pos), b=tuple(end), line=ln, rapid=mode == 0, f=feed))
            else:
                if "I" not in w and "J" not in w:
                    raise SystemExit(f"{path}:{ln}: arc without I/J")
                cx, cy = pos[0] + w.get("I", 0.0), pos[1] + w.get("J", 0.0)
                r0 = math.hypot(pos[0] - cx, pos[1] - cy)
                r1 = math.hypot(end[0] - cx, end[1] - cy)
                a0 = math.atan2(pos[1] - cy, pos[0] - cx)
                a1 = math.atan2(end[1] - cy, end[0] - cx)
                cw = mode == 2
                if cw:
                    sweep = -((a0 - a1) % (2 * math.pi))
                else:
                    sweep = (a1 - a0) % (2 * math.pi)
                if abs(sweep) < 1e-12 or (abs(end[0] - pos[0]) < 1e-9 and abs(end[1] - pos[1]) < 1e-9):
                    sweep = -2 * math.pi if cw else 2 * math.pi
                segs.append(dict(kind="arc", a=tuple(pos), b=tuple(end), line=ln, rapid=False,
                                 c=(cx, cy), r0=r0, r1=r1, a0=a0, sweep=sweep, f=feed))
            pos = end
    return segs


def seg_length(s):
    if s["kind"] == "line":
        return math.dist(s["a"], s["b"])
    r = 0.5 * (s["r0"] + s["r1"])
    return math.hypot(abs(s["sweep"]) * r, s["b"][2] - s["a"][2])


def seg_point(s, f):
    if s["kind"] == "line":
        a, b = s["a"], s["b"]
        return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))
    ang = s["a0"] + f * s["sweep"]
    r = s["r0"] + f * (s["r1"] - s["r0"])
    return (s["c"][0] + r * math.cos(ang), s["c"][1] + r * math.sin(ang),
            s["a"][2] + f * (s["b"][2] - s["a"][2]))


def seg_dist(s, p):
    if s["kind"] == "line":
        a, b = s["a"], s["b"]
        dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
        qx, qy, qz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
        L2 = dx * dx + dy * dy + dz * dz
        t = (qx * dx + qy * dy + qz * dz) / L2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        ex, ey, ez = qx - t * dx, qy - t * dy, qz - t * dz
        return math.sqrt(ex * ex + ey * ey + ez * ez)
    cx, cy = s["c"]
    th = math.atan2(p[1] - cy, p[0] - cx)
    sw = s["sweep"]
    d = (th - s["a0"]) % (2 * math.pi) if sw > 0 else (s["a0"] - th) % (2 * math.pi)
    best = min(math.dist(p, s["a"]), math.dist(p, s["b"]))
    if d <= abs(sw):
        f = d / abs(sw)
        r = s["r0"] + f * (s["r1"] - s["r0"])
        z = s["a"][2] + f * (s["b"][2] - s["a"][2])
        rp = math.hypot(p[0] - cx, p[1] - cy)
        best = min(best, math.hypot(rp - r, p[2] - z))
    return best


class Grid:
    """Segments registered in XY cells so that a segment passing within
    7/8 cell of a point is found in that point's own cell."""

    def __init__(self, segs, cell=0.5):
        self.cell = cell
        self.segs = segs
        self.cells = {}
        step = cell / 4
        for i, s in enumerate(segs):
            n = max(1, int(math.ceil(seg_length(s) / step)))
            seen = set()
            for k in range(n + 1):
                x, y, _ = seg_point(s, k / n)
                ix, iy = int(math.floor(x / cell)), int(math.floor(y / cell))
                for jx in (ix - 1, ix, ix + 1):
                    for jy in (iy - 1, iy, iy + 1):
                        if (jx, jy) not in seen:
                            seen.add((jx, jy))
                            self.cells.setdefault((jx, jy), []).append(i)

    def nearest(self, p):
        cell = self.cell
        ix, iy = int(math.floor(p[0] / cell)), int(math.floor(p[1] / cell))
        k = 0
        while True:
            cand = set()
            for jx in range(ix - k, ix + k + 1):
                for jy in range(iy - k, iy + k + 1):
                    c = self.cells.get((jx, jy))
                    if c:
                        cand.update(c)
            best, bi = math.inf, -1
            for i in cand:
                d = seg_dist(self.segs[i], p)
                if d < best:
                    best, bi = d, i
            if best <= (k + 0.875) * cell:
                return best, bi
            if k > 4096:  # nothing within 2 m: brute force
                for i, s in enumerate(self.segs):
                    d = seg_dist(s, p)
                    if d < best:
                        best, bi = d, i
                return best, bi
            k = 2 * k + 1


# ----------------------------------------------------------------- samples --

def read_samples(path):
    with open(path) as f:
        head = f.readline().strip()
        if "\t" in head:
            cols = head.split("\t")
            it, ix, iy, iz = (cols.index(c) for c in ("t_s", "x_mm", "y_mm", "z_mm"))
            sep = "\t"
            kind = "linuxcnc"
        else:
            cols = head.split(",")
            it, ix, iy, iz = (cols.index(c) for c in ("t", "x_set", "y_set", "z_set"))
            sep = ","
            kind = "ours"
        t, P = [], []
        for ln in f:
            v = ln.rstrip("\n").split(sep)
            if len(v) < len(cols):
                continue
            t.append(float(v[it]))
            P.append((float(v[ix]), float(v[iy]), float(v[iz])))
    for a, b in zip(t, t[1:]):
        if abs(b - a - 0.001) > 1e-6:
            raise SystemExit(f"{path}: samples are not 1 ms apart ({a} -> {b})")
    return kind, t, P


def read_limits(path):
    try:
        import tomllib
    except ImportError:  # python < 3.11: the values of config/mill.toml
        return {"x": (250.0, 2000.0), "y": (250.0, 2000.0), "z": (150.0, 1500.0)}
    with open(path, "rb") as f:
        m = tomllib.load(f)
    return {a["name"]: (a["max_velocity_mm_s"], a["max_acceleration_mm_s2"]) for a in m["axis"]}


# ------------------------------------------------------- curvature bound --

SHARP_DEG = 10.0   # a junction turning this much or more is a corner (blended within P)
FIT_MM = 2.0       # a polyline's curvature: the circle through points this far along either side


def _circle_curvature(p, q, r):
    """1/R of the circle through three points (0 for collinear ones)."""
    a, b, c = math.dist(p, q), math.dist(q, r), math.dist(p, r)
    u = [q[k] - p[k] for k in range(3)]
    v = [r[k] - p[k] for k in range(3)]
    cr = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    area2 = math.sqrt(sum(x * x for x in cr))
    return 0.0 if a * b * c == 0 else 2.0 * area2 / (a * b * c)


def curvature_bound(segs, vmax, amax, jmax, tol):
    """Lower bound of the motion time, s: the integral of ds / min(F,
    sqrt(a/kappa), cbrt(j/kappa^2)) over the program's path (rapids at the
    axes' speed), accelerations along the path ignored. kappa: lines 0, arcs
    1/R (the XY radius); a junction turning SHARP_DEG or more is a corner,
    rounded by the largest arc within the tolerance P and half of either
    line (the arc replaces the lines' tangent lengths); a run of lines
    turning less per junction is a polyline whose curvature at a vertex is
    that of the circle through the vertex and the polyline's points FIT_MM
    along either side (within the run; this averages the vertices' rounding
    out), each half line taking its vertex's curvature. a, j: the smallest
    acceleration and jerk limit of the axes (jmax None: no jerk limit)."""
    amin = min(amax)
    def speed(f, kappa):
        v = f
        if kappa > 0:
            v = min(v, math.sqrt(amin / kappa))
            if jmax:
                v = min(v, (jmax / (kappa * kappa)) ** (1.0 / 3.0))
        return v
    def cap(s):
        d = [s["b"][k] - s["a"][k] for k in range(3)]
        L = math.sqrt(sum(x * x for x in d)) or 1.0
        top = min(vmax[k] / (abs(d[k]) / L) for k in range(3) if d[k] != 0) if any(d) else vmax[0]
        return top if s["rapid"] or s["f"] is None else min(s["f"], top)
    def tdir(s, end):
        if s["kind"] == "line":
            d = [s["b"][k] - s["a"][k] for k in range(3)]
        else:
            ang = s["a0"] + (s["sweep"] if end else 0.0)
            sg = 1.0 if s["sweep"] > 0 else -1.0
            r = s["r1"] if end else s["r0"]
            d = [-sg * math.sin(ang) * r * abs(s["sweep"]), sg * math.cos(ang) * r * abs(s["sweep"]),
                 s["b"][2] - s["a"][2]]
        n = math.sqrt(sum(x * x for x in d)) or 1.0
        return [x / n for x in d]
    n = len(segs)
    L = [seg_length(s) for s in segs]
    # turn at the junction before segment i (None: no junction, a rapid)
    turn = [None] * n
    for i in range(1, n):
        if segs[i]["rapid"] or segs[i - 1]["rapid"]:
            continue
        t1, t2 = tdir(segs[i - 1], True), tdir(segs[i], False)
        turn[i] = math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(t1, t2)))))
    sharp = math.radians(SHARP_DEG)
    poly = lambda i: segs[i]["kind"] == "line" and not segs[i]["rapid"]
    # polyline vertex curvature at the junction before segment i (lines on both sides)
    kv = [None] * n
    for i in range(1, n):
        if turn[i] is None or turn[i] >= sharp or not (poly(i) and poly(i - 1)):
            continue
        # walk back and forward FIT_MM within the run
        q = segs[i]["a"]
        j, acc = i - 1, 0.0
        while True:
            acc += L[j]
            if acc >= FIT_MM or j == 0 or not poly(j - 1) or turn[j] is None or turn[j] >= sharp:
                break
            j -= 1
        p0 = segs[j]["a"]
        k, acc = i, 0.0
        while True:
            acc += L[k]
            if acc >= FIT_MM or k + 1 >= n or not poly(k + 1) or turn[k + 1] is None or turn[k + 1] >= sharp:
                break
            k += 1
        p2 = segs[k]["b"]
        if j == i - 1 and k == i:
            continue  # an isolated kink: a corner
        kv[i] = _circle_curvature(p0, q, p2)
    total = 0.0
    cut = [0.0] * n  # tangent length taken off each end of a line by corner arcs
    cut_end = [0.0] * n
    for i in range(1, n):
        th = turn[i]
        if th is None or th <= 1e-12 or kv[i] is not None:
            continue
        if not (segs[i - 1]["kind"] == "line" and segs[i]["kind"] == "line"):
            continue  # a kink at an arc: passed at the arc's own limit
        half = 0.5 * min(L[i - 1], L[i])
        r = half / math.tan(0.5 * th) if th < math.pi - 1e-9 else 0.0
        if tol > 0 and th < math.pi - 1e-9:
            r = min(r, tol / (1.0 / math.cos(0.5 * th) - 1.0))
        if r <= 0:
            continue
        cut_end[i - 1] = r * math.tan(0.5 * th)
        cut[i] = r * math.tan(0.5 * th)
        total += r * th / speed(min(cap(segs[i - 1]), cap(segs[i])), 1.0 / r)
    for i, s in enumerate(segs):
        f = cap(s)
        if s["kind"] == "arc":
            r = 0.5 * (s["r0"] + s["r1"])
            total += L[i] / speed(f, 1.0 / r if r > 0 else 0.0)
            continue
        body = max(0.0, L[i] - cut[i] - cut_end[i])
        k0 = kv[i] if kv[i] is not None else 0.0
        k1 = kv[i + 1] if i + 1 < n and kv[i + 1] is not None else 0.0
        total += 0.5 * body / speed(f, k0) + 0.5 * body / speed(f, k1)
    return total


# ----------------------------------------------------------------- analyse --

def analyse(prog, samples, limits):
    segs = parse_program(prog)
    kind, t, P = read_samples(samples)
    dt = 0.001
    n = len(P)
    eps = 1e-9
    moved = [i for i in range(1, n) if any(abs(P[i][k] - P[i - 1][k]) > eps for k in range(3))]
    if not moved:
        raise SystemExit(f"{samples}: nothing moves")
    k0, k1 = moved[0] - 1, moved[-1]
    res = {"program": prog, "samples": samples, "source": kind, "rows": n,
           "cycle_s": round((k1 - k0) * dt, 6), "blocks": len(segs)}
    names = "xyz"
    vmax, amax, over, aat = [0.0] * 3, [0.0] * 3, [0] * 3, [0.0] * 3
    for i in range(n - 1):
        for k in range(3):
            v = abs(P[i + 1][k] - P[i][k]) / dt
            if v > vmax[k]:
                vmax[k] = v
    for i in range(1, n - 1):
        for k in range(3):
            a = abs(P[i + 1][k] - 2 * P[i][k] + P[i - 1][k]) / (dt * dt)
            if a > amax[k]:
                amax[k] = a
                aat[k] = t[i]
            if a > limits[names[k]][1] + 2.0:
                over[k] += 1
    # jerk: sampled third differences, m/s³
    jmax = [0.0] * 3
    for i in range(1, n - 2):
        for k in range(3):
            j = abs(P[i + 2][k] - 3 * P[i + 1][k] + 3 * P[i][k] - P[i - 1][k]) / (dt ** 3) / 1000.0
            if j > jmax[k]:
                jmax[k] = j
    # stops: runs of samples whose path speed is under STOP_SPEED
    stops, slow = 0, False
    for i in range(k0 + 1, k1):
        v = math.dist(P[i + 1], P[i - 1]) / (2 * dt)
        if v < STOP_SPEED and not slow:
            stops += 1
        slow = v < STOP_SPEED
    res["stops"] = stops
    grid = Grid(segs)
    dmax, dat, dline, dsum = 0.0, 0.0, 0, 0.0
    over_tol = {0.001: 0, 0.01: 0, 0.1: 0}
    devs = []
    for i in range(k0, k1 + 1):
        d, si = grid.nearest(P[i])
        devs.append(d)
        if d > dmax:
            dmax, dat, dline = d, t[i], segs[si]["line"]
        for tol in over_tol:
            if d > tol:
                over_tol[tol] += 1
    devs.sort()
    res.update({
        "max_dev_mm": dmax, "max_dev_t_s": dat, "max_dev_line": dline,
        "p99_dev_mm": devs[int(0.99 * (len(devs) - 1))],
        "samples_dev_over": {str(k): v for k, v in over_tol.items()},
        "max_vel_mm_s": dict(zip(names, vmax)),
        "max_acc_mm_s2": dict(zip(names, amax)),
        "max_acc_t_s": dict(zip(names, aat)),
        "max_jerk_m_s3": dict(zip(names, jmax)),
        "samples_acc_over_limit": dict(zip(names, over)),
        "limits": {k: {"vel": v[0], "acc": v[1]} for k, v in limits.items()},
        "end_error_mm": math.dist(P[-1], segs[-1]["b"]),
    })
    return res


def read_machine(path):
    """Per-axis (velocity, acceleration, jerk or None) of a machine file."""
    import tomllib
    with open(path, "rb") as f:
        m = tomllib.load(f)
    return {a["name"]: (a["max_velocity_mm_s"], a["max_acceleration_mm_s2"], a.get("max_jerk_mm_s3"))
            for a in m["axis"]}


def jerk_table(manifest):
    """The table of bench/motion/jerk.sh: manifest lines of six columns,
    the sixth the machine file whose limits (and jerk) the run had; the
    LinuxCNC row (jerk column "none": 2.9 has no jerk limit) is the
    reference of the ratio column."""
    rows, ref = [], {}
    for ln in open(manifest):
        if not ln.strip() or ln.startswith("#"):
            continue
        label, ctrl, mode, prog, samples, mfile = ln.rstrip("\n").split("\t")
        lim = read_machine(mfile)
        r = analyse(prog, samples, {k: v[:2] for k, v in lim.items()})
        jerk = r_j = None
        if not ctrl.startswith("LinuxCNC"):
            r_j = [v[2] for v in lim.values() if v[2]]
            jerk = min(r_j) if r_j else None
        tol = float(mode.split("P")[1].split()[0]) if "G64 P" in mode else 0.0
        segs = parse_program(prog)
        r["bound_s"] = curvature_bound(segs, [lim[k][0] for k in "xyz"], [lim[k][1] for k in "xyz"], jerk, tol)
        r.update(label=label, controller=ctrl, mode=mode, jerk=jerk, limits_file=mfile)
        if ctrl.startswith("LinuxCNC"):
            ref[label] = r["cycle_s"]
        rows.append(r)
        print(f"analysed {label} / {ctrl} {mode} j={jerk}: {r['cycle_s']:.3f} s, bound {r['bound_s']:.3f} s, "
              f"max dev {r['max_dev_mm']:.4f} mm", file=sys.stderr)
    L = rows[0]["limits"] if rows else {}
    print("| program | controller | jerk m/s³ | mode | cycle time s | × LinuxCNC | curvature bound s "
          "| max deviation mm (line) | max \\|v\\| X / Y / Z mm/s | max \\|a\\| X / Y / Z mm/s² "
          "| max \\|j\\| X / Y / Z m/s³ | end error mm |")
    print("|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        v, a, j = r["max_vel_mm_s"], r["max_acc_mm_s2"], r["max_jerk_m_s3"]
        ratio = f"{r['cycle_s'] / ref[r['label']]:.3f}" if r["label"] in ref else "–"
        jj = "none" if r["jerk"] is None else f"{r['jerk'] / 1000:g}"
        print(f"| {r['label']} | {r['controller']} | {jj} | {r['mode']} | {r['cycle_s']:.3f} | {ratio} "
              f"| {r['bound_s']:.3f} | {r['max_dev_mm']:.5f} ({r['max_dev_line']}) "
              f"| {v['x']:.1f} / {v['y']:.1f} / {v['z']:.1f} | {a['x']:.0f} / {a['y']:.0f} / {a['z']:.0f} "
              f"| {j['x']:.0f} / {j['y']:.0f} / {j['z']:.0f} | {r['end_error_mm']:.6f} |")
    return rows


def table(manifest, limits_path):
    limits = read_limits(limits_path)
    rows = []
    for ln in open(manifest):
        if not ln.strip() or ln.startswith("#"):
            continue
        label, ctrl, mode, prog, samples = ln.rstrip("\n").split("\t")
        r = analyse(prog, samples, limits)
        r.update(label=label, controller=ctrl, mode=mode)
        rows.append(r)
        print(f"analysed {label} / {ctrl} {mode}: {r['cycle_s']:.3f} s, max dev {r['max_dev_mm']:.4f} mm",
              file=sys.stderr)
    L = limits
    print("| program | controller | mode | cycle time s | stops | max deviation mm (line) | samples > 0.01 mm "
          f"| max \\|a\\| X / Y / Z mm/s² (limit {L['x'][1]:g} / {L['y'][1]:g} / {L['z'][1]:g}) "
          "| samples over accel limit X / Y / Z "
          f"| max \\|v\\| X / Y / Z mm/s (limit {L['x'][0]:g} / {L['y'][0]:g} / {L['z'][0]:g}) "
          "| max \\|j\\| X / Y / Z m/s³ |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        a, v, o = r["max_acc_mm_s2"], r["max_vel_mm_s"], r["samples_acc_over_limit"]
        j = r["max_jerk_m_s3"]

        def acc(k):
            s = f"{a[k]:.0f}"
            return f"**{s}**" if o[k] else s
        print(f"| {r['label']} | {r['controller']} | {r['mode']} | {r['cycle_s']:.3f} | {r['stops']} "
              f"| {r['max_dev_mm']:.5f} ({r['max_dev_line']}) | {r['samples_dev_over']['0.01']} "
              f"| {acc('x')} / {acc('y')} / {acc('z')} | {o['x']} / {o['y']} / {o['z']} "
              f"| {v['x']:.1f} / {v['y']:.1f} / {v['z']:.1f} "
              f"| {j['x']:.0f} / {j['y']:.0f} / {j['z']:.0f} |")
    return rows


def main(argv):
    limits_path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "mill.toml")
    if "--limits" in argv:
        i = argv.index("--limits")
        limits_path = argv[i + 1]
        del argv[i:i + 2]
    if "--explain" in argv:
        print(EXPLAIN)
        return
    if "--jerk-table" in argv:
        i = argv.index("--jerk-table")
        rows = jerk_table(argv[i + 1])
        if "--json" in argv:
            with open(argv[argv.index("--json") + 1], "w") as f:
                json.dump(rows, f, indent=1)
        return
    if "--table" in argv:
        i = argv.index("--table")
        rows = table(argv[i + 1], limits_path)
        if "--json" in argv:
            with open(argv[argv.index("--json") + 1], "w") as f:
                json.dump(rows, f, indent=1)
        return
    out = None
    if "--json" in argv:
        i = argv.index("--json")
        out = argv[i + 1]
        del argv[i:i + 2]
    if len(argv) != 2:
        sys.exit(__doc__)
    r = analyse(argv[0], argv[1], read_limits(limits_path))
    text = json.dumps(r, indent=1)
    if out:
        with open(out, "w") as f:
            f.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main(sys.argv[1:])
