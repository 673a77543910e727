"""Shared by the Python module's tests: the repository's files and the C++ tools to compare with."""
import os
import re
import shutil
import subprocess

import numpy as np
import pytest

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def repo_path(*parts):
    return os.path.join(REPO, *parts)


def tool(name, variable):
    """A C++ tool: from its environment variable (the catkin test sets them), else on PATH, else None."""
    path = os.environ.get(variable) or shutil.which(name)
    return path if path and os.access(path, os.X_OK) else None


@pytest.fixture(scope="session")
def mac_register():
    path = tool("mac_register", "MAC_REGISTER")
    if path is None:
        pytest.skip("mac_register not built here (the catkin build's test sets MAC_REGISTER)")
    return path


@pytest.fixture(scope="session")
def mac_relocalize():
    path = tool("mac_relocalize", "MAC_RELOCALIZE")
    if path is None:
        pytest.skip("mac_relocalize not built here (the catkin build's test sets MAC_RELOCALIZE)")
    return path


def parse_matrix(text, heading):
    """The 4 x 4 matrix printed after the line starting with `heading` (10 decimals, as formatTransform)."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith(heading):
            rows = [[float(v) for v in lines[i + 1 + r].split()] for r in range(4)]
            return np.array(rows)
    raise AssertionError(f"no '{heading}' in:\n{text}")


def run_tool(*args):
    return subprocess.run([*args], capture_output=True, text=True, timeout=300)


def printed_inliers(stdout):
    match = re.search(r"counters: .*, inliers (\d+),", stdout)
    return int(match.group(1)) if match else None
