#!/usr/bin/env bash
# Two builds of `cnc` side by side on the same programs, alternated run by
# run (A B A B ...), so a machine whose speed drifts affects both alike:
# `cnc check` of the 1,000,000-block program of check_vs_rs274.sh and
# `cnc simulate` (plain and with --mcap) of the ten-minute program of
# simulate_10min.sh. Prints the median and range of wall time, CPU time
# (user + sys) and peak RSS per build, and the median of B/A per pair.
#
#   bash bench/ab.sh OLD_CNC NEW_CNC [RUNS]      # default 10 runs each
#
# Build the old one from its commit, e.g.
#   git worktree add --detach /tmp/old <commit> &&
#   (cd /tmp/old && cargo build --release -p cnc_node --bin cnc)
# and pass /tmp/old/target/release/cnc. Needs GNU time (apt: time).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export LC_ALL=C
A="${1:?old cnc}" B="${2:?new cnc}" RUNS="${3:-10}"
[ -x /usr/bin/time ] || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq time >/dev/null; }
OUT=bench/out
mkdir -p "$OUT"
CHECK="$OUT/prog_1000000_s1.ngc" SIM="$OUT/sim_10min.ngc"
[ -s "$CHECK" ] || python3 bench/gen_program.py --blocks 1000000 --seed 1 --out "$CHECK" 2>/dev/null
[ -s "$SIM" ] || python3 bench/gen_program.py --blocks 3000 --minutes 9 --out "$SIM" 2>/dev/null
# the two builds must agree before they are timed
for args in "check $CHECK --machine mill" "simulate $SIM --machine mill"; do
    # shellcheck disable=SC2086
    if ! cmp -s <("$A" $args 2>&1) <("$B" $args 2>&1); then
        echo "the builds disagree on: cnc $args" >&2
        exit 1
    fi
done
# (the same file name: a recording names its file in its metadata)
mkdir -p "$OUT/ab_a" "$OUT/ab_b"
"$A" simulate "$SIM" --machine mill --mcap "$OUT/ab_a/run.mcap" >/dev/null 2>&1
"$B" simulate "$SIM" --machine mill --mcap "$OUT/ab_b/run.mcap" >/dev/null 2>&1
cmp -s "$OUT/ab_a/run.mcap" "$OUT/ab_b/run.mcap" || {
    echo "the builds' recordings differ (compare them with cnc bag compare; builds that record different topics cannot be timed side by side here)" >&2
    exit 1
}

one() {  # one CNC ARGS... -> "wall cpu rss_kib"
    /usr/bin/time -f '%e %U %S %M' "$@" 2>&1 >/dev/null | tail -1 |
        awk '{printf "%.3f %.3f %d\n", $1, $2 + $3, $4}'
}
stats() {  # column of numbers -> "median (min-max)"
    sort -n | awk '{v[NR]=$1} END {m = (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2;
        printf "%.3f (%.3f-%.3f)", m, v[1], v[NR]}'
}
echo "| benchmark | build | wall s, median (range) | CPU s, median (range) | peak RSS MiB | B/A wall, median | B/A CPU, median |"
echo "|---|---|---:|---:|---:|---:|---:|"
bench() {  # bench NAME ARGS...
    local name="$1"; shift
    local ra=() rb=()
    for _ in $(seq "$RUNS"); do
        ra+=("$(one "$A" "$@")")
        rb+=("$(one "$B" "$@")")
    done
    local i ratios_w="" ratios_c=""
    for i in "${!ra[@]}"; do
        ratios_w+="$(echo "${ra[$i]} ${rb[$i]}" | awk '{printf "%.4f", $4 / $1}')"$'\n'
        ratios_c+="$(echo "${ra[$i]} ${rb[$i]}" | awk '{printf "%.4f", $5 / $2}')"$'\n'
    done
    for side in A B; do
        local rows
        if [ "$side" = A ]; then rows=("${ra[@]}"); else rows=("${rb[@]}"); fi
        local w c m
        w=$(printf '%s\n' "${rows[@]}" | cut -d' ' -f1 | stats)
        c=$(printf '%s\n' "${rows[@]}" | cut -d' ' -f2 | stats)
        m=$(printf '%s\n' "${rows[@]}" | cut -d' ' -f3 | sort -n | tail -1 | awk '{printf "%.1f", $1/1024}')
        if [ "$side" = A ]; then
            echo "| $name | A | $w | $c | $m | | |"
        else
            echo "| $name | B | $w | $c | $m | $(printf '%s' "$ratios_w" | stats | cut -d' ' -f1) | $(printf '%s' "$ratios_c" | stats | cut -d' ' -f1) |"
        fi
    done
}
bench "check 1M blocks" check "$CHECK" --machine mill
bench "simulate 10 min" simulate "$SIM" --machine mill
bench "simulate 10 min --mcap" simulate "$SIM" --machine mill --mcap "$OUT/ab_run.mcap"
