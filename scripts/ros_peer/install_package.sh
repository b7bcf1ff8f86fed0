#!/usr/bin/env bash
# Installs the nodes as the ROS 2 package `cnc_controller` under a prefix, as
# colcon --symlink-install would, so `ros2 run cnc_controller cnc_node ...`,
# `ros2 launch cnc_controller cnc_ros.launch.py` and launch_ros `Node(package=
# "cnc_controller", executable=...)` find them once PREFIX is on AMENT_PREFIX_PATH:
#
#   scripts/ros_peer/install_package.sh PREFIX [BIN_DIR]
#
#   PREFIX/lib/cnc_controller/{cnc_node,sim_axes,cnc}  -> BIN_DIR (default target/debug)
#   PREFIX/share/ament_index/resource_index/packages/cnc_controller
#   PREFIX/share/cnc_controller/package.xml            -> ros_package/package.xml
#   PREFIX/share/cnc_controller/launch/*.launch.py     -> launch_scripts/
#   PREFIX/share/cnc_controller/config/                -> config/ (params file, machine files)
#
# Symlinks, so a rebuild or an edit needs no reinstall; the binaries need not be
# built yet. Idempotent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
prefix="${1:?usage: install_package.sh PREFIX [BIN_DIR]}"
bin="${2:-$root/target/debug}"
pkg=cnc_controller
mkdir -p "$prefix"
prefix="$(cd "$prefix" && pwd)"
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
share="$prefix/share/$pkg"
mkdir -p "$prefix/lib/$pkg" "$share/launch" "$share/config" \
  "$prefix/share/ament_index/resource_index/packages"
for exe in cnc_node sim_axes cnc; do
  ln -sfn "$bin/$exe" "$prefix/lib/$pkg/$exe"
done
: > "$prefix/share/ament_index/resource_index/packages/$pkg"
ln -sfn "$root/ros_package/package.xml" "$share/package.xml"
for f in "$root"/launch_scripts/*.launch.py; do
  ln -sfn "$f" "$share/launch/$(basename "$f")"
done
for f in "$root"/config/*; do
  ln -sfn "$f" "$share/config/$(basename "$f")"
done
echo "installed $pkg in $prefix (executables from $bin)"
