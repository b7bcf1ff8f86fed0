#!/usr/bin/env bash
# How the spindle encoder's readings reached a thread job's cycles, builds
# alternated: for each round and each build, a fresh simulator and node from
# that build, N jobs of a thread program, then the count of cycles that ran
# without their period's reading (cnc_node logs it at each job's end) and
# the hypervisor's stolen ticks over the round (/proc/stat).
#
# Usage: bash bench/encoder_readings_ab.sh ROUNDS N DIR:LABEL [DIR:LABEL ...]
#   DIR holds release binaries cnc, cnc_node, sim_axes of one build.
# Environment: PROGRAM (default examples/lathe_thread.nc), MACHINE (lathe),
# ROS_DOMAIN_ID (default 84).
set -uo pipefail
cd "$(dirname "$0")/.."
rounds=${1:?rounds}; n=${2:?jobs per round}; shift 2
prog=${PROGRAM:-examples/lathe_thread.nc}
machine=${MACHINE:-lathe}
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-84}
out=$(mktemp -d)
steal() { awk '/^cpu /{print $9}' /proc/stat; }
for r in $(seq 1 "$rounds"); do
    for build in "$@"; do
        b=${build%%:*}; label=${build##*:}
        s0=$(steal)
        "$b/sim_axes" --machine "$machine" 2>"$out/sim_$label.log" & sim=$!
        "$b/cnc_node" --machine "$machine" 2>"$out/node_$label.log" & node=$!
        sleep 3
        for _ in $(seq 1 "$n"); do "$b/cnc" run "$prog" >/dev/null 2>&1 || true; done
        kill "$sim" "$node" 2>/dev/null; wait "$sim" "$node" 2>/dev/null
        counts=$(grep -o "[0-9]* cycles: [0-9]* without[^,]*, the newest up to [0-9.]* ms old" \
            "$out/node_$label.log" | sed "s/ without their period.s reading//" | paste -sd ';')
        echo "round $r $label steal_ticks $(( $(steal) - s0 )) :: $counts"
    done
done
echo "logs in $out"
