#!/usr/bin/env python3
"""Generate the two motion-quality test programs of issue 9, in both dialects.

usage: gen.py {part,dense,cam,helix_pairs} --dialect {linuxcnc,cnc836} [--mode "G64 P0.01"]
              [-o OUT] [--segments N] [--noise MM] [--seed S] [--stats]
              [--ellipse-biarcs N]

Programs (on the bundled mill, X 0..500, Y -200..500, Z -100..100, limits
of config/mill.toml; both start at X0 Y0 Z0 and end at X0 Y0 Z5):

  part   a 3-axis test part, 432 moves: plunge and 3D ramp, a contour of
         lines and tangent G03 corner arcs, pocket rings with sharp
         90-degree corners, polylines that turn 1, 1.9, 2.5 and 5 degrees
         per junction (nearly tangent), a zigzag with 127 and 23 degree
         turns and a reversal, S-curves of tangent arcs, small arcs (R2, R1)
         at F3000, full circles, a spiral of half circles, 3D lines (a
         sloped zigzag and two polyline helices), rapids between them.
  dense  a CAM-like closed contour of N (default 10,000) short lines,
         0.01-0.5 mm, on a smooth epitrochoid sampled with a varying step
         (chordal 5 um where it is curved, plus a slowly varying pattern
         between 0.01 and 0.5 mm), each vertex moved off the curve by up to
         --noise mm (default 0.001) and rounded to 0.1 um; Z plunge at the
         start, F3000 in XY.
  cam    issue 17's program at F6000 (100 mm/s): sharp corners, an ellipse
         of 1600 lines rounded to 1 um (--ellipse-biarcs N: N tangent
         biarcs instead), slots of lines and tangent R5/R2/R8
         arcs, a polyline helix (R10, 3 degrees per line); run with the
         limits of bench/motion/jerk.sh (100 mm/s, 1000 mm/s^2).
  helix_pairs  helical arcs run from rest to rest: full turns of R 0.5, 2
         and 10 mm down 2 mm (G02) and back (G03) at F6000.

Both dialects get the same blocks from the same source, in the common subset
G17 G90 G94 G00 G01 G02 G03 X Y Z I J F M02: only the comments differ
(LinuxCNC "( ... )", cnc836 '" ...'). --mode puts one line (e.g. "G64 P0.01"
or "G61") right after the header line. Python 3 stdlib only; the output is
deterministic (fixed --seed).
"""
import argparse
import math
import random
import sys


def fmt(v):
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def rnd(v):
    return round(v, 4) + 0.0


class Prog:
    """Blocks with positions rounded as written, so that the centre offsets
    I J are exact relative to the written start point."""

    def __init__(self):
        self.lines = []  # ("c", text) or ("g", text)
        self.p = [0.0, 0.0, 0.0]
        self.f = None

    def comment(self, text):
        self.lines.append(("c", text))

    def code(self, text):
        self.lines.append(("g", text))

    def _words(self, x, y, z):
        w = []
        n = list(self.p)
        for k, (ax, v) in enumerate(zip("XYZ", (x, y, z))):
            if v is None:
                continue
            v = rnd(v)
            if v != self.p[k]:
                w.append(f"{ax}{fmt(v)}")
            n[k] = v
        return w, n

    def _feed(self, f):
        if f is not None and f != self.f:
            self.f = f
            return [f"F{fmt(f)}"]
        return []

    def rapid(self, x=None, y=None, z=None):
        w, n = self._words(x, y, z)
        if w:
            self.code(" ".join(["G00"] + w))
            self.p = n

    def line(self, x=None, y=None, z=None, f=None):
        w, n = self._words(x, y, z)
        if w:
            self.code(" ".join(["G01"] + w + self._feed(f)))
            self.p = n

    def arc(self, cw, cx, cy, ex, ey, f=None, z=None):
        """Arc in XY about the centre (cx, cy) to (ex, ey); (ex, ey) equal to
        the start makes a full circle. The end point is put back on the
        circle through the written start point before rounding. `z`: a
        helix's end height (None: in the plane)."""
        sx, sy = self.p[0], self.p[1]
        i, j = rnd(cx - sx), rnd(cy - sy)
        cx, cy = sx + i, sy + j
        r = math.hypot(i, j)
        a = math.atan2(ey - cy, ex - cx)
        full = abs(ex - sx) < 1e-9 and abs(ey - sy) < 1e-9
        if not full:
            ex, ey = cx + r * math.cos(a), cy + r * math.sin(a)
        ex, ey = rnd(ex), rnd(ey)
        if full:
            ex, ey = sx, sy
        w = [f"X{fmt(ex)}", f"Y{fmt(ey)}"]
        ez = self.p[2] if z is None else rnd(z)
        if ez != self.p[2]:
            w.append(f"Z{fmt(ez)}")
        w += [f"I{fmt(i)}", f"J{fmt(j)}"]
        self.code(" ".join(["G02" if cw else "G03"] + w + self._feed(f)))
        self.p = [ex, ey, ez]


def polyline_turning(pr, turn_deg, seg, n, f, left=True):
    """n lines of length seg, each turning turn_deg from the previous one
    (a regular polygon arc), starting in the direction of the last move."""
    h = pr.heading
    for _ in range(n):
        h += math.radians(turn_deg if left else -turn_deg)
        pr.line(pr.p[0] + seg * math.cos(h), pr.p[1] + seg * math.sin(h), f=f)
    pr.heading = h


def part():
    pr = Prog()
    pr.comment("issue 9 test part: 3-axis mill, limits of config/mill.toml")
    pr.comment("generated by bench/motion/gen.py part; start and end at Z5 over X0 Y0")
    F, FF, FP, FR = 3000, 6000, 600, 1500
    # --- 1: plunge, 3D ramp down to Z-2, outer contour (lines + tangent
    # R10 corner arcs, one sharp corner)
    pr.comment("1 plunge, ramp, contour 20..120 x 20..100 with R10 corners, one sharp corner")
    pr.rapid(z=5)
    pr.rapid(30, 20)
    pr.line(z=0, f=FP)
    pr.line(70, 20, -2, f=FR)            # 3D ramp
    pr.line(30, 20, -2, f=F)            # back along the ramp (180 deg reversal)
    pr.line(110, 20)
    pr.arc(False, 110, 30, 120, 30)
    pr.line(120, 90)
    pr.arc(False, 110, 90, 110, 100)
    pr.line(30, 100)
    pr.arc(False, 30, 90, 20, 90)
    pr.line(20, 20)                      # sharp 90 deg corner at X20 Y20
    pr.line(30, 20)
    # --- 2: pocket rings with sharp corners, stepping in by 6 mm, Z-2
    pr.comment("2 pocket rings, sharp 90 degree corners, 45 degree step-ins")
    x0, y0, x1, y1 = 26, 26, 114, 94
    pr.line(x0, y0)
    while x1 - x0 > 12 and y1 - y0 > 12:
        pr.line(x1, y0)
        pr.line(x1, y1)
        pr.line(x0, y1)
        pr.line(x0, y0)
        x0, y0, x1, y1 = x0 + 6, y0 + 6, x1 - 6, y1 - 6
        pr.line(x0, y0)                  # 45 deg diagonal step in
    pr.rapid(z=5)
    # --- 3: nearly tangent polylines at F3000: 1, 1.9, 2.5, 5 deg per junction
    pr.comment("3 polylines turning 1, 1.9, 2.5 and 5 degrees per junction, 2 mm lines")
    pr.rapid(150, 20)
    pr.line(z=-1, f=FP)
    pr.heading = 0.0
    pr.line(160, 20, f=F)
    for turn, n in ((1.0, 40), (1.9, 30), (2.5, 24), (5.0, 18)):
        polyline_turning(pr, turn, 2.0, n, F, left=True)
        pr.line(pr.p[0] + 5 * math.cos(pr.heading), pr.p[1] + 5 * math.sin(pr.heading), f=F)
    pr.rapid(z=5)
    # --- 4: zigzag with sharp turns
    pr.comment("4 zigzag: 127 and 23 degree turns, a reversal")
    pr.rapid(150, 120)
    pr.line(z=-1, f=FP)
    for k in range(8):                    # triangle wave: 127 deg turns
        pr.line(pr.p[0] + 5, 130 if k % 2 == 0 else 120, f=F)
    for k in range(8):                    # shallow wave: 23 deg turns
        pr.line(pr.p[0] + 10, 122 if k % 2 == 0 else 120, f=F)
    pr.line(pr.p[0] + 20, 120, f=FF)
    pr.line(pr.p[0] - 10, 120, f=FF)      # reversal
    pr.line(pr.p[0], 135, f=F)
    pr.rapid(z=5)
    # --- 5: S-curves of tangent arcs and small arcs at feed
    pr.comment("5 S-curves of tangent R8 arcs at F6000, R2 and R1 arcs at F3000")
    pr.rapid(20, 140)
    pr.line(z=-1, f=FP)
    pr.line(30, 140, f=FF)
    for k in range(4):                    # alternating half circles, R8
        cx = pr.p[0] + 8
        pr.arc(k % 2 == 0, cx, 140, cx + 8, 140, f=FF)
    pr.line(pr.p[0] + 10, 140, f=F)
    for k in range(4):                    # R2 half circles at F3000: 1250 mm/s^2
        cx = pr.p[0] + 2
        pr.arc(k % 2 == 1, cx, 140, cx + 2, 140, f=F)
    for k in range(4):                    # R1 half circles at F3000: 2500 mm/s^2
        cx = pr.p[0] + 1
        pr.arc(k % 2 == 0, cx, 140, cx + 1, 140, f=F)
    pr.line(pr.p[0] + 10, 140, f=F)
    pr.line(pr.p[0], 150, f=F)            # sharp line-line
    pr.arc(True, pr.p[0] + 5, 150, pr.p[0] + 5, 155, f=F)  # line -> arc, tangent
    pr.line(pr.p[0] + 10, 158, f=F)       # arc -> line, 16.7 deg kink
    pr.arc(False, pr.p[0], 165, pr.p[0] - 7, 165, f=F)     # line -> arc, kink
    pr.rapid(z=5)
    # --- 6: circles: full circles and a spiral of half circles
    pr.comment("6 full circles R10 and R6, a spiral of half circles R2..R9 (tangent)")
    pr.rapid(200, 60)
    pr.line(z=-1, f=FP)
    pr.arc(True, 190, 60, 200, 60, f=F)   # full circle R10, clockwise
    pr.line(196, 60, f=F)                 # radial step (90 deg)
    pr.arc(False, 190, 60, 196, 60, f=F)  # full circle R6, counter-clockwise
    pr.line(192, 60, f=F)
    # spiral of half circles about alternating centres A (190, 60) and
    # B (191, 60), counter-clockwise: junctions on the X axis are tangent,
    # the radius grows by 1 mm each half turn (R2 .. R9)
    for k in range(8):
        c = 190.0 if k % 2 == 0 else 191.0
        rr = abs(pr.p[0] - c)
        pr.arc(False, c, 60, c - rr if k % 2 == 0 else c + rr, 60, f=F)
    pr.rapid(z=5)
    # --- 7: 3D lines: a sloped zigzag and a polyline helix
    pr.comment("7 3D lines: a sloped zigzag, a polyline helix (5 and 1.5 deg per junction)")
    pr.rapid(150, 170)
    pr.line(z=-1, f=FP)
    for k in range(10):
        pr.line(pr.p[0] + 4, 175 if k % 2 == 0 else 170, -1 - 0.3 * (k + 1), f=F)
    pr.line(z=-1, f=FR)
    for step_deg, turns, rad, cz in ((5.0, 1.0, 8.0, 210.0), (1.5, 0.5, 20.0, 250.0)):
        pr.rapid(z=5)
        pr.rapid(cz + rad, 60)
        pr.line(z=-1, f=FP)
        n = int(round(360 * turns / step_deg))
        for k in range(1, n + 1):
            a = math.radians(step_deg * k)
            pr.line(cz + rad * math.cos(a), 60 + rad * math.sin(a), -1 - 2.0 * k / n, f=F)
    # --- end
    pr.comment("end")
    pr.rapid(z=5)
    pr.rapid(0, 0)
    return pr


def ellipse_biarcs(pr, cx, cy, ea, eb, n, f):
    """The ellipse as n tangent biarcs (2n G03 arcs): between the true
    ellipse's points at parameters 2*pi*k/n, the equal-length biarc that
    meets its tangents there, so that no rounding noise and no merged lines
    remain (what a CAM system's arc fitting would give)."""
    def pt(t):
        return (cx + ea * math.cos(t), cy + eb * math.sin(t))

    def tan(t):
        x, y = -ea * math.sin(t), eb * math.cos(t)
        h = math.hypot(x, y)
        return (x / h, y / h)

    def centre(p0, t0, p1):
        # the circle through p0 and p1 tangent to t0 at p0
        nx, ny = -t0[1], t0[0]
        dx, dy = p1[0] - p0[0], p1[1] - p0[1]
        r = (dx * dx + dy * dy) / (2 * (dx * nx + dy * ny))
        return (p0[0] + r * nx, p0[1] + r * ny)

    def arc_to(p1, t0):
        p0 = (pr.p[0], pr.p[1])
        c = centre(p0, t0, p1)
        pr.arc(False, c[0], c[1], p1[0], p1[1], f=f)
        rx, ry = pr.p[0] - c[0], pr.p[1] - c[1]
        h = math.hypot(rx, ry)
        return (-ry / h, rx / h)

    t_here = tan(0.0)
    for k in range(n):
        a0, a1 = 2 * math.pi * k / n, 2 * math.pi * (k + 1) / n
        p0, p1, t0, t1 = pt(a0), pt(a1), tan(a0), tan(a1)
        vx, vy = p1[0] - p0[0], p1[1] - p0[1]
        vt = vx * (t0[0] + t1[0]) + vy * (t0[1] + t1[1])
        c = 1 - (t0[0] * t1[0] + t0[1] * t1[1])
        vv = vx * vx + vy * vy
        d = vv / (2 * vt) if abs(c) < 1e-12 else (-vt + math.sqrt(vt * vt + 2 * c * vv)) / (2 * c)
        mid = ((p0[0] + d * t0[0] + p1[0] - d * t1[0]) / 2, (p0[1] + d * t0[1] + p1[1] - d * t1[1]) / 2)
        t_here = arc_to(mid, t_here)
        t_here = arc_to(p1, t_here)


def cam(ellipse_biarcs_n=0):
    """Issue 17's CAM-like program at 100 mm/s (F6000): sharp corners, an
    ellipse of 1600 short lines rounded to 1 um (or, with
    ellipse_biarcs_n, that many tangent biarcs), a slot of lines and
    tangent arcs, a polyline helix."""
    pr = Prog()
    pr.comment("issue 17 CAM-like program: F6000 (100 mm/s), sharp corners, ellipse, slot, helix")
    pr.comment("generated by bench/motion/gen.py cam; start and end at Z5 over X0 Y0")
    F, FP = 6000, 600
    # --- 1: sharp corners: a square and a triangle (90, 135 and 45 degree turns)
    pr.comment("1 sharp corners: 40 mm square, a triangle")
    pr.rapid(z=5)
    pr.rapid(20, 20)
    pr.line(z=-1, f=FP)
    for x, y in ((60, 20), (60, 60), (20, 60), (20, 20), (60, 60), (20, 60), (20, 20)):
        pr.line(x, y, f=F)
    pr.rapid(z=5)
    # --- 2: an ellipse of 1600 lines, vertices rounded to 1 um
    pr.comment("2 ellipse 80 x 30 mm as 1600 lines, vertices rounded to 0.001 mm")
    cx, cy, ea, eb, n = 130.0, 40.0, 40.0, 15.0, 1600
    pts = [(round(cx + ea * math.cos(2 * math.pi * k / n), 3),
            round(cy + eb * math.sin(2 * math.pi * k / n), 3)) for k in range(n + 1)]
    pr.rapid(*pts[0])
    pr.line(z=-1, f=FP)
    if ellipse_biarcs_n:
        ellipse_biarcs(pr, cx, cy, ea, eb, ellipse_biarcs_n, F)
    else:
        for x, y in pts[1:]:
            pr.line(x, y, f=F)
    pr.rapid(z=5)
    # --- 3: a slot of lines and tangent arcs: R5 ends, then an R2 slot,
    # then an S of tangent R8 arcs
    pr.comment("3 slots of lines and tangent arcs: R5 and R2 ends, an S of R8 arcs")
    pr.rapid(200, 20)
    pr.line(z=-1, f=FP)
    pr.line(240, 20, f=F)
    pr.arc(False, 240, 25, 240, 30, f=F)
    pr.line(200, 30, f=F)
    pr.arc(False, 200, 25, 200, 20, f=F)
    pr.line(210, 20, f=F)
    pr.line(210, 40, f=F)               # sharp corner into the R2 slot
    pr.line(240, 40, f=F)
    pr.arc(False, 240, 42, 240, 44, f=F)
    pr.line(210, 44, f=F)
    pr.arc(False, 210, 42, 210, 40, f=F)
    pr.line(220, 40, f=F)
    pr.line(220, 60, f=F)               # sharp corner into the S
    pr.line(230, 60, f=F)
    for k in range(4):
        c = pr.p[0] + 8
        pr.arc(k % 2 == 0, c, 60, c + 8, 60, f=F)
    pr.line(pr.p[0] + 10, 60, f=F)
    pr.rapid(z=5)
    # --- 4: a polyline helix: R10, 3 degrees per line, 3 turns, Z -1 to -4
    pr.comment("4 polyline helix R10, 3 degrees per line, 3 turns, Z falling 1 mm per turn")
    hx, hy, hr = 330.0, 40.0, 10.0
    pr.rapid(hx + hr, hy)
    pr.line(z=-1, f=FP)
    n = 360
    for k in range(1, n + 1):
        a = math.radians(3.0 * k)
        pr.line(hx + hr * math.cos(a), hy + hr * math.sin(a), -1 - 3.0 * k / n, f=F)
    pr.comment("end")
    pr.rapid(z=5)
    pr.rapid(0, 0)
    return pr


def helix_pairs():
    """Helical arcs run from rest to rest: for R 0.5, 2 and 10 mm a full
    turn G02 down 2 mm and a full turn G03 back up (each reverses the
    other, so both start and end at rest), at F6000, between a plunge and
    a rapid."""
    pr = Prog()
    pr.comment("helical arc pairs from rest to rest: R 0.5, 2 and 10 mm, full turns down 2 mm and back, F6000")
    pr.comment("generated by bench/motion/gen.py helix_pairs; start and end at Z5 over X0 Y0")
    pr.rapid(z=5)
    for k, r in enumerate((0.5, 2.0, 10.0)):
        cx, cy = 40.0 + 40.0 * k, 40.0
        pr.rapid(cx + r, cy)
        pr.line(z=-1, f=600)
        pr.arc(True, cx, cy, cx + r, cy, f=6000, z=-3)
        pr.arc(False, cx, cy, cx + r, cy, f=6000, z=-1)
        pr.rapid(z=5)
    pr.rapid(0, 0)
    return pr


def epitrochoid(t, R, r, d):
    k = (R + r) / r
    return ((R + r) * math.cos(t) - d * math.cos(k * t),
            (R + r) * math.sin(t) - d * math.sin(k * t))


def dense(n_seg, noise, seed):
    """A closed epitrochoid (5 lobes) walked by arc length with a varying
    step; the scale is chosen so that exactly n_seg lines close the loop."""
    R, r, d = 80.0, 10.0, 9.0
    cx, cy = 250.0, 150.0
    # fine polyline of the curve to parametrize by arc length
    M = 200000
    pts = [epitrochoid(2 * math.pi * i / M, R, r, d) for i in range(M + 1)]
    cum = [0.0]
    for a, b in zip(pts, pts[1:]):
        cum.append(cum[-1] + math.hypot(b[0] - a[0], b[1] - a[1]))
    L1 = cum[-1]

    def curvature_radius(t):
        h = 1e-5
        (x0, y0), (x1, y1), (x2, y2) = (epitrochoid(t - h, R, r, d),
                                        epitrochoid(t, R, r, d),
                                        epitrochoid(t + h, R, r, d))
        dx, dy = (x2 - x0) / (2 * h), (y2 - y0) / (2 * h)
        ddx, ddy = (x2 - 2 * x1 + x0) / h ** 2, (y2 - 2 * y1 + y0) / h ** 2
        k = abs(dx * ddy - dy * ddx) / (dx * dx + dy * dy) ** 1.5
        return 1.0 / max(k, 1e-12)

    def t_at(s):  # arc length (unit curve) -> parameter
        lo, hi = 0, M
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if cum[mid] <= s:
                lo = mid
            else:
                hi = mid
        frac = (s - cum[lo]) / max(cum[hi] - cum[lo], 1e-300)
        return 2 * math.pi * (lo + frac) / M

    def walk(scale, rng):
        """Arc-length positions (unit curve) of the vertices for a curve
        scaled by `scale`."""
        L = L1 * scale
        s, out = 0.0, [0.0]
        while s < L:
            u = (len(out) - 1) / n_seg
            # slowly varying CAM-like pattern over the segment index, in log
            # space, 0.01 .. 0.5 mm (mean about 0.2 mm before the chordal cap)
            w = 0.5 + 0.5 * math.sin(2 * math.pi * 13 * u + 1.3 * math.sin(2 * math.pi * 3 * u))
            pat = math.exp(math.log(0.01) + (math.log(0.5) - math.log(0.01)) * w ** 0.7)
            rc = curvature_radius(t_at(s / scale)) * scale
            chord = math.sqrt(8 * rc * 0.005)      # 5 um chordal error
            step = min(pat, chord) * (1 + 0.25 * (rng.random() - 0.5))
            step = min(max(step, 0.0125), 0.4975)  # noise keeps lines in 0.01..0.5
            s += step
            out.append(s)
        return out, L

    lo, hi = 0.2, 20.0
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        ss, L = walk(mid, random.Random(seed))
        if len(ss) - 1 > n_seg:
            hi = mid
        else:
            lo = mid
    # take the scale with exactly n_seg (or n_seg+1) segments, close the loop
    scale = lo
    ss, L = walk(scale, random.Random(seed))
    ss = ss[:n_seg]  # vertices 0..n_seg-1; the last line returns to vertex 0
    rng = random.Random(seed + 1)
    verts = []
    for s in ss:
        t = t_at(s / scale)
        x, y = epitrochoid(t, R, r, d)
        h = 1e-6
        xa, ya = epitrochoid(t + h, R, r, d)
        tx, ty = xa - x, ya - y
        tn = math.hypot(tx, ty)
        nx, ny = -ty / tn, tx / tn
        e = noise * (2 * rng.random() - 1)
        verts.append((rnd(cx + scale * x + e * nx), rnd(cy + scale * y + e * ny)))
    verts.append(verts[0])
    pr = Prog()
    pr.comment(f"issue 9 dense contour: {n_seg} lines of 0.01-0.5 mm on a closed epitrochoid "
               f"(R{R} r{r} d{d}, scale {scale:.5f}, length {L:.1f} mm), noise {noise} mm, seed {seed}")
    pr.comment("generated by bench/motion/gen.py dense")
    pr.rapid(z=5)
    pr.rapid(*verts[0])
    pr.line(z=-1, f=600)
    pr.comment("contour at F3000")
    first = True
    for x, y in verts[1:]:
        pr.line(x, y, f=3000 if first else None)
        first = False
    pr.rapid(z=5)
    pr.rapid(0, 0)
    return pr


def emit(pr, dialect, mode):
    def comment(text):
        if dialect == "linuxcnc":  # no nested parentheses in LinuxCNC comments
            return "(" + text.replace("(", "[").replace(")", "]") + ")"
        return '" ' + text

    lines = []
    # comments before the first code line stay on top; the header follows
    i = 0
    while i < len(pr.lines) and pr.lines[i][0] == "c":
        lines.append(comment(pr.lines[i][1]))
        i += 1
    lines.append("G17 G90 G94")
    if mode:
        lines.append(mode)
    for kind, text in pr.lines[i:]:
        lines.append(comment(text) if kind == "c" else text)
    lines.append("M02")
    return "\n".join(lines) + "\n"


def stats(pr):
    """Junction angles of consecutive G01 lines (XY), for information."""
    import re
    pts = []
    p = [0.0, 0.0, 0.0]
    angs = []
    prev = None
    for kind, text in pr.lines:
        if kind != "g":
            continue
        w = dict((m[0], float(m[1:])) for m in re.findall(r"[A-Z][-0-9.]+", text))
        q = [w.get("X", p[0]), w.get("Y", p[1]), w.get("Z", p[2])]
        if text.startswith("G01"):
            d = [q[k] - p[k] for k in range(3)]
            n = math.sqrt(sum(v * v for v in d))
            if prev is not None and n > 0:
                c = sum(a * b for a, b in zip(prev, d)) / n
                angs.append(math.degrees(math.acos(max(-1.0, min(1.0, c)))))
            prev = [v / n for v in d] if n > 0 else prev
            pts.append(n)
        else:
            prev = None
        p = q
    return pts, angs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("program", choices=("part", "dense", "cam", "helix_pairs"))
    ap.add_argument("--dialect", choices=("linuxcnc", "cnc836"), required=True)
    ap.add_argument("--mode", default="", help='one line after the header, e.g. "G64 P0.01"')
    ap.add_argument("-o", "--out", default="-")
    ap.add_argument("--segments", type=int, default=10000)
    ap.add_argument("--noise", type=float, default=0.001)
    ap.add_argument("--seed", type=int, default=9)
    ap.add_argument("--stats", action="store_true", help="print line lengths and junction angles to stderr")
    ap.add_argument("--ellipse-biarcs", type=int, default=0, metavar="N",
                    help="cam: the ellipse as N tangent biarcs instead of 1600 rounded lines")
    a = ap.parse_args()
    if a.ellipse_biarcs < 0 or a.ellipse_biarcs == 1:
        ap.error("--ellipse-biarcs: 0 (the polyline) or 2 or more biarcs (one would start and end at one point)")
    pr = {"part": part, "cam": lambda: cam(a.ellipse_biarcs), "helix_pairs": helix_pairs}.get(
        a.program, lambda: dense(a.segments, a.noise, a.seed))()
    text = emit(pr, a.dialect, a.mode)
    if a.out == "-":
        sys.stdout.write(text)
    else:
        with open(a.out, "w") as f:
            f.write(text)
    if a.stats:
        lens, angs = stats(pr)
        nb = sum(1 for _, t in pr.lines if _ == "g")
        angs.sort()
        q = lambda p: angs[min(len(angs) - 1, int(p * len(angs)))] if angs else 0
        print(f"{a.program}: {nb} motion blocks; G01 lengths {min(lens):.4f}..{max(lens):.4f} mm; "
              f"line-line junctions {len(angs)}: angle p50 {q(0.5):.2f} p90 {q(0.9):.2f} max {angs[-1]:.2f} deg, "
              f"{sum(1 for v in angs if v >= 2.0)} at 2 deg or more", file=sys.stderr)


if __name__ == "__main__":
    main()
