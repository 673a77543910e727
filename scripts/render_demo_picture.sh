#!/usr/bin/env bash
# Renders doc/demo_alignment.png: rviz under Xvfb shows the demo's indoor pair (grey target, orange source
# aligned by the node, green inlier correspondences), ImageMagick captures the 3D view; then
# doc/demo_relocalization.png: the campus map's keypoints (grey) and the drive placed on it by the
# relocalization's map -> odom (orange), from above.
# Needs a built workspace (scripts/demo.sh) and: apt-get install xvfb imagemagick rviz
set -euo pipefail
source "$(dirname "$0")/common.sh"
exit_with_help_if_asked "$@"
source_workspace
export DISPLAY=:99
Xvfb "$DISPLAY" -screen 0 1280x900x24 >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null' EXIT
sleep 2
timeout 60 roslaunch mac_registration demo.launch bag:="$WORKSPACE/build/mac_registration/demo.bag" gui:=true \
  relocalization_gui:=false exit_when_done:=false rate:=0.5 >/dev/null 2>&1 &
launch=$!
sleep 22  # the first indoor registration arrives ~8 s of wall time after the start at rate 0.5
import -window root /tmp/mac_demo_screen.png
kill -INT $launch 2>/dev/null || true
# The 3D view of rviz's default layout, trimmed to the clouds.
convert /tmp/mac_demo_screen.png -crop 820x708+364+62 +repage -trim -bordercolor white -border 20 \
  "$PROJECT_DIR/doc/demo_alignment.png"
echo "wrote $PROJECT_DIR/doc/demo_alignment.png"
wait $launch 2>/dev/null || true

timeout 60 roslaunch mac_registration demo.launch bag:="$WORKSPACE/build/mac_registration/demo.bag" gui:=false \
  relocalization_gui:=true exit_when_done:=false >/dev/null 2>&1 &
launch=$!
sleep 25  # the map described and the drive localized, with the slow rendering of Xvfb
import -window root /tmp/mac_relocalization_screen.png
kill -INT $launch 2>/dev/null || true
wait $launch 2>/dev/null || true
convert /tmp/mac_relocalization_screen.png -crop 840x780+352+62 +repage -trim -bordercolor white -border 20 \
  "$PROJECT_DIR/doc/demo_relocalization.png"
echo "wrote $PROJECT_DIR/doc/demo_relocalization.png"
