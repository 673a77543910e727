#!/usr/bin/env bash
# The Python module without ROS, as README.md ("Python") installs it: Debian's packages, a fresh virtual
# environment of Debian's /usr/bin/python3 that sees them (--system-site-packages: numpy, setuptools,
# wheel, pytest, matplotlib), `pip install --no-build-isolation .` from this checkout (nothing is
# downloaded; CMake builds the core, the config and the PCL front end into the module, warnings as errors),
# then, from outside the checkout, the import, the example and the module's tests, against mac_register
# and mac_relocalize built from the same CMake build. A second build of the C++, so CI does not run it;
# run it on a fresh Debian 12 to check the pip route. VENV=DIR keeps the environment there (default: a
# temporary folder, removed at the end).
set -euo pipefail
source "$(dirname "$0")/common.sh"
exit_with_help_if_asked "$@"

PIP_ROUTE_PACKAGES=(
  build-essential cmake pkg-config git
  libeigen3-dev libigraph-dev libglpk-dev libplfit-dev libpcl-dev
  pybind11-dev python3-dev python3-venv python3-setuptools python3-wheel python3-numpy
  python3-pytest python3-matplotlib
)
missing=()
for p in "${PIP_ROUTE_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

venv="${VENV:-$(mktemp -d)/venv}"
[ -n "${VENV:-}" ] || trap 'rm -rf "$(dirname "$venv")"' EXIT
echo "== virtual environment $venv (/usr/bin/python3, --system-site-packages)"
/usr/bin/python3 -m venv --system-site-packages "$venv"
echo "== pip install --no-build-isolation $PROJECT_DIR"
build="$(dirname "$venv")/cmake-build"
(cd "$PROJECT_DIR" && MAC_REGISTRATION_CMAKE_BUILD_DIR="$build" CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" \
  CMAKE_ARGS="-DMAC_REGISTRATION_WERROR=ON" "$venv/bin/pip" install --no-build-isolation .)
# The tools from the same build, for the tests to compare the module with (the libraries are built already).
echo "== mac_register and mac_relocalize from the same build"
cmake --build "$build" --target mac_register mac_relocalize -j"$(nproc)" >"$build.tools.log" 2>&1 ||
  { tail -n 40 "$build.tools.log"; exit 1; }
export MAC_REGISTER="$build/tools/mac_register" MAC_RELOCALIZE="$build/tools/mac_relocalize"

# From elsewhere: the installed package, not the checkout's sources.
cd "$(dirname "$venv")"
"$venv/bin/python" -c 'import mac_registration as mr; print("== imported", mr.__file__, "kernels:", mr.kernels_in_use())'
echo "== the example"
MPLBACKEND=Agg "$venv/bin/python" "$PROJECT_DIR/examples/register_clouds.py" --picture registered_clouds.png
echo "== the module's tests"
"$venv/bin/python" -m pytest -p no:cacheprovider -q -rs "$PROJECT_DIR/python/tests"
