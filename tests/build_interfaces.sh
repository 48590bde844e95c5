#!/usr/bin/env bash
# Builds tests/interfaces/nav2_msgs (the ROS 2 Jazzy nav2_msgs interfaces the rclpy tests use:
# ComputePathToPose, ComputePathThroughPoses, FollowWaypoints, NavigateToPose, Spin, BackUp,
# DriveOnHeading, Wait, AssistedTeleop, FollowPath, IsPathValid, GetCostmap, LoadMap, the four costmap clearing services, SpeedLimit, CostmapFilterInfo) and
# tests/interfaces/map_msgs (OccupancyGridUpdate, costmap_2d's partial updates) and
# tests/interfaces/tf2_msgs (TFMessage, what /tf and /tf_static carry) and installs them into the
# test venv, so that `from nav2_msgs.action import ComputePathToPose` works there and
# rclpy can create action and service clients and servers for them. None has a wheel on PyPI,
# so this generates them with the rosidl generators from PyPI (tests/requirements-interfaces.txt).
#
#   tests/build_interfaces.sh [VENV]      VENV defaults to .venv at the repository root
#
# Idempotent: when nothing that goes into the build has changed (the packages' files, the pinned
# requirements, this script, the venv's Python) and both packages import, it only says so (~1 s).
# Installs into the venv's own prefix (VENV/lib, VENV/lib/python3.X/site-packages, VENV/share),
# where the ros-* wheels put their libraries too: the wheels' ros_wheels_bootstrapper.pth already
# puts VENV/lib on LD_LIBRARY_PATH when the venv's python starts, so the tests need no
# environment variable. The build trees are VENV/build/<package>.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

say() { printf '==> build_interfaces: %s\n' "$*"; }
die() { printf 'error: build_interfaces: %s\n' "$*" >&2; exit 1; }

VENV=${1:-.venv}
mkdir -p "$(dirname "$VENV")"
VENV=$(cd "$(dirname "$VENV")" && pwd)/$(basename "$VENV")
PY=$VENV/bin/python
# In build order (each may use the ones before it).
PKGS=(nav2_msgs map_msgs tf2_msgs)
STAMP=$VENV/share/patrol-planner-interfaces.stamp
START=$SECONDS

# The check that matters: the generated package imports and has C type support for rclpy,
# started as the tests start it (LD_LIBRARY_PATH comes from the wheels' bootstrapper, not us).
works() {
  env -u LD_LIBRARY_PATH -u _ROS_WHEELS_BOOTSTRAP_COMPLETE -u PYTHONPATH -u AMENT_PREFIX_PATH "$PY" -c '
from nav2_msgs.action import AssistedTeleop, ComputePathToPose, FollowPath, ComputePathThroughPoses, FollowWaypoints, NavigateToPose, Spin, BackUp, DriveOnHeading, Wait
from nav2_msgs.srv import ClearCostmapAroundPose, ClearEntireCostmap, GetCostmap, IsPathValid
from nav2_msgs.msg import CostmapFilterInfo, SpeedLimit
from map_msgs.msg import OccupancyGridUpdate
from tf2_msgs.msg import TFMessage
from rclpy.type_support import check_for_type_support
for t in (AssistedTeleop, ComputePathToPose, ComputePathThroughPoses, FollowWaypoints, NavigateToPose, Spin, BackUp, DriveOnHeading, Wait, ClearCostmapAroundPose, ClearEntireCostmap, GetCostmap, IsPathValid, CostmapFilterInfo, SpeedLimit, OccupancyGridUpdate, TFMessage):
    check_for_type_support(t)
' "$@"
}

# A hash of everything the result depends on.
inputs_hash() {
  {
    for pkg in "${PKGS[@]}"; do
      (cd "$ROOT/tests/interfaces/$pkg" && find . -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum)
    done
    sha256sum tests/requirements-interfaces.txt tests/build_interfaces.sh tests/interfaces/wheel_include_dirs.cmake
    "$PY" -c 'import sys; print(sys.version)'
  } | sha256sum | cut -d' ' -f1
}

if [ ! -x "$PY" ]; then
  say "no venv at $VENV: creating it with tests/requirements.txt"
  python3 -m venv "$VENV"
  "$PY" -m pip install --quiet --disable-pip-version-check -r tests/requirements.txt
fi

# One build at a time per venv: a second run waits here, then finds the first one's result.
exec 9>"$VENV/.build_interfaces.lock"
if ! flock -n 9; then
  say "another build_interfaces.sh is working on $VENV: waiting for it"
  flock 9
fi

if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$(inputs_hash)" ] && works 2>/dev/null; then
  say "${PKGS[*]} in $VENV are up to date (delete $STAMP to force a rebuild)"
  exit 0
fi

say "installing the rosidl/ament generator wheels (tests/requirements-interfaces.txt) into $VENV"
"$PY" -m pip install --quiet --disable-pip-version-check \
  -r tests/requirements.txt -r tests/requirements-interfaces.txt \
  || die "pip could not install tests/requirements-interfaces.txt"

# A C and a C++ compiler and make (Debian's; CMake itself comes from PyPI, above).
missing=()
command -v cc >/dev/null || missing+=(gcc)
command -v c++ >/dev/null || missing+=(g++)
command -v make >/dev/null || missing+=(make)
if [ ${#missing[@]} -gt 0 ]; then
  say "installing ${missing[*]} with apt-get"
  command -v apt-get >/dev/null || die "${missing[*]} missing and no apt-get to install them"
  SUDO=; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  $SUDO apt-get update -qq || die "apt-get update failed"
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" \
    || die "apt-get install ${missing[*]} failed"
fi
INCLUDEPY=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
[ -f "$INCLUDEPY/Python.h" ] \
  || die "no Python.h in $INCLUDEPY: the venv's Python needs its headers (Debian: apt-get install python3-dev)"

# Only the venv's prefix: no sourced ROS install or other workspace may leak into the build.
# (ament_cmake's resource index search, which finds the type support generators, reads
# AMENT_PREFIX_PATH and CMAKE_INSTALL_PREFIX; find_package reads CMAKE_PREFIX_PATH.)
export PATH=$VENV/bin:$PATH
export AMENT_PREFIX_PATH=$VENV
unset CMAKE_PREFIX_PATH COLCON_PREFIX_PATH PYTHONPATH LD_LIBRARY_PATH _ROS_WHEELS_BOOTSTRAP_COMPLETE
rm -f "$STAMP"
SITE=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
for pkg in "${PKGS[@]}"; do
  SRC=$ROOT/tests/interfaces/$pkg
  BUILD=$VENV/build/$pkg
  # Leave no file of a previous build behind (an interface removed from the package, say).
  if [ -f "$BUILD/install_manifest.txt" ]; then
    say "removing the previous install of $pkg from $VENV"
    while IFS= read -r f; do
      case "$f" in "$VENV"/*) rm -f -- "$f" ;; esac
    done < "$BUILD/install_manifest.txt"
    # and the directories that held them (pip chokes on an empty *.egg-info directory)
    rm -rf "${SITE:?}/$pkg" "$SITE/$pkg"-*.egg-info "$VENV/include/$pkg" "$VENV/share/$pkg"
  fi
  rm -rf "$BUILD"
  mkdir -p "$BUILD"
  LOG=$BUILD/build.log
  run() {
    if ! "$@" >>"$LOG" 2>&1; then
      tail -n 60 "$LOG" >&2
      die "failed: $* (whole log: $LOG)"
    fi
  }
  say "$pkg: configuring (cmake $(cmake --version | head -n 1 | cut -d' ' -f3); log: $LOG)"
  run cmake -S "$SRC" -B "$BUILD" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DCMAKE_PREFIX_PATH="$VENV" \
    -DPython3_EXECUTABLE="$PY" \
    -DBUILD_TESTING=OFF
  say "$pkg: generating and compiling (C, C++ and Python type support)"
  run cmake --build "$BUILD" --parallel "$(nproc)"
  say "$pkg: installing into $VENV"
  run cmake --install "$BUILD"
done

if ! works; then
  die "${PKGS[*]} were installed into $VENV but do not import with rclpy type support (see above)"
fi
mkdir -p "$(dirname "$STAMP")"
inputs_hash >"$STAMP"
say "done in $((SECONDS - START)) s: ${PKGS[*]} (Jazzy subsets) are importable from $PY"
