#!/usr/bin/python3
"""Convert halsampler -t output (bench sampler, cfg=fffffffs) to a TSV.

usage: sampler2tsv.py RAW OUT.tsv [--period-s 0.001] [--no-trim]

Input columns: sample-num x y z revs rpm rpm_cmd vel line.
Output columns (header line first):
  t_s x_mm y_mm z_mm spindle_revs spindle_rpm spindle_rpm_cmd vel_mm_s line
t_s = (sample index - first kept index) * period.  By default, leading and
trailing rows in which no data column changes are trimmed, keeping one
stationary row at each end, so t_s=0 is the last servo cycle before anything
moved and the last row is the first cycle at which everything had stopped.
Fails on gaps ("overrun" lines or missing sample numbers).
"""
import sys


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    period = 0.001
    if "--period-s" in argv:
        period = float(argv[argv.index("--period-s") + 1])
        args.remove(argv[argv.index("--period-s") + 1])
    trim = "--no-trim" not in argv
    raw, out = args[0], args[1]
    rows = []
    with open(raw) as f:
        for ln in f:
            p = ln.split()
            if not p:
                continue
            if p[0] == "overrun":
                sys.exit(f"{raw}: sampler overrun, data has gaps")
            if len(p) != 9:
                continue  # partial last line when halsampler was stopped
            rows.append((int(p[0]), p[1:]))
    if not rows:
        sys.exit(f"{raw}: no samples")
    for (a, _), (b, _) in zip(rows, rows[1:]):
        if b != a + 1:
            sys.exit(f"{raw}: sample numbers jump {a} -> {b}")
    lo, hi = 0, len(rows) - 1
    if trim:
        key = lambda i: rows[i][1]
        while lo < hi and key(lo + 1) == key(lo):
            lo += 1
        while hi > lo and key(hi - 1) == key(hi):
            hi -= 1
    n0 = rows[lo][0]
    with open(out, "w") as f:
        f.write("t_s\tx_mm\ty_mm\tz_mm\tspindle_revs\tspindle_rpm\t"
                "spindle_rpm_cmd\tvel_mm_s\tline\n")
        for n, v in rows[lo:hi + 1]:
            f.write(f"{(n - n0) * period:.3f}\t" + "\t".join(v) + "\n")
    print(f"{out}: {hi - lo + 1} rows ({len(rows)} sampled, "
          f"{(hi - lo) * period:.3f} s)", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
