#!/usr/bin/env bash
# The check of a program with 9999 x 9999 loop iterations (G73, nested):
# it runs the loops (never expands them), so it finishes with the cycle
# time, in the memory of a short program.
#   bash bench/loops_9999x9999.sh
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
mkdir -p bench/out
[ -x /usr/bin/time ] || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq time >/dev/null; }
cargo build --release --locked -p cnc_node --bin cnc >&2
cat > bench/out/loops.nc <<'NC'
" 9999 x 9999 iterations: N20..N30 runs 10000 times inside N10..N40, which runs 10000 times
N1 G00 X100 Y100
N2 F60000 G91
N10 G01 X0.5
N20 X0.5
N30 X-0.5 G73 L20 Q9999
N40 X-0.5 G73 L10 Q9999
NC
printf 'N1 G00 X100 Y100\nN2 F60000 G91\nN10 G01 X0.5\nN20 X-0.5\n' > bench/out/short.nc
sed 's/Q9999/Q99/g' bench/out/loops.nc > bench/out/loops_q99.nc
echo "| program | wall s | peak RSS MiB | result |"
echo "|---|---:|---:|---|"
for p in short loops_q99 loops; do
    /usr/bin/time -f '%e %M' -o bench/out/$p.time target/release/cnc check bench/out/$p.nc > bench/out/$p.out
    read -r wall kib < bench/out/$p.time
    echo "| $p.nc | $wall | $(awk -v k="$kib" 'BEGIN{printf "%.1f", k/1024}') | $(cut -d: -f2- bench/out/$p.out | cut -c1-120) |"
done
