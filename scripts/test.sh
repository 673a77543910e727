#!/usr/bin/env bash
# Installs the Debian packages, checks the formatting, builds the core alone with plain CMake and runs its
# tests, then builds the whole package (warnings are errors) and runs every test with ctest.
set -euo pipefail
source "$(dirname "$0")/common.sh"
exit_with_help_if_asked "$@"
install_dependencies
check_formatting
mkdir -p "$WORKSPACE"
build_and_test_core_only
MAC_CMAKE_ARGS="-DMAC_REGISTRATION_WERROR=ON" build_workspace tests
source_workspace
echo "== running tests"
cd "$WORKSPACE/build"
ctest --output-on-failure --timeout 900
