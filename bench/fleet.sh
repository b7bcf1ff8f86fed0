#!/usr/bin/env bash
# A fleet of digital twins on one host (issue 21): N controller+simulator
# pairs in one DDS domain on loopback, each running bench/fleet/lathe_job.nc
# (G95, G33) recorded; N raised until something gives.
#   bash bench/fleet.sh [N ...]           (default: 1 2 4 6 8)
#   CNC_BIN=DIR bash bench/fleet.sh ...   (other binaries, e.g. an older build)
#   bash bench/fleet.sh --node-args "--rt-priority 0" 1 2   (options: python3 bench/fleet.py -h)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/ros_peer/setup.sh >/dev/null
. .venv-ros/env.sh
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-78} ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
bin=${CNC_BIN:-target/release}
[ -n "${CNC_SKIP_BUILD:-}" ] || cargo build --release --locked -p cnc_node -p sim_axes --bins >&2
# (at most 10 twins; each round stops what it started)
exec timeout -s INT 1800 python3 bench/fleet.py --bin "$bin" "$@"
