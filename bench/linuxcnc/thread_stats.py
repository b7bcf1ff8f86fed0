#!/usr/bin/python3
"""Thread-start statistics of LinuxCNC G33 runs (TSVs written by run.sh).

usage: thread_stats.py MANIFEST          print the markdown table
       thread_stats.py --explain         print the definitions below

MANIFEST is tab-separated, one run a line ('#' lines are comments):

  group label program tsv rpm lead pitch spec_start acc_limit mode

  group       runs of one example; the groove phase difference is taken
              against the group's first (lowest-rpm) run
  label       text of the table's first column
  program     the .ngc that was run (its first G33 line is the thread block;
              motion.program-line in the TSV is that file line number)
  tsv         run.sh output
  rpm         the commanded spindle speed
  lead        lead axis: x, y or z (x is the radius on the lathe)
  pitch       the thread's lead along the lead axis, mm/rev (G33's F)
  spec_start  the lead-axis coordinate where the example's thread starts (for
              the groove phase; differs from the G33 start point when a start
              angle is emulated by an earlier start)
  acc_limit   the lead axis's configured acceleration limit, mm/s^2
  mode        full, or pitch (only the measured lead per revolution)

Definitions (all from the 1 ms rows; only python3 stdlib):

* index row: the last row before the G33 block's first row in which
  spindle_revs falls back (the index pulse resets it to the fraction of a
  revolution past the index). p0 is the lead axis there (at rest), d the
  direction of travel, s = d * (p - p0) the distance travelled.
* lag = pitch * revs - s: how far the axis is behind the ideal thread line
  p0 + d * pitch * revs. revs is the row's own spindle_revs (LinuxCNC's
  motion used the previous row's value for that row's position, so one
  servo cycle of spindle travel, pitch*rpm/60*1 ms, is part of the lag; that
  is what the cut sees in this simulation).
* start shift: the mean lag over the middle half of the G33 block's rows
  (steady state), in mm and in degrees of spindle angle (360 * shift/pitch).
* lead error e = lag - shift, in encoder counts of pitch/4096 mm.
* run-in: from the index row to the first row with |e| < 1 count (LinuxCNC
  accelerates the axis at its limit until its speed reaches the spindle's,
  then freezes the lag it has at that moment as the sync offset, so this
  row is where synchronization starts); reported in ms and in mm of travel.
* synchronized part: from the end of the run-in up to the row where the
  remaining lead-axis distance to the block's end falls below
  v^2/acc_limit + v * 10 ms (v = pitch * rpm / 60), which leaves out the
  deceleration at the end (LinuxCNC stops the axis at the block end
  without regard to the spindle). "lead err" is max |e| there, in counts.
* groove phase = 360 * d * (p - spec_start) / pitch - 360 * revs, mod 360,
  circular mean over the synchronized part. Its ideal value is minus the
  start angle (0 for a thread starting at the index, 180 for I180); the
  start shift lowers it by the lag in degrees. "dphase" is the phase minus
  the phase of the group's first run, in (-180, 180].
* v^2/2a: the lag of an axis that starts at rest at the index and
  accelerates at acc_limit to v. "delay" = (shift - v^2/2a) / v in ms:
  the rest of the shift expressed as a time delay.
* acceleration: second difference of the lead axis / (1 ms)^2. "max acc"
  over the G33 block (index row to the block's last row + 2), "sync acc"
  the median and maximum of |acc| in the synchronized part.
* lead/rev: (s at the end of the middle half - s at its start) / (revs
  difference): the lead LinuxCNC actually cut along the lead axis.
"""
import math
import re
import sys

COUNTS = 4096
COLS = {"x": "x_mm", "y": "y_mm", "z": "z_mm"}


def g33_line(program):
    """1-based line number of the first G33 block (comments stripped)."""
    for n, line in enumerate(open(program), 1):
        code = re.sub(r"\([^)]*\)|;.*$", "", line).upper().replace(" ", "")
        if re.search(r"G0*33(?![.\d])", code):
            return n
    raise SystemExit(f"{program}: no G33 block")


def load(path):
    with open(path) as f:
        head = f.readline().split()
        rows = [list(map(float, ln.split())) for ln in f if ln.strip()]
    col = {n: i for i, n in enumerate(head)}
    return col, rows


def circ_mean_deg(values):
    sx = sum(math.cos(math.radians(v)) for v in values)
    sy = sum(math.sin(math.radians(v)) for v in values)
    return math.degrees(math.atan2(sy, sx)) % 360.0


def wrap180(a):
    a = (a + 180.0) % 360.0 - 180.0
    return 180.0 if a == -180.0 else a


def analyse(run):
    col, rows = load(run["tsv"])
    line = g33_line(run["program"])
    pc, rc = col[COLS[run["lead"]]], col["spindle_revs"]
    K = run["pitch"]
    cnt = K / COUNTS
    blk = [i for i, r in enumerate(rows) if int(r[col["line"]]) == line]
    if len(blk) < 50:
        raise SystemExit(f"{run['tsv']}: G33 block (line {line}) has {len(blk)} rows")
    a, b = blk[0], blk[-1]
    resets = [i for i in range(1, a + 1) if rows[i][rc] < rows[i - 1][rc] - 0.5]
    if not resets:
        raise SystemExit(f"{run['tsv']}: no index reset of spindle_revs before line {line}")
    ix = resets[-1]
    p0 = rows[ix][pc]
    end = rows[b + 2 if b + 2 < len(rows) else b][pc]
    d = 1.0 if end > p0 else -1.0
    n = len(rows)
    s = [d * (rows[i][pc] - p0) for i in range(n)]
    revs = [rows[i][rc] for i in range(n)]
    lag = [K * revs[i] - s[i] for i in range(n)]
    q0, q1 = a + (b - a) // 4, b - (b - a) // 4
    rpm = sum(rows[i][col["spindle_rpm"]] for i in range(q0, q1)) / (q1 - q0)
    res = {"line": line, "rpm_meas": rpm, "rpm_at_index": rows[ix][col["spindle_rpm"]],
           "lead_rev": (s[q1] - s[q0]) / (revs[q1] - revs[q0])}
    if run["mode"] == "pitch":
        return res
    shift = sum(lag[q0:q1]) / (q1 - q0)
    e = [(lag[i] - shift) / cnt for i in range(n)]
    run_end = next(i for i in range(ix, b) if abs(e[i]) < 1.0)
    v = K * run["rpm"] / 60.0
    A = run["acc_limit"]
    total = s[b + 2 if b + 2 < n else b]
    margin = v * v / A + v * 0.010
    sync_end = max(i for i in range(run_end, b + 1) if total - s[i] >= margin)
    sync = range(run_end, sync_end + 1)
    acc = [0.0] * n
    for i in range(1, n - 1):
        acc[i] = (rows[i + 1][pc] - 2 * rows[i][pc] + rows[i - 1][pc]) / 1e-6
    blk_acc = [abs(acc[i]) for i in range(ix, min(b + 3, n - 1))]
    sync_acc = sorted(abs(acc[i]) for i in sync)
    ph = [(360.0 * d * (rows[i][pc] - run["spec_start"]) / K - 360.0 * revs[i]) % 360.0
          for i in sync]
    v2a = v * v / (2 * A)
    res.update({
        "shift_mm": shift, "shift_deg": 360.0 * shift / K,
        "runin_ms": (run_end - ix) * 1.0, "runin_mm": s[run_end],
        "lead_err": max(abs(e[i]) for i in sync),
        "phase": circ_mean_deg(ph),
        "v2a": v2a, "delay_ms": (shift - v2a) / v * 1000.0,
        "max_acc": max(blk_acc), "sync_acc_p50": sync_acc[len(sync_acc) // 2],
        "sync_acc_max": sync_acc[-1], "sync_rows": len(sync),
        "start_lag0": lag[ix],
    })
    return res


def read_manifest(path):
    runs = []
    for ln in open(path):
        if not ln.strip() or ln.startswith("#"):
            continue
        f = ln.rstrip("\n").split("\t")
        if len(f) != 10:
            raise SystemExit(f"{path}: need 10 tab-separated fields: {ln!r}")
        runs.append({"group": f[0], "label": f[1], "program": f[2], "tsv": f[3],
                     "rpm": float(f[4]), "lead": f[5], "pitch": float(f[6]),
                     "spec_start": float(f[7]), "acc_limit": float(f[8]), "mode": f[9]})
    return runs


def main(argv):
    if argv[:1] == ["--explain"]:
        print(__doc__)
        return 0
    if len(argv) != 1:
        print(__doc__.split("Definitions")[0], file=sys.stderr)
        return 2
    runs = read_manifest(argv[0])
    first_phase = {}
    print("| example | rpm | lead/rev mm | start shift mm | shift ° | v²/2a mm | delay ms "
          "| run-in ms | run-in mm | groove phase ° | dphase ° | sync lead err counts "
          "| max acc mm/s² (limit) | sync \\|acc\\| p50 / max |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    notes = []
    for run in runs:
        r = analyse(run)
        if abs(r["rpm_at_index"] - run["rpm"]) > 1.0:
            notes.append(f"{run['label']} {run['rpm']:.0f} rpm: spindle at "
                         f"{r['rpm_at_index']:.1f} rpm at the index")
        if run["mode"] == "pitch":
            print(f"| {run['label']} | {run['rpm']:.0f} | {r['lead_rev']:.5f} |"
                  + " — |" * 11)
            continue
        g = run["group"]
        if g not in first_phase:
            first_phase[g] = r["phase"]
            dph = "0 (ref)"
        else:
            dph = f"{wrap180(r['phase'] - first_phase[g]):+.1f}"
        print(f"| {run['label']} | {run['rpm']:.0f} | {r['lead_rev']:.5f} "
              f"| {r['shift_mm']:.4f} | {r['shift_deg']:.1f} | {r['v2a']:.4f} "
              f"| {r['delay_ms']:.2f} | {r['runin_ms']:.0f} | {r['runin_mm']:.3f} "
              f"| {r['phase']:.1f} | {dph} | {r['lead_err']:.1f} "
              f"| {r['max_acc']:.0f} ({run['acc_limit']:.0f}) "
              f"| {r['sync_acc_p50']:.0f} / {r['sync_acc_max']:.0f} |")
    for n in notes:
        print(f"\nwarning: {n}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
