#!/usr/bin/env bash
# Benchmark `cnc simulate` on a program with about ten minutes of motion:
# wall time and peak RSS, without and with the per-sample CSV.
#   bash bench/simulate_10min.sh
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export LC_ALL=C
OUT=bench/out
mkdir -p "$OUT"
[ -x /usr/bin/time ] || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq time >/dev/null; }
cargo build --release --locked -p cnc_node --bin cnc >&2
PROG=$OUT/sim_10min.ngc
python3 bench/gen_program.py --blocks 3000 --minutes 9 --out "$PROG" 2>/dev/null
target/release/cnc check "$PROG" --machine mill
best() { sort -n | head -1; }
t_plain=$(for i in 1 2 3; do /usr/bin/time -f '%e %M' target/release/cnc simulate "$PROG" 2>&1 >/dev/null | tail -1; done | sort -n | head -1)
t_csv=$(for i in 1 2 3; do /usr/bin/time -f '%e %M' target/release/cnc simulate "$PROG" --csv "$OUT/sim_10min.csv" 2>&1 >/dev/null | tail -1; done | sort -n | head -1)
target/release/cnc simulate "$PROG"
echo
echo "| run | best wall s (3 runs) | peak RSS MiB |"
echo "|---|---:|---:|"
echo "$t_plain" | awk '{printf "| cnc simulate | %.2f | %.1f |\n", $1, $2/1024}'
echo "$t_csv" | awk '{printf "| cnc simulate --csv | %.2f | %.1f |\n", $1, $2/1024}'
echo "csv: $(wc -l < "$OUT/sim_10min.csv") rows, $(du -h "$OUT/sim_10min.csv" | cut -f1)"
