#!/usr/bin/env bash
# Installs the Debian packages, builds, and runs the demo headless: a bag made from the shipped scans (an
# indoor 3DMatch pair and an outdoor lidar pair) is replayed with simulated time against two registration
# nodes; each registration is printed with its transform, its error against the ground truth and its time.
# With a display (DISPLAY set), rviz shows the indoor alignment; gui:=false keeps it headless.
set -euo pipefail
source "$(dirname "$0")/common.sh"
DEBIAN_PACKAGES+=(rviz)
install_dependencies
build_workspace
source_workspace
gui=false
[ -n "${DISPLAY:-}" ] && gui=true
echo "== roslaunch mac_registration demo.launch gui:=$gui"
roslaunch mac_registration demo.launch bag:="$WORKSPACE/build/mac_registration/demo.bag" gui:="$gui"
