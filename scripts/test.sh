#!/usr/bin/env bash
# The whole test suite, from a fresh machine: installs what it needs, then
# formatting, lints and every test of the workspace.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null 2>&1; then
    if [ -x "$HOME/.cargo/bin/cargo" ]; then
        export PATH="$HOME/.cargo/bin:$PATH"
    else
        echo "cargo not found: install Rust (rustup) first" >&2
        exit 1
    fi
fi
rustup component add rustfmt clippy >/dev/null 2>&1 || true
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings
echo "== cargo test"
cargo test --workspace --locked
echo "== ROS 2 integration with a stock peer (rclpy, Kilted wheels from PyPI)"
bash scripts/ros_peer/setup.sh
# shellcheck disable=SC1091
. .venv-ros/env.sh
# `cargo test` above already built (and placed in target/debug) the nodes, the
# cnc tool and the record_example the tests run; a separate `cargo build -p`
# would resolve other features and compile the whole tree a second time.
cargo test --workspace --locked --no-run
# (one line a failure, with what the test printed: all of them fit in a
# CI log that is cut)
# (and how much of the CPUs' time the hypervisor took meanwhile: the ROS
# tests measure in real time, and skip, with the reason, what a host that
# holds every thread up spoils; README "The ROS tests measure ...")
steal() { awk '/^cpu /{s=$9; t=0; for (i = 2; i <= 9; i++) t += $i; print s, t}' /proc/stat 2>/dev/null || echo "0 0"; }
read -r s0 t0 < <(steal)
rc=0
CNC_SKIP_BUILD=1 python3 -m pytest tests/ros tests/mcap -q -p no:cacheprovider --tb=line -rfEs || rc=$?
read -r s1 t1 < <(steal)
awk -v s=$((s1 - s0)) -v t=$((t1 - t0)) 'BEGIN { if (t > 0) printf "ROS tests: the hypervisor took %.1f %% of the CPUs'"'"' time (steal)\n", 100 * s / t }'
exit $rc
