#!/usr/bin/env bash
# Starts the simulator node and the controller node with no ROS installed
# (pure-Rust DDS), in the foreground until Ctrl-C or until they exit.
#
#   launch_scripts/start_nodes.sh [--machine mill|lathe|FILE] [--namespace /cnc] [--sim-namespace /sim]
#                                 [--cpu-affinity CPUS]   (both nodes on these CPUs, e.g. 1)
#
# ROS_DOMAIN_ID selects the DDS domain (default 0);
# ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST keeps discovery on loopback.
# CNC_BIN_DIR: where the binaries are (default target/release, built if missing).
set -euo pipefail
cd "$(dirname "$0")/.."
machine=mill ns=/cnc sim_ns=/sim
pin=()
while [ $# -gt 0 ]; do
    case "$1" in
        --machine) machine=$2; shift 2 ;;
        --namespace) ns=$2; shift 2 ;;
        --sim-namespace) sim_ns=$2; shift 2 ;;
        --cpu-affinity) pin=(--cpu-affinity "$2"); shift 2 ;;
        *) echo "unknown option $1" >&2; exit 2 ;;
    esac
done
bin=${CNC_BIN_DIR:-target/release}
if [ ! -x "$bin/cnc_node" ] || [ ! -x "$bin/sim_axes" ]; then
    cargo build --release --locked -p cnc_node -p sim_axes --bins
fi
pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT INT TERM
"$bin/sim_axes" --machine "$machine" --namespace "$sim_ns" --controller-namespace "$ns" "${pin[@]}" & pids+=($!)
"$bin/cnc_node" --machine "$machine" --namespace "$ns" --sim-namespace "$sim_ns" "${pin[@]}" & pids+=($!)
wait -n "${pids[@]}"
