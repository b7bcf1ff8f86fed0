#!/usr/bin/env bash
# A thread program run N times on the bundled simulator over DDS (release
# nodes, as scripts/main_job.sh starts them), one job after the other: how
# each job ended, then what the simulator reported (its loop held up,
# setpoints that reached it after their instant). On a host that holds the
# nodes up now and then, this is how often a user's thread job gets through.
#
# Usage: bash bench/thread_jobs.sh [N] [PROGRAM] [MACHINE]
#   N        jobs (default 10)
#   PROGRAM  default examples/lathe_thread.nc
#   MACHINE  default lathe
# Environment: SIM=PATH runs that simulator binary instead (e.g. an older
# build, for a before/after pair); SKIP_BUILD=1 uses target/release as it
# is; ROS_DOMAIN_ID (default 57).
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
n=${1:-10}
prog=${2:-examples/lathe_thread.nc}
machine=${3:-lathe}
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-57}
[ -n "${SKIP_BUILD:-}" ] || cargo build --release --locked -p cnc_node -p sim_axes --bins
bin=target/release
sim=${SIM:-$bin/sim_axes}
out=$(mktemp -d)
"$sim" --machine "$machine" 2>"$out/sim_axes.log" & sim_pid=$!
"$bin/cnc_node" --machine "$machine" --record-dir "$out/recordings" 2>"$out/cnc_node.log" & node_pid=$!
trap 'kill $sim_pid $node_pid 2>/dev/null || true' EXIT
sleep 3
done_n=0
for i in $(seq 1 "$n"); do
    line=$("$bin/cnc" run "$prog" 2>&1 | tail -1 || true)
    echo "$line"
    case "$line" in *" done: "*) done_n=$((done_n + 1)) ;; esac
done
kill $sim_pid $node_pid 2>/dev/null || true
wait 2>/dev/null || true
late=$(grep -o '[0-9]* setpoints arrived after their instant' "$out/sim_axes.log" | awk '{s += $1} END {print s + 0}')
stall_lines=$(grep -c ': stalled:' "$out/sim_axes.log" || true)
echo "simulator: $sim"
echo "jobs finished: $done_n of $n; setpoints late at the simulator: $late; its stall reports: $stall_lines (logs in $out)"
