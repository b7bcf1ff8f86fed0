#!/usr/bin/env bash
# The screenshots of docs/ (README "Rerun"): a mill and a lathe recording as
# the Rerun viewer shows them at mid-run, taken by the viewer itself under
# Xvfb with Mesa's software Vulkan (lavapipe). Needs the test venv
# (scripts/ros_peer/setup.sh: rerun-sdk) and installs xvfb and
# mesa-vulkan-drivers with apt-get when missing. About a minute.
#
#   bash scripts/rerun/screenshots.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
missing=()
command -v xvfb-run >/dev/null || missing+=(xvfb xauth)
[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ] || ls /usr/share/vulkan/icd.d/lvp_icd.*.json >/dev/null 2>&1 || missing+=(mesa-vulkan-drivers)
if [ ${#missing[@]} -gt 0 ]; then
    sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo -n"
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
bash scripts/ros_peer/setup.sh >/dev/null
# shellcheck disable=SC1091
. .venv-ros/env.sh
cargo build -q --locked -p cnc_node --bin cnc
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
# a viewer of its own: no layout remembered from earlier sessions
export XDG_RUNTIME_DIR="$out/xdg" XDG_DATA_HOME="$out/data" XDG_CONFIG_HOME="$out/config" XDG_CACHE_HOME="$out/cache"
mkdir -m 700 "$XDG_RUNTIME_DIR"
for name in mill_pocket lathe_profile; do
    target/debug/cnc bag rrd "bags/$name.mcap" -o "$out/$name.rrd" --python "$(command -v python3)"
    xvfb-run -a -s "-screen 0 1600x1000x24" \
        python3 scripts/rerun/screenshot.py "$out/$name.rrd" "docs/rerun_$name.png" 0.5 \
        2> "$out/$name.viewer.log" || { tail -20 "$out/$name.viewer.log" >&2; exit 1; }
done
