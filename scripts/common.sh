# Shared by the set-up scripts: environment fixes for Debian 12's ROS 1, dependency install, build.
# Sourced, not run.

# A pyenv python first on PATH has no ROS modules (catkin_make fails with "No module named catkin_pkg").
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH:-}"
export ROS_HOSTNAME=localhost
export ROS_HOME="${ROS_HOME:-${HOME:-/tmp}/.ros}"
PROJECT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# The catkin workspace links to this checkout, so it must lie outside it: roslaunch and rospack follow
# symbolic links and would find the package inside itself again and again.
WORKSPACE="${MAC_WORKSPACE:-$(dirname "$PROJECT_DIR")/mac_registration_ws}"

# `--help` or `-h` among a script's arguments: prints its header comment and exits 0.
exit_with_help_if_asked() {
  local arg
  for arg in "$@"; do
    if [ "$arg" = --help ] || [ "$arg" = -h ]; then
      sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"
      exit 0
    fi
  done
}

# Debian 12 packages the package builds, tests and runs with.
DEBIAN_PACKAGES=(
  build-essential cmake pkg-config catkin clang-format git
  libeigen3-dev libigraph-dev libglpk-dev libplfit-dev libgtest-dev libpcl-dev
  ros-base-dev libnodelet-dev libpcl-ros-dev libpcl-conversions-dev libtf2-ros-dev libtf2-eigen-dev
  libtf2-sensor-msgs-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libdiagnostic-updater-dev librostest-dev python3-rostest python3-rosbag python3-roslaunch rosbash tf2-tools
  python3-sensor-msgs python3-geometry-msgs python3-std-srvs libvisualization-msgs-dev
  # for the shell tools on the node's outputs: rostopic echo /diagnostics and ~correspondence_markers,
  # rosservice call MANAGER/list, rosrun tf2_tools echo.py
  python3-diagnostic-msgs python3-visualization-msgs python3-nodelet python3-numpy
  # scripts/loop_closure_bridge.py
  python3-nav-msgs python3-message-filters
  # mac_benchmark's peers (--baseline open3d / fgr) and their test
  python3-open3d
  # the Python module (python/): pybind11 and the interpreter's headers; its tests and the example's picture
  pybind11-dev python3-dev python3-pytest python3-matplotlib
)

install_dependencies() {
  local missing=()
  for p in "${DEBIAN_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && { echo "== dependencies: all ${#DEBIAN_PACKAGES[@]} Debian packages present"; return; }
  echo "== installing ${#missing[@]} Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# Builds the package in a catkin workspace that links to this checkout, Release; with an argument `tests`,
# its tests too (catkin's `tests` target). MAC_CMAKE_ARGS adds CMake options (CI: -DMAC_REGISTRATION_WERROR=ON).
build_workspace() {
  mkdir -p "$WORKSPACE/src"
  ln -sfn "$PROJECT_DIR" "$WORKSPACE/src/mac_registration"
  # catkin writes the environment its tests run in (build/catkin_generated/setup_cached.sh) when it first
  # configures, listing only folders that exist then: without this one the rostests' Python nodes would
  # not find the package's messages on a fresh workspace.
  mkdir -p "$WORKSPACE/devel/lib/python3/dist-packages"
  : >"$WORKSPACE/build.log"
  local targets=(all)
  [ "${1:-}" = tests ] && targets+=(tests)
  echo "== building ${targets[*]} in $WORKSPACE (Release)"
  local target
  for target in "${targets[@]}"; do
    # shellcheck disable=SC2086  # MAC_CMAKE_ARGS holds several words on purpose
    (cd "$WORKSPACE" && catkin_make -DCMAKE_BUILD_TYPE=Release ${MAC_CMAKE_ARGS:-} -j"$(nproc)" "$target" \
      >>"$WORKSPACE/build.log" 2>&1) || {
      tail -n 60 "$WORKSPACE/build.log"
      echo "build failed; full log: $WORKSPACE/build.log"
      return 1
    }
  done
}

# Every C++ file as .clang-format wants it; prints the ones that are not and fails.
check_formatting() {
  local unformatted=()
  while IFS= read -r f; do
    clang-format --dry-run -Werror "$PROJECT_DIR/$f" >/dev/null 2>&1 || unformatted+=("$f")
  done < <(git -C "$PROJECT_DIR" ls-files '*.cpp' '*.hpp')
  if [ ${#unformatted[@]} -gt 0 ]; then
    echo "not clang-formatted (run clang-format -i on them): ${unformatted[*]}"
    return 1
  fi
  echo "== formatting: every C++ file is clang-formatted"
}

# The ROS-free core, its tools and tests with plain CMake, as a user without ROS builds them.
build_and_test_core_only() {
  local dir="$WORKSPACE/core_only"
  echo "== core-only build (plain CMake, no ROS, no PCL) in $dir"
  cmake -S "$PROJECT_DIR" -B "$dir" -DMAC_REGISTRATION_CORE_ONLY=ON -DMAC_REGISTRATION_WERROR=ON >"$dir.log" 2>&1 &&
    cmake --build "$dir" -j"$(nproc)" >>"$dir.log" 2>&1 || {
    tail -n 40 "$dir.log"
    echo "core-only build failed; full log: $dir.log"
    return 1
  }
  (cd "$dir" && ctest --output-on-failure --timeout 600)
}

source_workspace() {
  # devel/setup.bash reads unset variables (ROS_DISTRO): it cannot run under set -u.
  set +u
  # shellcheck disable=SC1091
  source "$WORKSPACE/devel/setup.bash"
  set -u
}
