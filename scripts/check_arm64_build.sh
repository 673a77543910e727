#!/usr/bin/env bash
# Compiles the core, configuration and front-end sources for 64-bit ARM (the Jetson and Raspberry Pi class
# of robot computer) with Debian's cross compiler, warnings as errors: the SIMD kernels are x86's, and this
# checks that everything else builds without them (src/core/kernels). A compile check only: nothing runs,
# and the ROS sources, which have no kernels, are not compiled. Installs g++-aarch64-linux-gnu if missing.
set -euo pipefail
source "$(dirname "$0")/common.sh"
exit_with_help_if_asked "$@"
if ! command -v aarch64-linux-gnu-g++ >/dev/null; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends g++-aarch64-linux-gnu
fi
cd "$PROJECT_DIR"
# The host's headers come last: the libraries' headers are the same on both, the C library's are ARM's.
FLAGS=(-c -o /dev/null -O2 -std=c++17 -fopenmp -Wall -Wextra -Werror -Iinclude -Isrc -Isrc/core
  -I/usr/include/eigen3 -I/usr/include/igraph -I/usr/include/pcl-1.13 -idirafter /usr/include)
echo "== arm64 compile check: src/core, src/config, src/features"
ls src/core/*.cpp src/core/kernels/*.cpp src/config/*.cpp src/features/*.cpp |
  xargs -P "$(nproc)" -I{} sh -c 'aarch64-linux-gnu-g++ "$@" {} || { echo "arm64: {} failed"; exit 255; }' _ "${FLAGS[@]}"
echo "== arm64 compile check: passed"
