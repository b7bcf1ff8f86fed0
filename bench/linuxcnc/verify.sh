#!/usr/bin/env bash
# End-to-end check of the LinuxCNC bench sim: runs the mill test program and
# the lathe G33 program at S200 and S800, checks the TSVs (1 ms rows without
# gaps, end position, G33 dz/drev = K within 1 %).  TSVs go to $OUT
# (default ${TMPDIR:-/tmp}/linuxcnc-bench-out).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${OUT:-${TMPDIR:-/tmp}/linuxcnc-bench-out}"
mkdir -p "$OUT"
P="$HERE/programs"
"$HERE/run.sh" "$P/mill_square_arcs.ngc" "$OUT/mill_square_arcs.tsv"
"$HERE/check_tsv.py" "$OUT/mill_square_arcs.tsv" --end 0,0,5
for rpm in 200 800; do
    "$HERE/run.sh" "$P/lathe_g33.ngc" "$OUT/lathe_g33_s$rpm.tsv" --lathe --rpm "$rpm"
    "$HERE/check_tsv.py" "$OUT/lathe_g33_s$rpm.tsv" --end 25,0,5 --pitch 1 --sync-line 7
done
echo "verify.sh: all checks passed"
