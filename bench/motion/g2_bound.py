#!/usr/bin/env python3
"""Issue 17: what a planner without setpoint filters could reach on a program.

A prototype of a design, not the controller. It writes a trajectory of
1 kHz samples that keeps every axis's velocity, acceleration and jerk
limit and stays within the path tolerance P, and reports its cycle time,
so that the time is one such a planner can reach (an upper bound on the
best time, not an estimate of it). Two steps, as the design would have
them:

1. Geometry, independent of speed. Each run of feed moves between rests
   (a rapid is a run of its own) is put on a uniform grid of DS mm and
   smoothed twice with a moving average in arc length whose width w(s)
   is as large as the path tolerance allows there (a kink becomes a
   curvature ramp, a step of curvature a smooth one). The width starts
   at W0 and is narrowed wherever the smoothed path is further than
   TARGET * P from the programmed one; it changes by at most SLOPE mm per
   mm and is averaged so that it changes smoothly. On a CAM polyline
   (moves under 1 mm on average) the average's shrink of curves is made
   up (2 B - B B), so that it can be wide enough to even out the
   polyline's vertices. The ends of a run are kept.
2. Speed along the smoothed path, by linear programs in u = v^2 over a
   grid in its arc length sigma (a quarter of the width, at most 50 um;
   then again with a point at least every DT_GRID of the first
   solution's time): per axis T_x^2 u <= V^2, |T u'/2 + K u| <= A on each
   step, and |T u''/2 + 3/2 K u' + K' u| <= J / sqrt(u_ref) at each
   point, with T, K, K' the path's tangent, curvature vector and its
   derivative. The jerk rows are linear in u only for a fixed u_ref;
   each program is solved with u <= (1 + RHO) u_prev and
   u_ref = (1 + RHO) u_prev, so every solution keeps the true jerk rows
   (sqrt(u) <= sqrt(u_ref)); the first u_prev is the speed cap. Starts
   and ends from rest also keep the jerk-only bound
   u <= (J^2/4) (6 s / J)^(4/3). Maximises the integral of u. The rows
   keep 0.98 of J and 0.999 of A.

Known gap: where the width is under about 0.1 mm (sharp corners, the
ends of a run that stops on a curve) the finite-difference geometry on
the DS grid misses what the path does between its points, and a few
samples there go over the jerk limit (BENCHMARKS.md). A planner would
give such places a corner blend of its own.

The samples (t, x_set, y_set, z_set) go to a CSV that analyse.py reads as
it reads ours, so the distance from the path and the limits are checked
by the same code as for LinuxCNC and ours; this script also prints the
jerk (third differences) and the time of each section at cutting depth as
profile_plot.py cuts them.

usage: g2_bound.py PROGRAM --jerk J_M_S3 [--tol 0.01] [--vel 100]
                   [--acc 1000] [--csv OUT.csv]

Needs numpy and scipy (linprog, HiGHS). Environment: G2_ONLY=LINE,...
plans only the runs starting at those program lines; G2_DEBUG=1 prints
the smoothing's rounds; G2_W0, G2_SLOPE, G2_TWICE=0 change W0, SLOPE and
turn the polylines' shrink correction off. G2_SPEED=BINARY replaces the
linear programs by the controller's speed stage (cnc_core::path_speed,
`cargo build --release -p cnc_core --example path_plan`, then
G2_SPEED=target/release/examples/path_plan): the same geometry, every
1 ms sample's path position from the Rust planner. G2_PLAN=BINARY
(the same binary) hands each run's programmed polyline to the Rust
geometry and speed stages (cnc_core::path_smooth, path_speed) instead,
streamed as a look-ahead would (PATH_PLAN_CHUNK=C,M: the geometry C mm
at a time with M mm either side; without it, each run whole): this script then only parses, samples the program and judges.
"""
import argparse
import math
import os
import subprocess
import sys
import time

import numpy as np
from scipy import sparse
from scipy.ndimage import minimum_filter1d, uniform_filter1d
from scipy.optimize import linprog

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import analyse  # noqa: E402
from profile_plot import SECTIONS  # noqa: E402

DS = 0.004  # fine grid of the geometry, mm
W0 = float(os.environ.get("G2_W0", "3"))  # widest smoothing, mm
TARGET = 0.95  # share of P the smoothed path may use
DONE = 0.98  # the smoothing is done once no point is further off than this share of P
SLOPE = float(os.environ.get("G2_SLOPE", "0.5"))  # how fast the smoothing width may change, mm per mm
RHO = 0.3  # trust region of each linear program
TWICE = os.environ.get("G2_TWICE", "1") == "1"  # polylines: the smoothing's shrink of arcs made up
DT_GRID = 0.0003  # s, longest step of the speed grid at the first speeds
NO_FEED = 1e9  # mm/s, a rapid's feed: the axes' speed limits only
H_RUST = 0.004  # mm, station spacing handed to the Rust speed stage (the geometry grid: narrow blends resolved)
RUST_TIME = [0.0]  # s the Rust speed stage took, all runs
RUST_SMOOTH = [0.0]  # s the Rust geometry stage took, all runs (G2_PLAN)


def runs(segs):
    out, cur = [], []
    for s in segs:
        if s["rapid"]:
            if cur:
                out.append(cur)
                cur = []
            out.append([s])
        else:
            cur.append(s)
    if cur:
        out.append(cur)
    return out


def dense(run):
    """Points every DS mm or less, the feed at each point (mm/s)."""
    pts = [np.array([run[0]["a"]], dtype=float)]
    feeds = []
    for s in run:
        L = analyse.seg_length(s)
        n = max(1, math.ceil(L / DS))
        pts.append(np.array([analyse.seg_point(s, k / n) for k in range(1, n + 1)]))
        f = NO_FEED if s["rapid"] or s["f"] is None else s["f"]
        feeds.append(np.full(n, f))
    p = np.vstack(pts)
    fe = np.concatenate([[feeds[0][0]]] + feeds)
    # a vertex between two moves takes the slower feed
    idx = np.cumsum([len(f) for f in feeds])[:-1]
    for i, f in zip(idx, feeds[1:]):
        fe[i] = min(fe[i], f[0])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    return p, s, fe


def box(p, s, w, x):
    """Moving average of the piecewise linear p (on s) over [x - w/2,
    x + w/2], integrated exactly, the window shrunk symmetrically at the
    ends."""
    h = np.diff(s)
    C = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (p[1:] + p[:-1]) * h[:, None], axis=0)])

    def at(y):
        j = np.clip(np.searchsorted(s, y, side="right") - 1, 0, len(s) - 2)
        tau = y - s[j]
        slope = (p[j + 1] - p[j]) / h[j][:, None]
        return C[j] + p[j] * tau[:, None] + slope * (0.5 * tau * tau)[:, None]

    half = np.minimum(0.5 * w, np.minimum(x - s[0], s[-1] - x))
    out = np.stack([np.interp(x, s, p[:, k]) for k in range(3)], axis=1)
    m = half > 1e-9
    out[m] = (at(x[m] + half[m]) - at(x[m] - half[m])) / (2.0 * half[m])[:, None]
    return out


def nearest(q, p, cand, K):
    """Distance of q[i] (i in cand) to the nearest of p[i-K .. i+K]."""
    d = np.full(len(cand), np.inf)
    n = len(p)
    for k in range(-K, K + 1):
        j = cand + k
        ok = (j >= 0) & (j < n)
        dd = np.linalg.norm(q[cand[ok]] - p[j[ok]], axis=1)
        d[ok] = np.minimum(d[ok], dd)
    return d


def regular(req):
    """A width under the required one everywhere that changes slowly and
    smoothly: at most SLOPE mm per mm, then its least over 0.5 mm on
    either side averaged twice over 0.5 mm (so its second derivative, and
    with it the smoothed path's curvature derivative, is bounded). Always
    made from the requirement, so that narrow places do not spread from
    one round to the next."""
    i = np.arange(len(req)) * (SLOPE * DS)
    w = np.minimum(np.minimum.accumulate(req - i) + i, (np.minimum.accumulate((req + i)[::-1]) - i[::-1])[::-1])
    m = int(0.5 / DS) | 1
    w = minimum_filter1d(w, 2 * m + 1, mode="nearest")
    return uniform_filter1d(uniform_filter1d(w, m, mode="nearest"), m, mode="nearest")


def smooth(p0, s0, tol, twice):
    """The smoothed path on a uniform grid s (every DS mm or less), the
    width there and the largest distance from the path."""
    s = np.linspace(0.0, s0[-1], int(math.ceil(s0[-1] / DS)) + 1)
    p = np.stack([np.interp(s, s0, p0[:, k]) for k in range(3)], axis=1)  # on the path
    n = len(p)
    req = np.full(n, W0)
    w = regular(req)
    for _ in range(300):
        b = box(box(p0, s0, w, s), s, w, s)
        q = 2.0 * b - box(box(b, s, w, s), s, w, s) if twice else b
        off = np.linalg.norm(q - p, axis=1)
        cand = np.nonzero(off > TARGET * tol)[0]
        dev = np.zeros(n)
        if len(cand):
            K = int(math.ceil(w[cand].max() / DS)) + 2
            dev[cand] = nearest(q, p, cand, K)
        bad = dev > TARGET * tol
        if not (dev > DONE * tol).any():
            return q, w, dev.max(), s
        if os.environ.get("G2_DEBUG"):
            iw = int(np.argmax(dev))
            print(f"    {int(bad.sum())} points over, worst {dev.max() * 1000:.2f} um at s {s[iw]:.3f} {np.round(p[iw], 3)} "
                  f"w there {w[iw]:.4f}, w {w.min():.4f}", file=sys.stderr)
        # the requirement: a fifth narrower than now at the points too far off
        req[bad] = np.minimum(req[bad], 0.8 * w[bad])
        w = regular(req)
    raise SystemExit("smoothing did not converge")


def hermite(sig, q, T, x):
    j = np.clip(np.searchsorted(sig, x, side="right") - 1, 0, len(sig) - 2)
    h = sig[j + 1] - sig[j]
    t = ((x - sig[j]) / h)[:, None]
    h = h[:, None]
    h00 = 2 * t**3 - 3 * t**2 + 1
    h10 = t**3 - 2 * t**2 + t
    h01 = -2 * t**3 + 3 * t**2
    h11 = t**3 - t**2
    return h00 * q[j] + h10 * h * T[j] + h01 * q[j + 1] + h11 * h * T[j + 1]


def plan_speed(sig, T, K, Kd, feed, V, A, J):
    """u = v^2 on the grid sig; returns u."""
    n = len(sig)
    S = sig[-1]
    cap = np.minimum(feed, V / np.maximum(np.abs(T).max(axis=1), 1e-12)) ** 2
    env = lambda d: (J * J / 4.0) * (6.0 * np.maximum(d, 0.0) / J) ** (4.0 / 3.0)
    ub = np.minimum(cap, np.minimum(env(sig), env(S - sig)))
    # curvature caps (single-axis bounds, as a first reference)
    with np.errstate(divide="ignore"):
        ub = np.minimum(ub, np.min(A / np.abs(K), axis=1))
        ub = np.minimum(ub, np.min((J / np.abs(Kd)) ** (2.0 / 3.0), axis=1))
    ub[0] = ub[-1] = 0.0
    h1 = sig[1:-1] - sig[:-2]
    h2 = sig[2:] - sig[1:-1]
    hs = h1 + h2
    cm, c0, cp = 2 / (h1 * hs), -2 / (h1 * h2), 2 / (h2 * hs)
    dm, dp = -1 / hs, 1 / hs
    ii = np.arange(1, n - 1)
    ie = np.arange(0, n - 1)  # interval i..i+1, written at its first point
    weight = np.concatenate([[0.0], 0.5 * hs, [0.0]])
    uref = ub.copy()
    best = None
    for it in range(12):
        rows, cols, vals, rhs = [], [], [], []
        r0 = 0
        he = np.diff(sig)
        jb = J / np.sqrt(np.maximum(uref[1:-1], 1e-9))
        for ax in range(3):
            t, k, kd = T[1:-1, ax], K[1:-1, ax], Kd[1:-1, ax]
            # acceleration on each interval [i, i+1] (one-sided: central
            # differences would let u zigzag), jerk at each inner point
            te, ke = 0.5 * (T[:-1, ax] + T[1:, ax]), 0.5 * (K[:-1, ax] + K[1:, ax])
            blocks = [
                ((np.zeros(n - 1), -te / (2 * he) + ke / 2, te / (2 * he) + ke / 2), np.full(n - 1, A), ie),
                ((t * cm / 2 + 1.5 * k * dm, t * c0 / 2 + kd, t * cp / 2 + 1.5 * k * dp), jb, ii),
            ]
            for (am, a0, ap), b, at in blocks:
                use = (np.abs(am) + np.abs(a0) + np.abs(ap)) > 1e-12
                m = int(use.sum())
                for sign in (1.0, -1.0):
                    rid = r0 + np.arange(m)
                    for off, coef in ((-1, am), (0, a0), (1, ap)):
                        if not np.any(coef):
                            continue
                        rows.append(rid)
                        cols.append(at[use] + off)
                        vals.append(sign * coef[use])
                    rhs.append(b[use])
                    r0 += m
        Aub = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(r0, n))
        hi = np.minimum(ub, uref)
        res = linprog(-weight, A_ub=Aub, b_ub=np.concatenate(rhs), bounds=np.stack([np.zeros(n), hi], axis=1),
                      method="highs")
        if res.status != 0:
            raise SystemExit(f"linear program: {res.message}")
        u = np.maximum(res.x, 0.0)
        tt = duration(sig, u, J)
        if best is not None and tt > best[1] * 0.999:
            best = (u, tt) if tt < best[1] else best
            break
        best = (u, tt)
        uref = np.minimum(ub, (1.0 + RHO) * u)
    return best[0]


def run_rust(binary, args, head, body, dump_name, V, A, J):
    """Runs examples/path_plan.rs on one run: the header line, the limits
    line, the records; writes the input to G2_DUMP if set; adds the speed
    stage's time to RUST_TIME; returns the numbers printed and stderr."""
    text = head + "\n" + " ".join(repr(float(x)) for x in [V] * 3 + [A] * 3 + [J] * 3) + "\n" + body
    if os.environ.get("G2_DUMP"):
        with open(os.path.join(os.environ["G2_DUMP"], dump_name), "w") as f:
            f.write(text)
    res = subprocess.run([binary] + args, input=text, capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"{binary}: {res.stderr.strip()}")
    w = res.stderr.split()
    RUST_TIME[0] += float(w[w.index("speed") + 2])
    return np.array([float(x) for x in res.stdout.split()]), w


def rust_speed(binary, sig, T, K, Kd, feed, V, A, J):
    """The path position at every 1 ms sample from cnc_core::path_speed,
    on stations H_RUST apart."""
    S = sig[-1]
    n = int(math.ceil(S / H_RUST)) + 1
    st = np.minimum(np.arange(n) * H_RUST, S)
    at = lambda arr: np.stack([np.interp(st, sig, arr[:, k]) for k in range(3)], axis=1)
    rows = np.hstack([at(T), at(K), at(Kd), np.interp(st, sig, feed)[:, None]])
    body = "\n".join(" ".join(repr(float(x)) for x in r) for r in rows)
    s, _ = run_rust(binary, ["stations"], f"{H_RUST!r} {float(S)!r} 0.001", body, f"run_{S:.3f}.txt", V, A, J)
    return s


def rust_plan(binary, p, feed, tol, mode, V, A, J):
    """Positions at every 1 ms sample of one run planned wholly by
    cnc_core (examples/path_plan.rs): smoothing and speed."""
    body = "\n".join(f"{x!r} {y!r} {z!r} {float(f)!r}" for (x, y, z), f in zip(p.tolist(), feed))
    xyz, w = run_rust(binary, [], f"{tol!r} {mode} 0.001 {H_RUST!r}", body, f"poly_{len(p)}.txt", V, A, J)
    RUST_SMOOTH[0] += float(w[w.index("smoothed") + 2])
    print("  " + " ".join(w), file=sys.stderr, flush=True)
    return xyz.reshape(-1, 3)


def grid_of(S, spacing):
    """Grid points from 0 to S, each step spacing(x) at the point before;
    no sliver at the end."""
    out = [0.0]
    x = 0.0
    while True:
        x = x + float(spacing(np.array([x]))[0])
        if len(out) > 400000:
            raise SystemExit("speed grid over 400000 points: a speed of zero inside the run?")
        if x >= S:
            break
        out.append(x)
    if len(out) > 1 and S - out[-1] < 0.5 * (out[-1] - out[-2]):
        out.pop()
    out.append(S)
    return np.array(out)


def geometry_at(gs, sig, T, K, Kd, feed):
    at = lambda arr: np.stack([np.interp(gs, sig, arr[:, k]) for k in range(3)], axis=1)
    return gs, at(T), at(K), at(Kd), np.interp(gs, sig, feed)


def steps(sig, u, J):
    """Time of each grid step: constant acceleration between its speeds;
    between two stops, rest to rest with the jerk alone."""
    v = np.sqrt(u)
    h = np.diff(sig)
    vs = v[1:] + v[:-1]
    return np.where(vs > 1e-9, 2.0 * h / np.maximum(vs, 1e-9), np.cbrt(32.0 * h / J)), v


def duration(sig, u, J):
    return float(np.sum(steps(sig, u, J)[0]))


def section_time(sig, u, J):
    dt, v = steps(sig, u, J)
    return np.concatenate([[0.0], np.cumsum(dt)]), v


def s_at(tgrid, sig, v, tq):
    """Arc length at times tq: constant acceleration between grid points."""
    j = np.clip(np.searchsorted(tgrid, tq, side="right") - 1, 0, len(tgrid) - 2)
    tau = tq - tgrid[j]
    dt = tgrid[j + 1] - tgrid[j]
    a = (v[j + 1] - v[j]) / dt
    return np.minimum(sig[j] + v[j] * tau + 0.5 * a * tau * tau, sig[j + 1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("program")
    ap.add_argument("--jerk", type=float, required=True, help="m/s^3, every axis")
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--vel", type=float, default=100.0)
    ap.add_argument("--acc", type=float, default=1000.0)
    ap.add_argument("--csv")
    a = ap.parse_args()
    V, A, J = a.vel, a.acc * 0.999, a.jerk * 1000.0 * 0.98
    segs = analyse.parse_program(a.program)
    parts = []
    t0 = time.time()
    only = os.environ.get("G2_ONLY")
    for run in runs(segs):
        if only and str(run[0]["line"]) not in only.split(","):
            continue
        p, s, feed = dense(run)
        if os.environ.get("G2_PLAN"):
            plain = len(run) == 1 and run[0]["kind"] == "line"
            mode = 0 if plain else (2 if TWICE and s[-1] / len(run) < 1.0 else 1)
            xyz = rust_plan(os.environ["G2_PLAN"], p, feed, a.tol, mode, V, A, J)
            tg = np.arange(len(xyz)) * 0.001
            parts.append(dict(xyz=xyz, tg=tg))
            print(f"run from line {run[0]['line']}: {len(run)} moves, {s[-1]:.3f} mm programmed, {tg[-1]:.4f} s (Rust)",
                  file=sys.stderr, flush=True)
            continue
        if len(run) == 1 and run[0]["kind"] == "line":
            q, w, dev = p, np.full(len(p), W0), 0.0
            su = s
        else:
            # a CAM polyline (moves under 1 mm on average): the smoothing's
            # shrink of its curves made up, so that it can be wide enough
            # to even out the polyline's vertices; otherwise plain
            twice = TWICE and s[-1] / len(run) < 1.0
            q, w, dev, su = smooth(p, s, a.tol, twice)
            feed = np.interp(su, s, feed)
            print(f"  smoothed in {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
        sig = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
        T = np.gradient(q, sig, axis=0)
        T /= np.linalg.norm(T, axis=1)[:, None]
        K = np.gradient(T, sig, axis=0)
        Kd = np.gradient(K, sig, axis=0)
        # the speed grid: first spaced by a quarter of the smoothing width
        # (4..50 um), then again where the first speeds take more than
        # DT_GRID a step (starts and stops, slow corners)
        if os.environ.get("G2_SPEED"):
            st = rust_speed(os.environ["G2_SPEED"], sig, T, K, Kd, feed, V, A, J)
            tg = np.arange(len(st)) * 0.001
            parts.append(dict(sig=sig, q=q, T=T, st=st, tg=tg))
            print(f"run from line {run[0]['line']}: {len(run)} moves, {sig[-1]:.3f} mm, {tg[-1]:.4f} s (Rust), "
                  f"smoothed dev {dev * 1000:.2f} um", file=sys.stderr, flush=True)
            continue
        wf = lambda x: np.interp(x, sig, w)
        gs = grid_of(sig[-1], lambda x: np.clip(0.25 * wf(x), DS, 0.05))
        u = plan_speed(*geometry_at(gs, sig, T, K, Kd, feed), V, A, J)
        for _ in range(2):
            vf = lambda x, gs=gs, u=u: np.sqrt(np.interp(x, gs, u))
            gs = grid_of(sig[-1], lambda x: np.clip(np.minimum(0.25 * wf(x), DT_GRID * vf(x)), 1e-6, 0.05))
            u = plan_speed(*geometry_at(gs, sig, T, K, Kd, feed), V, A, J)
        tg, v = section_time(gs, u, J)
        parts.append(dict(sig=sig, q=q, T=T, gs=gs, tg=tg, v=v))
        print(f"run from line {run[0]['line']}: {len(run)} moves, {sig[-1]:.3f} mm, {tg[-1]:.4f} s, "
              f"smoothed dev {dev * 1000:.2f} um, w {w.min():.4f}..{w.max():.2f} mm, grid {len(gs)}",
              file=sys.stderr, flush=True)
    total = sum(pt["tg"][-1] for pt in parts)
    # 1 kHz samples over the whole program
    nsamp = int(math.ceil(total / 0.001)) + 1
    tq = np.arange(nsamp) * 0.001
    out = np.zeros((nsamp, 3))
    start = 0.0
    first = segs[0]["a"]
    out[:] = first
    if parts and ("st" in parts[0] or "xyz" in parts[0]):
        # whole samples per run: each run's positions at its own samples
        rows = [np.array([first])]
        for pt in parts:
            xyz = pt["xyz"] if "xyz" in pt else hermite(pt["sig"], pt["q"], pt["T"], pt["st"])
            rows.append(xyz[1:])
        out = np.concatenate(rows)
        nsamp = len(out)
        tq = np.arange(nsamp) * 0.001
        parts = []
    for pt in parts:
        end = start + pt["tg"][-1]
        m = (tq >= start) & (tq < end)
        sl = s_at(pt["tg"], pt["gs"], pt["v"], tq[m] - start)
        out[m] = hermite(pt["sig"], pt["q"], pt["T"], sl)
        out[tq >= end] = pt["q"][-1]
        start = end
    dt = 0.001
    vel = np.abs(np.diff(out, axis=0)).max(axis=0) / dt
    accm = np.abs(np.diff(out, 2, axis=0)).max(axis=0) / dt**2
    jer = np.abs(np.diff(out, 3, axis=0)).max(axis=0) / dt**3
    print(f"total {total:.3f} s ({time.time() - t0:.0f} s to plan)")
    if os.environ.get("G2_PLAN"):
        print(f"Rust geometry stage: {RUST_SMOOTH[0]:.3f} s")
    if os.environ.get("G2_SPEED") or os.environ.get("G2_PLAN"):
        print(f"Rust speed stage: {RUST_TIME[0]:.3f} s for {total:.3f} s of motion "
              f"({RUST_TIME[0] / total * 1e3:.1f} us per 1 ms sample)")
    print("max |v| mm/s " + " ".join(f"{x:.1f}" for x in vel))
    print("max |a| mm/s^2 " + " ".join(f"{x:.1f}" for x in accm))
    print("max |j| m/s^3 " + " ".join(f"{x / 1000:.1f}" for x in jer))
    for name, (lo, hi) in SECTIONS.items():
        m = (out[:, 2] < -0.99) & (out[:, 0] >= lo) & (out[:, 0] <= hi)
        k = np.nonzero(m)[0]
        if len(k):
            print(f"section {name}: {(k[-1] - k[0]) * dt:.3f} s at depth")
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("t,x_set,y_set,z_set\n")
            for i in range(nsamp):
                f.write(f"{tq[i]:.3f},{out[i, 0]:.9f},{out[i, 1]:.9f},{out[i, 2]:.9f}\n")


if __name__ == "__main__":
    main()
