#!/usr/bin/env bash
# Set up a stock ROS 2 (Kilted) peer from PyPI wheels, for interop tests of the
# Rust controller: rclpy + rmw_fastrtps_cpp + std/sensor/diagnostic msgs, our own
# interface package msgs/ (cnc_msgs) built with plain cmake, and tf2_msgs's
# TFMessage (scripts/ros_peer/tf2_msgs: geometry2 has no wheel on PyPI) likewise.
#
#   scripts/ros_peer/setup.sh          # idempotent; re-runs take a few seconds
#   . .venv-ros/env.sh                 # then: python3 scripts/ros_peer/smoke.py
#
# Creates (all gitignored, under the repo root):
#   .venv-ros/                    Python 3.11 venv with the pinned wheels (requirements.txt)
#   .venv-ros/build/cnc_msgs/     cmake build tree of msgs/ (build/tf2_msgs/: of tf2_msgs)
#   .venv-ros/cnc_msgs_install/   install prefix of cnc_msgs and tf2_msgs (C/C++ libs, Python packages, ament index)
#   .venv-ros/env.sh              environment for tests (PATH, PYTHONPATH, LD_LIBRARY_PATH, ...)
#   .venv-ros/bin/ros2            the ROS 2 command line and launch (ros2cli, launch, launch_ros):
#                                 from ../shared/vendor beside the repo when it is there (CI),
#                                 else from their upstream repositories when the network allows,
#                                 else not (.venv-ros/ros2cli.missing says why; tests that need
#                                 `ros2` skip with that reason)
#   .venv-ros/cnc_msgs_install/   also composition_interfaces (launch_ros imports it; no wheel)
#   .venv-ros/cnc_controller_install/  the nodes as the ament package cnc_controller
#                                 (install_package.sh: symlinks to $CNC_BIN_DIR, default
#                                 target/debug), for `ros2 run` and `ros2 launch`
# and, outside the repo, symlinks under /opt/python/cp311-cp311 (only if missing or
# dangling) because the wheels' CMake exports hard-code the manylinux build
# image's Python and numpy include directories.
#
# Needs: Debian 12 (or similar, x86_64/glibc >= 2.28), python3.11, network access to
# PyPI; installs python3-venv, python3-dev, g++, make with apt-get when missing.
# Environment knobs: ROS_PEER_PYTHON (interpreter, default python3),
# ROS_PEER_FORCE=1 (reinstall wheels and rebuild msgs/ from scratch).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/.venv-ros"
prefix="$venv/cnc_msgs_install"
req="$here/requirements.txt"
py="${ROS_PEER_PYTHON:-python3}"
force="${ROS_PEER_FORCE:-0}"
t_start=$(date +%s)

log() { printf '[ros_peer setup %3ss] %s\n' "$(( $(date +%s) - t_start ))" "$*"; }

# ---------------------------------------------------------------- apt helpers
apt_updated=0
apt_install() {
  local sudo=""
  if [ "$(id -u)" != 0 ]; then
    command -v sudo >/dev/null || { echo "need root (or sudo) to apt-get install $*" >&2; exit 1; }
    sudo="sudo -n"
  fi
  if [ "$apt_updated" = 0 ]; then
    log "apt-get update"
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    apt_updated=1
  fi
  log "apt-get install $*"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}
as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"; else sudo -n "$@"; fi
}

# ---------------------------------------------------------------- 0. tools
command -v "$py" >/dev/null || apt_install python3
pyver="$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
if [ "$pyver" != 3.11 ]; then
  echo "the ROS 2 wheels are cp311 only; $py is Python $pyver (set ROS_PEER_PYTHON)" >&2
  exit 1
fi
# The generated Python bindings are C extensions: they need Python.h.
py_inc="$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
[ -f "$py_inc/Python.h" ] || apt_install python3-dev
missing=()
command -v g++ >/dev/null || missing+=(g++)
command -v gcc >/dev/null || missing+=(gcc)
command -v make >/dev/null || missing+=(make)
[ ${#missing[@]} = 0 ] || apt_install "${missing[@]}"

# ---------------------------------------------------------------- 1. venv
if [ "$force" = 1 ]; then rm -rf "$venv"; fi
if [ ! -x "$venv/bin/python" ]; then
  log "creating venv $venv"
  # Debian's python3 has venv but not ensurepip until python3-venv is installed.
  "$py" -c 'import ensurepip, venv' 2>/dev/null || apt_install python3-venv
  "$py" -m venv "$venv"
fi
vpy="$venv/bin/python"

# ---------------------------------------------------------------- 2. wheels
stamp="$venv/.requirements.sha256"
want="$(sha256sum "$req" | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  log "pip install -r $(realpath --relative-to="$root" "$req")"
  # ros_wheels_bootstrapper (a .pth) re-execs every venv python with
  # LD_LIBRARY_PATH set; harmless for pip.
  "$vpy" -m pip install -q --disable-pip-version-check -r "$req"
  echo "$want" > "$stamp"
else
  log "wheels up to date (requirements.txt unchanged)"
fi

# ---------------------------------------------------------------- 3. include symlinks
# The wheels' exported CMake targets (e.g. builtin_interfaces__rosidl_generator_py)
# list these manylinux paths in INTERFACE_INCLUDE_DIRECTORIES; CMake refuses
# non-existent ones. Point them at this machine's Python and numpy headers.
np_inc="$("$vpy" -c 'import numpy; print(numpy.get_include())')"
link_dir() {  # link_dir TARGET LINKPATH
  local target="$1" link="$2"
  if [ -L "$link" ]; then
    # ours from an earlier run (maybe another checkout): keep while it resolves
    [ -e "$link" ] && return 0
    as_root rm -f "$link"
  elif [ -e "$link" ]; then
    return 0  # a real directory (e.g. we are in a manylinux image): leave it
  fi
  log "symlink $link -> $target"
  as_root mkdir -p "$(dirname "$link")"
  as_root ln -s "$target" "$link"
}
link_dir "$py_inc" /opt/python/cp311-cp311/include/python3.11
link_dir "$np_inc" /opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include

# ---------------------------------------------------------------- 4. build msgs/
export PATH="$venv/bin:$PATH"
export CMAKE_PREFIX_PATH="$venv"
export AMENT_PREFIX_PATH="$venv"
unset PYTHONPATH
if [ "$force" = 1 ]; then rm -rf "$venv/build" "$prefix"; fi
mkdir -p "$venv/build"
# interface package NAME from SRC: configured once in BUILD, built and installed into $prefix
cmake_package() {  # cmake_package NAME SRC BUILD
  local name="$1" src="$2" b="$3" logs="$venv/build/$1"
  if [ ! -f "$b/CMakeCache.txt" ]; then
    log "cmake configure $name"
    cmake -S "$src" -B "$b" \
      -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_INSTALL_PREFIX="$prefix" \
      -DPython3_EXECUTABLE="$vpy" \
      -DBUILD_TESTING=OFF \
      >"$logs.configure.log" 2>&1 \
      || { cat "$logs.configure.log" >&2; exit 1; }
  fi
  log "cmake build + install $name -> $(realpath --relative-to="$root" "$prefix")"
  cmake --build "$b" -j "$(nproc)" >"$logs.build.log" 2>&1 \
    || { tail -50 "$logs.build.log" >&2; exit 1; }
  cmake --install "$b" >"$logs.install.log" 2>&1 \
    || { cat "$logs.install.log" >&2; exit 1; }
}
cmake_package cnc_msgs "$root/msgs" "$venv/build/cnc_msgs"
cmake_package tf2_msgs "$here/tf2_msgs" "$venv/build/tf2_msgs"

# ---------------------------------------------------------------- 5. ros2cli and launch
# Not on PyPI. Unmodified upstream sources: ../shared/vendor (CI and our
# machines), else the upstream repositories at the same commits.
vendor="$root/../shared/vendor"
missing_note="$venv/ros2cli.missing"
ros2_stamp="$venv/.ros2cli.stamp"
upstream_install() {  # the vendored install, from github.com/ros2 (needs git and the network)
  local src="$venv/build/ros2cli-src" r c
  command -v git >/dev/null || { echo "git is not installed"; return 1; }
  rm -rf "$src"; mkdir -p "$src"
  for rc in ros2cli:e20d2c664fc2981b0b80ebed534e5becc6fdbf34 \
            rosidl_runtime_py:3327b1dc488af514017c5446ffff12d102bbe94a \
            launch:02595bafc7891d4d287667b6aa9161edf738e9f3 \
            launch_ros:f9ab9371824d470bca47602bc7d277eb2217c90d; do
    r=${rc%%:*} c=${rc#*:}
    git init -q "$src/$r" \
      && timeout 120 git -C "$src/$r" fetch -q --depth 1 "https://github.com/ros2/$r" "$c" \
      && git -C "$src/$r" checkout -q FETCH_HEAD \
      || { echo "github.com/ros2/$r not reachable"; return 1; }
  done
  "$vpy" -m pip install -q osrf-pycommon lark argcomplete packaging psutil pyyaml wheel setuptools || return 1
  for p in rosidl_runtime_py ros2cli/ros2cli ros2cli/ros2pkg ros2cli/ros2node ros2cli/ros2topic \
           ros2cli/ros2service ros2cli/ros2action ros2cli/ros2param ros2cli/ros2interface \
           ros2cli/ros2run launch/launch launch/launch_xml launch/launch_yaml \
           launch_ros/launch_ros launch_ros/ros2launch; do
    "$vpy" -m pip install -q --no-deps --no-build-isolation "$src/$p" || return 1
  done
  rm -rf "$src"
}
rm -f "$missing_note"
if [ -f "$vendor/install.sh" ]; then
  want_ros2="vendor $(cat "$vendor"/*.tar.gz | sha256sum | cut -d' ' -f1)"
else
  want_ros2="upstream e20d2c6 3327b1d 02595ba f9ab937"
fi
if [ -x "$venv/bin/ros2" ] && [ "$(cat "$ros2_stamp" 2>/dev/null)" = "$want_ros2" ]; then
  log "ros2 command line up to date"
elif [ -f "$vendor/install.sh" ]; then
  log "installing the ros2 command line and launch from $(realpath "$vendor")"
  bash "$vendor/install.sh" "$venv" && echo "$want_ros2" > "$ros2_stamp"
else
  log "no ../shared/vendor: the ros2 command line and launch from github.com/ros2"
  if why=$(upstream_install 2>&1); then
    echo "$want_ros2" > "$ros2_stamp"
  else
    log "ros2 command line not installed: $why"
    echo "the ros2 command line is not installed: no ../shared/vendor beside the repository, and the upstream repositories could not be installed ($why)" > "$missing_note"
  fi
fi
# launch_ros imports composition_interfaces, which no wheel provides
if [ -x "$venv/bin/ros2" ] && ! "$vpy" -c "import composition_interfaces" 2>/dev/null; then
  cmake_package composition_interfaces "$here/composition_interfaces" "$venv/build/composition_interfaces"
fi

# ---------------------------------------------------------------- 6. the package cnc_controller
pkg_prefix="$venv/cnc_controller_install"
bash "$here/install_package.sh" "$pkg_prefix" "${CNC_BIN_DIR:-$root/target/debug}" >/dev/null
log "package cnc_controller in $(realpath --relative-to="$root" "$pkg_prefix") (ros2 run cnc_controller cnc_node)"

# ---------------------------------------------------------------- 7. env.sh
cat > "$venv/env.sh" <<EOF
# Generated by scripts/ros_peer/setup.sh -- source it: . .venv-ros/env.sh
# Stock ROS 2 Kilted (PyPI wheels) + cnc_msgs, Fast DDS RMW.
_rp_venv="$venv"
_rp_prefix="$prefix"
_rp_pkg="$pkg_prefix"
_rp_sp="\$_rp_venv/lib/python3.11/site-packages"
_rp_libs="\$_rp_prefix/lib:\$_rp_venv/lib"
for _rp_d in "\$_rp_sp"/ros_*.libs; do [ -d "\$_rp_d" ] && _rp_libs="\$_rp_libs:\$_rp_d"; done
export PATH="\$_rp_venv/bin\${PATH:+:\$PATH}"
export PYTHONPATH="\$_rp_prefix/lib/python3.11/site-packages\${PYTHONPATH:+:\$PYTHONPATH}"
export LD_LIBRARY_PATH="\$_rp_libs\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
export AMENT_PREFIX_PATH="\$_rp_pkg:\$_rp_prefix:\$_rp_venv"
export CMAKE_PREFIX_PATH="\$_rp_prefix:\$_rp_venv"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
# LD_LIBRARY_PATH is complete: stop ros_wheels_bootstrapper re-exec'ing python.
export _ROS_WHEELS_BOOTSTRAP_COMPLETE=1
export VIRTUAL_ENV="\$_rp_venv"
export ROS_DISTRO=kilted   # ros2-client compares it with its distro feature
# Keep discovery on loopback unless the caller chose otherwise: Fast DDS then
# sends SPDP by unicast to 127.0.0.1:7410+2*i instead of multicast
# 239.255.0.1:7400 on every interface. ROS_DOMAIN_ID is left to the caller.
export ROS_AUTOMATIC_DISCOVERY_RANGE="\${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
unset _rp_venv _rp_prefix _rp_pkg _rp_sp _rp_libs _rp_d
EOF

# ---------------------------------------------------------------- 8. check
log "checking imports"
( . "$venv/env.sh"
  python3 -c "import rclpy; from cnc_msgs.srv import RunProgram; from cnc_msgs.msg import SpindleEncoder, ControllerStatus; from cnc_msgs.action import ExecuteProgram; from sensor_msgs.msg import JointState; from std_srvs.srv import Trigger; from diagnostic_msgs.msg import DiagnosticArray; from rcl_interfaces.msg import Log; from tf2_msgs.msg import TFMessage"
  if [ -x "$venv/bin/ros2" ]; then
    python3 -c "import launch_ros.actions"
    ros2 pkg prefix cnc_controller >/dev/null
  fi )
log "done: . $(realpath --relative-to="$PWD" "$venv/env.sh" 2>/dev/null || echo "$venv/env.sh") && python3 scripts/ros_peer/smoke.py"
