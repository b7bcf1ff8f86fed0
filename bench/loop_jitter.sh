#!/usr/bin/env bash
# Loop jitter at 1 kHz with the simulator running, as a stock ROS 2
# subscriber sees it, and the node's CPU use; then the same while 5 MB
# programs are checked (sent by program_path as dry runs).
#   bash bench/loop_jitter.sh [SECONDS]     (default 60)
#   RECORD=1 bash bench/loop_jitter.sh      (the node records every job to MCAP)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
secs=${1:-60}
bash scripts/ros_peer/setup.sh >/dev/null
. .venv-ros/env.sh
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-77} ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
cargo build --release --locked -p cnc_node -p sim_axes --bins >&2
mkdir -p bench/out/progs
[ -s bench/out/progs/big.ngc ] || python3 bench/gen_program.py --blocks 115000 --out bench/out/progs/big.ngc 2>/dev/null
ls -l bench/out/progs/big.ngc >&2
target/release/sim_axes --machine mill 2>/dev/null & sim=$!
rec_args=()
[ "${RECORD:-0}" = 1 ] && rec_args=(--record-all --record-dir bench/out/recordings)
target/release/cnc_node --machine mill --program-dir bench/out/progs --loop-stats 30 "${rec_args[@]}" 2>bench/out/cnc_node.log & node=$!
trap 'kill $sim $node 2>/dev/null || true' EXIT
echo "| run | periods | gaps (missed by the subscriber) | p50 µs | p99 µs | p99.9 µs | max µs | node CPU |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
python3 bench/loop_jitter.py --seconds "$secs" --node-pid "$node" --label "job running, simulator running" --start-job big.ngc
python3 bench/loop_jitter.py --seconds "$secs" --node-pid "$node" --label "with 5 MB checks" --big-program big.ngc --checks 10
echo "(|period - 1000 µs| from the setpoints' header stamps; $(nproc) cores: $(awk -F': ' '/model name/{print $2; exit}' /proc/cpuinfo))"
[ "${RECORD:-0}" = 1 ] && echo "recording: $(du -sh bench/out/recordings | cut -f1) in bench/out/recordings"
echo "in-node wake-up lateness (cumulative, every 30 s): "
grep "loop lateness" bench/out/cnc_node.log || true
