"""The package: where it imports from, the ROS messages beside it, the example, the relocalization's options."""
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import mac_registration as mr
from conftest import REPO, repo_path


def test_the_module_is_the_packages_extension():
    assert mr._mac is not None and mr._mac.__name__ == "mac_registration._mac"
    with open(repo_path("package.xml")) as f:
        assert mr.__version__ == re.search(r"<version>(.*)</version>", f.read()).group(1)
    assert mr.kernels_in_use()
    assert all(hasattr(mr, name) for name in mr.__all__)


@pytest.mark.skipif(not os.environ.get("MAC_REGISTRATION_CATKIN"), reason="a catkin devel space only")
def test_the_messages_import_beside_the_module():
    from mac_registration.msg import RegistrationResult
    from mac_registration.srv import Register

    assert RegistrationResult.UNVERIFIED == int(mr.Status.UNVERIFIED)
    assert RegistrationResult.TOO_FEW_INLIERS == int(mr.Status.TOO_FEW_INLIERS)
    assert Register._type == "mac_registration/Register"


def test_the_statuses_are_the_messages_constants():
    with open(repo_path("msg/RegistrationResult.msg")) as f:
        constants = dict(re.findall(r"^uint8 ([A-Z_]+) = (\d+)", f.read(), re.M))
    for status in mr.Status.__members__.values():
        assert int(constants[status.name]) == int(status)
    assert mr.Status.TOO_FEW_INLIERS.text == "too few inliers"


def test_a_search_area_needs_a_centre_and_a_radius():
    config = mr.Config(repo_path("config/map_relocalization.yaml"), relocalization_time_limit=600)
    lidar_map = mr.load_cloud(repo_path("data/lidar/lidar_target_251370668.pcd"))
    query = mr.load_cloud(repo_path("data/lidar/lidar_source_251371071.pcd"))
    described = mr.describe_map(lidar_map, config)
    assert described.keypoints.shape[1] == 3 and described.bytes > 0 and described.describe_ms > 0
    assert described.config.as_dict() == config.as_dict()
    with pytest.raises(ValueError, match="search_centre"):
        mr.relocalize(described, query, search_radius=10.0)
    far = mr.relocalize(described, query, search_centre=(1e4, 1e4), search_radius=5.0)
    assert not far.success and far.outcome == mr.Outcome.NOT_LOCALIZED and not far.candidates
    near = mr.relocalize(described, query, search_centre=(0.0, 0.0), search_radius=50.0)
    anywhere = mr.relocalize(described, query)
    assert near.outcome == anywhere.outcome
    np.testing.assert_array_equal(near.T_map_query, anywhere.T_map_query)
    assert "RelocalizationResult(" in repr(anywhere)


def test_load_cloud_reads_as_the_tools_read():
    cloud = mr.load_cloud(repo_path("data/lidar/lidar_source_251371071.pcd"))
    assert cloud.points.shape == (15950, 3) and cloud.points.dtype == np.float32
    assert cloud.viewpoint.shape == (3,) and cloud.warnings == []
    with pytest.raises(OSError, match="missing.pcd"):
        mr.load_cloud(repo_path("data/missing.pcd"))


def test_the_example_registers_the_shipped_pair_and_draws_it(tmp_path):
    pytest.importorskip("matplotlib")
    picture = tmp_path / "pair.png"
    run = subprocess.run(
        [sys.executable, os.path.join(REPO, "examples", "register_clouds.py"), "--picture", str(picture)],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "T_target_source" in run.stdout and "SUCCESS" in run.stdout
    assert picture.stat().st_size > 10000
    with open(picture, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"


def test_without_the_extension_module_the_package_still_imports(tmp_path):
    # A catkin build without the module (MAC_REGISTRATION_PYTHON=OFF, or a failed load): the messages must
    # still import, and the module's names say why they are missing.
    package = tmp_path / "mac_registration"
    package.mkdir()
    for name in ("__init__.py", "_api.py"):
        (package / name).write_text(open(os.path.join(REPO, "python", "mac_registration", name)).read())
    (package / "msg").mkdir()
    (package / "msg" / "__init__.py").write_text("RegistrationResult = 'the message'\n")
    code = (
        "import mac_registration as mr\n"
        "from mac_registration.msg import RegistrationResult\n"
        "assert RegistrationResult == 'the message'\n"
        "try:\n"
        "    mr.Config\n"
        "except ImportError as e:\n"
        "    print('ImportError:', e)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert run.returncode == 0, run.stderr
    assert "ImportError: mac_registration's extension module _mac was not built" in run.stdout
