#!/usr/bin/env bash
# Installs the Debian packages, builds the package and its tests, and runs every test with ctest.
set -euo pipefail
source "$(dirname "$0")/common.sh"
install_dependencies
build_workspace
source_workspace
echo "== running tests"
cd "$WORKSPACE/build"
ctest --output-on-failure --timeout 900
