#!/usr/bin/env bash
# Fast arcs at P 0.001 under the path planner (issue 17): a line, a half
# circle of radius R and a line at F15000 (250 mm/s) with `G64 P0.001` on
# the bundled mill (250 mm/s, 2000 mm/s²) with every axis's jerk limit J,
# planned by the path planner; prints, per run, the cycle time and each
# axis's largest sampled jerk (third difference of the setpoints) against
# the limit.
#
#   bash bench/motion/arc_jerk.sh [--jerks "20 50 67.6 100 200"] [--radii "5.3 10.3 20.6 40"] [--out DIR]
#
# Environment: CNC (default: cargo build --release, target/release/cnc).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
JERKS="20 50 67.6 100 200" RADII="5.3 10.3 20.6 40" OUT="$ROOT/bench/out/arc_jerk"
while [ $# -gt 0 ]; do
    case "$1" in
        --jerks) JERKS="${2:?}"; shift ;;
        --radii) RADII="${2:?}"; shift ;;
        --out) OUT="${2:?}"; shift ;;
        *) sed -n '2,12p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2 ;;
    esac
    shift
done
if [ -z "${CNC:-}" ]; then
    (cd "$ROOT" && cargo build --release -q -p cnc_node --bin cnc)
    CNC="$ROOT/target/release/cnc"
fi
mkdir -p "$OUT"
printf '| jerk limit m/s³ | R mm | cycle time s | largest sampled jerk X / Y m/s³ | over the limit |\n|---:|---:|---:|---|---|\n'
for J in $JERKS; do
    JM=$(python3 -c "print($J * 1000.0)")
    sed -e "s/^max_jerk_mm_s3 = .*/max_jerk_mm_s3 = $JM/" \
        -e "s/^lookahead_blocks = \(.*\)/lookahead_blocks = \1\nmethod = \"path\"/" \
        "$ROOT/config/mill.toml" > "$OUT/mill_j$J.toml"
    for R in $RADII; do
        X=$(python3 -c "print(round(30 + 2 * $R, 4))")
        X2=$(python3 -c "print(round($X + 20, 4))")
        P="$OUT/arc_r$R.nc"
        printf 'N10 G17 G90 G00 X10 Y30 Z0\nN20 G64 P0.001\nN30 G01 X30 Y30 F15000\nN40 G02 X%s Y30 I%s J0\nN50 G01 X%s\nN60 M30\n' "$X" "$R" "$X2" > "$P"
        T=$("$CNC" simulate --machine "$OUT/mill_j$J.toml" "$P" --csv "$OUT/arc_j${J}_r$R.csv" | grep -o 'cycle time [0-9.]*s' | grep -o '[0-9.]*')
        python3 - "$OUT/arc_j${J}_r$R.csv" "$J" "$R" "$T" <<'PY'
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))[1:]
lim, dt = float(sys.argv[2]), 0.001
top = []
for c in (1, 2):
    p = [float(r[c]) for r in rows]
    j = [(p[i + 3] - 3 * p[i + 2] + 3 * p[i + 1] - p[i]) / dt**3 / 1000 for i in range(len(p) - 3)]
    top.append(max(abs(x) for x in j))
over = "yes" if max(top) > lim * (1 + 1e-9) else "no"
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {top[0]:.2f} / {top[1]:.2f} | {over} |")
PY
    done
done
