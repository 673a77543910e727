#!/usr/bin/env bash
# Installs the Debian packages, builds, and runs the demo headless: a bag made from the shipped scans (an
# indoor 3DMatch pair, an outdoor lidar pair and a campus drive) is replayed with simulated time against two
# registration nodes and a relocalization node with a campus map; each result is printed with its transform,
# its error against the ground truth and its time.
# With a display (DISPLAY set), rviz shows the indoor alignment and the campus drive on its map; gui:=false
# keeps it headless.
set -euo pipefail
source "$(dirname "$0")/common.sh"
exit_with_help_if_asked "$@"
DEBIAN_PACKAGES+=(rviz)
install_dependencies
build_workspace
source_workspace
gui=false
[ -n "${DISPLAY:-}" ] && gui=true
echo "== roslaunch mac_registration demo.launch gui:=$gui"
# roslaunch runs in the background and is stopped once the monitor has written its summary, so that the
# summary, not roslaunch's shutdown messages, is what the demo prints last.
summary="$WORKSPACE/demo_summary.txt"
rm -f "$summary"
roslaunch mac_registration demo.launch bag:="$WORKSPACE/build/mac_registration/demo.bag" gui:="$gui" \
  exit_when_done:=false summary_file:="$summary" &
launch=$!
while [ ! -f "$summary" ] && kill -0 "$launch" 2>/dev/null; do sleep 1; done
kill -INT "$launch" 2>/dev/null || true
wait "$launch" || true
if [ ! -f "$summary" ]; then
  echo "demo: roslaunch ended before every result was reported"
  exit 1
fi
echo
echo "== summary"
cat "$summary"
