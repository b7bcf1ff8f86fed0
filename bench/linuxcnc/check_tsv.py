#!/usr/bin/python3
"""Sanity checks for a TSV written by run.sh.

usage: check_tsv.py OUT.tsv [--end X,Y,Z] [--pitch K --sync-line N] [--tol-mm 1e-3]

  * t_s advances by exactly 1 ms per row (no gaps), prints rows and duration
  * --end: the last row's x,y,z equals the program end position (mm)
  * --pitch/--sync-line: over the rows of program line N (e.g. the G33 block,
    motion.program-line) excluding the first and last 10 % (sync ramp in/out),
    |dz| / d(spindle revs) must equal K within 1 %.  Steps across the spindle
    index reset (revs jumping back) are skipped.
Exit status 1 if a check fails.
"""
import sys


def main(argv):
    path = argv[0]
    opt = {argv[i]: argv[i + 1] for i in range(1, len(argv) - 1, 2)}
    tol = float(opt.get("--tol-mm", "1e-3"))
    with open(path) as f:
        head = f.readline().split()
        rows = [list(map(float, ln.split())) for ln in f if ln.strip()]
    col = {n: i for i, n in enumerate(head)}
    ok = True
    t = [r[col["t_s"]] for r in rows]
    bad = [i for i in range(1, len(t)) if abs(t[i] - t[i - 1] - 0.001) > 1e-6]
    print(f"{path}: {len(rows)} rows, {t[-1] - t[0]:.3f} s "
          f"(rows-1 = {len(rows) - 1} ms); gaps: {len(bad)}")
    ok &= not bad
    last = rows[-1]
    end = (last[col["x_mm"]], last[col["y_mm"]], last[col["z_mm"]])
    print(f"  end position x y z = {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
    if "--end" in opt:
        want = [float(v) for v in opt["--end"].split(",")]
        err = max(abs(a - b) for a, b in zip(end, want))
        good = err <= tol
        print(f"  end vs expected {want}: max error {err:.2e} mm "
              f"-> {'OK' if good else 'FAIL'}")
        ok &= good
    if "--pitch" in opt:
        k = float(opt["--pitch"])
        line = int(opt["--sync-line"])
        seg = [r for r in rows if int(r[col["line"]]) == line]
        if len(seg) < 20:
            print(f"  line {line}: only {len(seg)} rows -> FAIL")
            return 1
        cut = len(seg) // 10
        core = seg[cut:len(seg) - cut]
        dz = drev = 0.0
        for a, b in zip(core, core[1:]):
            r = b[col["spindle_revs"]] - a[col["spindle_revs"]]
            if r < 0:          # index reset
                continue
            drev += r
            dz += abs(b[col["z_mm"]] - a[col["z_mm"]])
        ratio = dz / drev if drev else float("nan")
        rpm = sum(r[col["spindle_rpm"]] for r in core) / len(core)
        z0, z1 = seg[0][col["z_mm"]], seg[-1][col["z_mm"]]
        good = abs(ratio - k) <= 0.01 * k
        print(f"  line {line}: {len(seg)} rows ({len(seg) / 1000:.3f} s), "
              f"z {z0:.4f} -> {z1:.4f}, mean spindle {rpm:.1f} rpm; "
              f"middle 80 %: dz/drev = {ratio:.6f} mm/rev vs K={k} "
              f"({(ratio / k - 1) * 100:+.4f} %) -> {'OK' if good else 'FAIL'}")
        ok &= good
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
