"""The Python package mac_registration: `pip install --no-build-isolation .` (README.md, "Python").

Builds the extension module mac_registration._mac with CMake (the repository's CMakeLists.txt with
MAC_REGISTRATION_PYTHON_ONLY: the core, the parameter table and the PCL front end, no ROS) from Debian's
packages: cmake, pybind11-dev, python3-dev, libpcl-dev, libigraph-dev, libeigen3-dev. catkin reads the same
file (catkin_python_setup) for the package's Python sources; in a catkin build, CMake builds the module.
"""
import os
import re
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = os.path.dirname(os.path.abspath(__file__))


def package_version():
    """The version of package.xml: one number for the catkin package and the Python one."""
    with open(os.path.join(HERE, "package.xml"), encoding="utf-8") as f:
        return re.search(r"<version>\s*([^<\s]+)\s*</version>", f.read()).group(1)


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    """Configures the repository with CMake and builds the module's target alone, into the folder setuptools
    packs. CMAKE_ARGS adds options (e.g. -DMAC_REGISTRATION_WERROR=ON); CMAKE_BUILD_PARALLEL_LEVEL sets
    the jobs (default: the machine's cores); MAC_REGISTRATION_CMAKE_BUILD_DIR the build folder (default:
    setuptools' build/temp.*/cmake)."""

    def build_extension(self, ext):
        target = os.path.abspath(self.get_ext_fullpath(ext.name))
        out_dir = os.path.dirname(target)
        build_dir = os.path.abspath(
            os.environ.get("MAC_REGISTRATION_CMAKE_BUILD_DIR") or os.path.join(self.build_temp, "cmake")
        )
        os.makedirs(out_dir, exist_ok=True)
        configure = [
            "cmake",
            "-S",
            HERE,
            "-B",
            build_dir,
            "-DCMAKE_BUILD_TYPE=Release",
            "-DMAC_REGISTRATION_PYTHON_ONLY=ON",
            "-DMAC_REGISTRATION_PYTHON_OUTPUT_DIR=" + out_dir,
            "-DPYTHON_EXECUTABLE=" + sys.executable,
        ] + os.environ.get("CMAKE_ARGS", "").split()
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        subprocess.check_call(configure)
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "mac_registration_python", "-j", jobs])
        if not os.path.isfile(target):
            raise RuntimeError(f"CMake did not write {target}")


# catkin's install step runs this file with CATKIN_BINARY_DIR set: there CMake has built the module and
# installs it itself, and setuptools installs the Python sources only.
in_catkin = bool(os.environ.get("CATKIN_BINARY_DIR"))

setup(
    name="mac_registration",
    version=package_version(),
    description="Global point cloud registration with maximal cliques (MAC): the C++ core and PCL front end",
    license="BSD-3-Clause",
    packages=["mac_registration"],
    package_dir={"": "python"},
    ext_modules=[] if in_catkin else [CMakeExtension("mac_registration._mac")],
    cmdclass={} if in_catkin else {"build_ext": CMakeBuild},
    install_requires=[] if in_catkin else ["numpy"],
    python_requires=">=3.8",
)
