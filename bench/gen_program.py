#!/usr/bin/env python3
"""Generate a deterministic G-code benchmark program.

    python3 bench/gen_program.py --blocks N [--seed S] [--feed F | --minutes M]
                                 [--no-n] [--out FILE]

The program has N motion blocks, roughly a third each of G01, G02 and G03,
and is valid both for LinuxCNC's rs274 interpreter and for our `cnc836`
dialect (DIN 66025 core):

    N1 G17 G90 G94 G00 X100 Y100 Z10
    N2 F1000
    N3 G01 X101.2345 Y98.7654 Z10.4321
    N4 G02 X102.0000 Y97.5000 I1.5000 J-0.2500
    N5 G03 X... Y... I... J...
    ...
    N<N+3> M30

Guarantees:
* Arcs lie in G17 with I/J the centre offset from the start point
  (incremental). The end point is the start point rotated about the
  (rounded) centre by an exactly rational rotation, then rounded to 4
  decimals; |r_start - r_end| < 0.001 mm is verified on the ROUNDED
  coordinates that are printed (in practice it is below 0.0001 mm).
* The feed is set (N2 F...) before the first G01/G02/G03.
* The tool stays within ANCHOR +- 45 mm in X/Y (anchor X100 Y100) and
  Z 4..16 mm, arc extremes included: far inside X 0..500, Y 0..500,
  Z -100..100.
* No comments, upper-case words, one block per line, '\\n' line endings.
* Fully deterministic for a given (--blocks, --seed, --feed/--minutes,
  --no-n): all geometry is integer arithmetic in units of 0.0001 mm, no
  libm calls, and Python's Mersenne Twister `random.Random(seed)` is stable
  across versions and platforms.

--minutes M picks the feed so that the feed moves (G01/G02/G03 path length,
ignoring acceleration and the initial G00) last about M minutes.
"""

from __future__ import annotations

import argparse
import math
import random
import sys

UNIT = 10_000  # printed units per mm (4 decimals)

ANCHOR = (100 * UNIT, 100 * UNIT, 10 * UNIT)  # start point, X100 Y100 Z10
SOFT_XY = 20 * UNIT   # beyond this distance from the anchor, steer back
HARD_XY = 45 * UNIT   # nothing (arc extremes included) goes beyond this
Z_MIN, Z_MAX = 4 * UNIT, 16 * UNIT
ENVELOPE = ((0, 500 * UNIT), (0, 500 * UNIT), (-100 * UNIT, 100 * UNIT))

MIN_LINE = 5_000     # G01 XY length 0.5 mm ..
MAX_LINE = 50_000    # .. 5 mm (per-axis delta bound)
MIN_R = 10_000       # arc radius 1 mm ..
MAX_R = 50_000       # .. 5 mm
RADIUS_TOL = 10      # 0.001 mm in units

MACHINE_MAX_FEED = 15_000.0  # mm/min: config/mill.toml max_velocity 250 mm/s


def fmt(u: int) -> str:
    """Integer units of 0.0001 mm as a 4-decimal number, e.g. -1.2500."""
    sign = "-" if u < 0 else ""
    u = abs(u)
    return f"{sign}{u // UNIT}.{u % UNIT:04d}"


def fmt_feed(f: float) -> str:
    s = f"{f:.3f}".rstrip("0").rstrip(".")
    return s or "0"


def div_round(a: int, b: int) -> int:
    """round(a / b) for integers, b > 0, halves away from zero."""
    q, r = divmod(abs(a), b)
    if 2 * r >= b:
        q += 1
    return q if a >= 0 else -q


def steer(rng: random.Random, pos: int, anchor: int, lo: int, hi: int) -> int:
    """A random integer in [lo, hi], with its sign forced towards the anchor
    when pos has drifted more than SOFT_XY away from it."""
    v = rng.randint(lo, hi)
    if pos - anchor > SOFT_XY and v > 0:
        v = -v
    elif anchor - pos > SOFT_XY and v < 0:
        v = -v
    return v


class Gen:
    def __init__(self, seed: int):
        self.rng = random.Random(seed)
        self.x, self.y, self.z = ANCHOR
        self.path_mm = 0.0
        self.counts = {"G01": 0, "G02": 0, "G03": 0}
        self.max_dr = 0.0  # worst |r_start - r_end| in units

    def line(self) -> str:
        rng = self.rng
        ax, ay, _ = ANCHOR
        while True:
            dx = steer(rng, self.x, ax, -MAX_LINE, MAX_LINE)
            dy = steer(rng, self.y, ay, -MAX_LINE, MAX_LINE)
            if dx * dx + dy * dy >= MIN_LINE * MIN_LINE:
                break
        dz = rng.randint(-UNIT, UNIT)  # +-1 mm
        nz = self.z + dz
        if not Z_MIN <= nz <= Z_MAX:
            nz = self.z - dz
        nx, ny = self.x + dx, self.y + dy
        assert abs(nx - ax) <= HARD_XY and abs(ny - ay) <= HARD_XY
        self.path_mm += math.sqrt(dx * dx + dy * dy + (nz - self.z) ** 2) / UNIT
        self.x, self.y, self.z = nx, ny, nz
        self.counts["G01"] += 1
        return f"G01 X{fmt(nx)} Y{fmt(ny)} Z{fmt(nz)}"

    def arc(self, g: str) -> str:
        rng = self.rng
        ax, ay, _ = ANCHOR
        while True:
            # centre offset from the start point (I, J), radius 1..5 mm
            i = steer(rng, self.x, ax, -MAX_R, MAX_R)
            j = steer(rng, self.y, ay, -MAX_R, MAX_R)
            r2 = i * i + j * j
            if not MIN_R * MIN_R <= r2 <= MAX_R * MAX_R:
                continue
            cx, cy = self.x + i, self.y + j
            r_ceil = math.isqrt(r2) + 1
            # whole circle (so every arc extreme) inside the hard box
            if (abs(cx - ax) + r_ceil > HARD_XY) or (abs(cy - ay) + r_ceil > HARD_XY):
                continue
            # exact rational rotation by theta = 2*atan2(n, m):
            # cos = (m^2 - n^2)/d, sin = 2mn/d, d = m^2 + n^2
            m, n = rng.randint(1, 10), rng.randint(1, 10)
            d = m * m + n * n
            c, s = m * m - n * n, 2 * m * n
            if rng.random() < 0.25:  # sweep beyond 180 degrees
                c, s = -c, -s
            # swept angle in the direction of travel, 0..2pi
            sweep = math.atan2(s, c) % (2 * math.pi)
            if g == "G02":  # clockwise: rotate by -theta
                s = -s
            vx, vy = -i, -j  # centre -> start
            ex = cx + div_round(c * vx - s * vy, d)
            ey = cy + div_round(s * vx + c * vy, d)
            if (ex, ey) == (self.x, self.y):
                continue  # would be a full circle
            # verify on the rounded numbers actually printed
            rs = math.sqrt(r2)
            re = math.sqrt((ex - cx) ** 2 + (ey - cy) ** 2)
            dr = abs(rs - re)
            if dr >= RADIUS_TOL:
                continue
            break
        self.max_dr = max(self.max_dr, dr)
        self.path_mm += (rs / UNIT) * sweep
        self.x, self.y = ex, ey
        self.counts[g] += 1
        return f"{g} X{fmt(ex)} Y{fmt(ey)} I{fmt(i)} J{fmt(j)}"

    def block(self) -> str:
        k = self.rng.randrange(3)
        if k == 0:
            return self.line()
        return self.arc("G02" if k == 1 else "G03")


def path_length(blocks: int, seed: int) -> float:
    g = Gen(seed)
    for _ in range(blocks):
        g.block()
    return g.path_mm


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blocks", type=int, required=True, help="number of motion blocks")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    fg = ap.add_mutually_exclusive_group()
    fg.add_argument("--feed", type=float, default=None,
                    help="feed in mm/min (default 1000)")
    fg.add_argument("--minutes", type=float, default=None,
                    help="choose the feed so that the motion lasts about this many minutes")
    ap.add_argument("--no-n", action="store_true", help="omit N block numbers")
    ap.add_argument("--out", default="-", help="output file (default stdout)")
    a = ap.parse_args(argv)
    if a.blocks < 0:
        ap.error("--blocks must be >= 0")

    if a.minutes is not None:
        if a.minutes <= 0:
            ap.error("--minutes must be > 0")
        length = path_length(a.blocks, a.seed)
        feed = round(length / a.minutes, 3) if length > 0 else 1000.0
        feed = max(feed, 0.001)
    else:
        feed = 1000.0 if a.feed is None else a.feed
    if feed <= 0:
        ap.error("--feed must be > 0")

    out = sys.stdout if a.out == "-" else open(a.out, "w", encoding="ascii", newline="\n")
    try:
        nbr = 0

        def emit(text: str) -> None:
            nonlocal nbr
            nbr += 1
            if a.no_n:
                out.write(text + "\n")
            else:
                out.write(f"N{nbr} {text}\n")

        x, y, z = ANCHOR
        emit(f"G17 G90 G94 G00 X{x // UNIT} Y{y // UNIT} Z{z // UNIT}")
        emit(f"F{fmt_feed(feed)}")
        g = Gen(a.seed)
        for _ in range(a.blocks):
            emit(g.block())
        emit("M30")
    finally:
        if out is not sys.stdout:
            out.close()
        else:
            out.flush()

    minutes = g.path_mm / feed
    print(
        f"gen_program: {a.blocks} motion blocks (G01 {g.counts['G01']}, "
        f"G02 {g.counts['G02']}, G03 {g.counts['G03']}), seed {a.seed}, "
        f"F{fmt_feed(feed)} mm/min, feed path {g.path_mm:.1f} mm, "
        f"~{minutes:.2f} min of feed motion, worst |r_start-r_end| "
        f"{g.max_dr / UNIT:.4f} mm",
        file=sys.stderr,
    )
    if feed > MACHINE_MAX_FEED:
        print(
            f"gen_program: warning: F{fmt_feed(feed)} exceeds {MACHINE_MAX_FEED:g} mm/min "
            "(config/mill.toml max_velocity_mm_s 250); use fewer blocks or more minutes",
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
