#!/usr/bin/env bash
# The main job: builds the controller, starts the simulator node and the
# controller node (ROS 2 over pure-Rust DDS, no ROS installation needed),
# sends an example program through the /cnc/run_program service, follows it
# to the end and prints a summary; the node records the job to
# out/recordings/job_1_<program>.mcap (ROS 2 MCAP: ros2 bag, Foxglove and
# Rerun open it). Then an offline run of the same program writes every
# sample to out/<program>.csv.
# Usage: bash scripts/main_job.sh [PROGRAM] [MACHINE]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
prog=${1:-examples/mill_pocket.nc}
machine=${2:-mill}
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-0}
mkdir -p out
cargo build --release --locked -p cnc_node -p sim_axes --bins
bin=target/release
"$bin/cnc" check "$prog" --machine "$machine"
"$bin/sim_axes" --machine "$machine" 2>out/sim_axes.log & sim=$!
"$bin/cnc_node" --machine "$machine" --record-dir out/recordings 2>out/cnc_node.log & node=$!
trap 'kill $sim $node 2>/dev/null || true' EXIT
"$bin/cnc" run "$prog" --record
sleep 0.5   # the node closes the recording right after the job
"$bin/cnc" simulate "$prog" --machine "$machine" --csv "out/$(basename "${prog%.*}").csv"
echo "samples written to out/$(basename "${prog%.*}").csv; node logs in out/"
