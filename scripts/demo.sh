#!/usr/bin/env bash
# Installs the Debian packages, builds, and registers a shipped real correspondence set (3DMatch
# redkitchen fragments 24 -> 59, FPFH matches with 3.7 % inliers), then compares with the ground truth.
set -euo pipefail
source "$(dirname "$0")/common.sh"
install_dependencies
build_workspace
source_workspace
data="$PROJECT_DIR/test/data/redkitchen_24_59"
out="$(mktemp)"
echo "== mac_register on $data/correspondences.txt"
"$WORKSPACE/devel/lib/mac_registration/mac_register" --correspondences "$data/correspondences.txt" \
  --config "$PROJECT_DIR/config/indoor_rgbd.yaml" --out "$out"
"$WORKSPACE/devel/lib/mac_registration/mac_benchmark" compare "$out" "$data/T_target_source_gt.txt"
