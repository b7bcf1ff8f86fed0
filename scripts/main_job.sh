#!/usr/bin/env bash
# The main job: builds the controller and runs an example program on the
# bundled simulator (the in-process axis and spindle model), writing every
# sample to out/mill_pocket.csv.
# Usage: bash scripts/main_job.sh [PROGRAM] [MACHINE]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
prog=${1:-examples/mill_pocket.nc}
machine=${2:-mill}
mkdir -p out
cargo build --release --locked -p cnc_node --bin cnc
target/release/cnc check "$prog" --machine "$machine"
target/release/cnc simulate "$prog" --machine "$machine" --csv "out/$(basename "${prog%.*}").csv"
echo "samples written to out/$(basename "${prog%.*}").csv"
