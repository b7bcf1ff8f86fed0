"""The jerk of G33 threads (issue 17): `examples/lathe_thread.nc` (two
passes of M20 x 1.5 at S800, the second with a 3 mm runout at 30 deg on X)
run offline (`cnc simulate --csv`) on copies of the bundled lathe with the
jerk limit set on both axes, for each `cnc` binary given.

Two encoders: the bundled one (4096 counts/rev), whose counts the
controller's spindle tracker fits, and one of 2^30 counts/rev, fine enough
that the tracker's prediction follows the simulated spindle's true angle:
there the setpoints show the motion the controller plans (run-in,
deceleration, runout), not the encoder's quantization.

Per run: the cycle time, and per axis the largest |a| and |j| of the
setpoints (finite differences at the 1 ms sample period), the 99.9th
percentile of |j|, and the samples whose |j| is over the limit.

    python3 bench/motion/thread_jerk.py --cnc before=/tmp/cnc_before \
        --cnc after=target/release/cnc [--jerks 20,50,200] [--ripple 0,0.02] [--out DIR]
"""

import argparse
import csv
import pathlib
import re
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
FINE = 1 << 30


def machine(out, jerk_m_s3, counts, ripple=0.0):
    text = (ROOT / "config" / "lathe.toml").read_text()
    text, n = re.subn(
        r"(?m)^sim_ripple_fraction = .*$", f"sim_ripple_fraction = {ripple}", text
    )
    assert n == 1
    text, n = re.subn(
        r"(?m)^max_jerk_mm_s3 = .*$", f"max_jerk_mm_s3 = {jerk_m_s3 * 1000.0}", text
    )
    assert n == 2, "the lathe has two axes with a jerk limit"
    text, n = re.subn(
        r"(?m)^encoder_counts_per_rev = .*$", f"encoder_counts_per_rev = {counts}", text
    )
    assert n == 1
    # (the look-ahead and its filters at every jerk, as these figures were
    # taken before the default became "auto")
    text, n = re.subn(
        r"(?m)^(lookahead_blocks = .*)$", r'\1\nmethod = "filters"', text
    )
    assert n == 1
    path = out / f"lathe_j{jerk_m_s3:g}_c{counts}_r{ripple:g}.toml"
    path.write_text(text)
    return path


def run(cnc, mfile, csv_path):
    r = subprocess.run(
        [cnc, "simulate", str(ROOT / "examples" / "lathe_thread.nc"),
         "--machine", str(mfile), "--csv", str(csv_path)],
        capture_output=True, text=True, check=True,
    )
    rows = list(csv.reader(open(csv_path)))
    head, data = rows[0], [[float(x) for x in r] for r in rows[1:]]
    return r.stdout.strip(), head, data


def series_stats(x, limit_mm_s3, dt=0.001, keep=None):
    """Of positions `x` (mm) at period `dt`: the largest |a| (mm/s²), the
    largest |j| and its 99.9th percentile (m/s³) and the samples whose |j|
    is over `limit_mm_s3`, from finite differences; `keep(k)` picks the
    differences ending at sample k that count (all by default)."""
    ks = [k for k in range(len(x)) if keep is None or keep(k)]
    a = [abs(x[k] - 2 * x[k - 1] + x[k - 2]) / dt**2 for k in ks if k >= 2]
    j = sorted(abs(x[k] - 3 * x[k - 1] + 3 * x[k - 2] - x[k - 3]) / dt**3 for k in ks if k >= 3)
    if not j:
        return None
    over = sum(1 for q in j if q > limit_mm_s3 * (1 + 1e-6) + 1e-3)
    return max(a), j[-1] / 1000.0, j[int(0.999 * len(j))] / 1000.0, over


def stats(head, data, limit_mm_s3, dt=0.001):
    out = {}
    for c, name in enumerate(head):
        if name.endswith("_set"):
            out[name[0].upper()] = series_stats([r[c] for r in data], limit_mm_s3, dt)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cnc", action="append", required=True,
                    help="NAME=PATH of a cnc binary (repeat)")
    ap.add_argument("--jerks", default="20,50,200", help="m/s³, comma-separated")
    ap.add_argument("--ripple", default="0",
                    help="the simulated spindle's speed ripple at 5 Hz, fractions, comma-separated")
    ap.add_argument("--out", help="directory for the machine files and CSVs")
    args = ap.parse_args()
    out = pathlib.Path(args.out or tempfile.mkdtemp(prefix="thread_jerk_"))
    out.mkdir(parents=True, exist_ok=True)
    bins = [c.split("=", 1) for c in args.cnc]
    print("| encoder counts/rev | ripple | jerk m/s³ | build | cycle time s "
          "| X max \\|a\\| mm/s² | X max \\|j\\| (p99.9) m/s³ | X samples over "
          "| Z max \\|a\\| mm/s² | Z max \\|j\\| (p99.9) m/s³ | Z samples over |")
    print("|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for counts in (4096, FINE):
      for ripple in (float(r) for r in args.ripple.split(",")):
        for jerk in (float(j) for j in args.jerks.split(",")):
            mfile = machine(out, jerk, counts, ripple)
            for name, cnc in bins:
                csv_out = out / f"{name}_j{jerk:g}_c{counts}_r{ripple:g}.csv"
                line, head, data = run(cnc, mfile, csv_out)
                t = re.search(r"cycle time ([0-9.]+)s", line).group(1)
                s = stats(head, data, jerk * 1000.0)
                cells = []
                for ax in ("X", "Z"):
                    a, jm, jp, over = s[ax]
                    cells += [f"{a:.0f}", f"{jm:.1f} ({jp:.1f})", f"{over}"]
                c = "2^30" if counts == FINE else str(counts)
                print(f"| {c} | {ripple:g} | {jerk:g} | {name} | {t} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
