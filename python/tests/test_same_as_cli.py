"""A Python call and the C++ tools give the same result on the shipped data (README.md, "Python")."""
import numpy as np
import pytest

import mac_registration as mr
from conftest import parse_matrix, printed_inliers, repo_path, run_tool

# The shipped pairs with the preset the README registers each with (None: the built-in defaults).
PAIRS = {
    "indoor": ("data/redkitchen_4_0/source_cloud_bin_4.pcd", "data/redkitchen_4_0/target_cloud_bin_0.pcd", None),
    "lidar": (
        "data/lidar/lidar_source_251371071.pcd",
        "data/lidar/lidar_target_251370668.pcd",
        "config/outdoor_lidar.yaml",
    ),
    "bunny": ("data/bunny/stanford_bun045.ply", "data/bunny/stanford_bun000.ply", "config/object_scan.yaml"),
}


def cli_result(mac_register, *args):
    run = run_tool(mac_register, *args)
    assert run.returncode in (0, 1), run.stderr
    return run.returncode, parse_matrix(run.stdout, "T_target_source"), run.stdout


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_register_clouds_gives_mac_registers_pose(mac_register, name):
    source, target, preset = PAIRS[name]
    args = [repo_path(source), repo_path(target)] + (["--config", repo_path(preset)] if preset else [])
    code, T_cli, stdout = cli_result(mac_register, *args)

    result = mr.register_clouds(
        mr.load_cloud(repo_path(source)), mr.load_cloud(repo_path(target)), repo_path(preset) if preset else None
    )
    assert result.success == (code == 0), result.message
    np.testing.assert_allclose(result.T_target_source, T_cli, rtol=0, atol=1e-9)
    assert result.counters.inliers == printed_inliers(stdout)
    # The front end's matches are what the inlier indices refer to.
    source_matches, target_matches = result.correspondences
    assert source_matches.shape == target_matches.shape == (result.counters.correspondences, 3)
    assert result.inlier_indices.max() < len(source_matches)


def test_register_correspondences_gives_mac_registers_pose(mac_register):
    path = repo_path("test/data/redkitchen_24_59/correspondences.txt")
    code, T_cli, stdout = cli_result(mac_register, "--correspondences", path)

    rows = np.loadtxt(path)
    result = mr.register_correspondences(rows[:, :3], rows[:, 3:])
    assert result.success == (code == 0), result.message
    np.testing.assert_allclose(result.T_target_source, T_cli, rtol=0, atol=1e-9)
    assert result.counters.inliers == printed_inliers(stdout)
    assert result.front_end is None and result.correspondences is None


def test_a_config_with_overrides_is_what_set_gives(mac_register):
    path = repo_path("test/data/redkitchen_24_59/correspondences.txt")
    preset = repo_path("config/indoor_rgbd.yaml")
    code, T_cli, _ = cli_result(
        mac_register, "--correspondences", path, "--config", preset, "--set", "graph.t_cmp=0.995",
        "--set", "graph.second_order=false",
    )
    rows = np.loadtxt(path)
    config = mr.Config(preset, graph_t_cmp=0.995, graph_second_order=False)
    result = mr.register_correspondences(rows[:, :3], rows[:, 3:], config)
    assert result.success == (code == 0)
    np.testing.assert_allclose(result.T_target_source, T_cli, rtol=0, atol=1e-9)


def test_relocalize_gives_mac_relocalizes_pose(mac_relocalize):
    map_file = repo_path("data/lidar/lidar_target_251370668.pcd")
    query_file = repo_path("data/lidar/lidar_source_251371071.pcd")
    preset = repo_path("config/map_relocalization.yaml")
    # A time limit no query reaches: the places registered do not depend on the machine's speed.
    run = run_tool(mac_relocalize, map_file, query_file, "--config", preset, "--set", "relocalization.time_limit=600")
    assert run.returncode in (0, 1), run.stderr

    config = mr.Config(preset, relocalization_time_limit=600)
    described = mr.describe_map(mr.load_cloud(map_file), config)
    assert described.points == 15773 and described.places >= 1
    answer = mr.relocalize(described, mr.load_cloud(query_file))
    assert answer.success == (run.returncode == 0), answer.message
    np.testing.assert_allclose(answer.T_map_query, parse_matrix(run.stdout, "T_map_query"), rtol=0, atol=1e-9)
    assert answer.outcome == (mr.Outcome.LOCALIZED if answer.success else answer.outcome)
    assert answer.candidates and answer.candidates[answer.chosen].registered
    place = answer.candidates[answer.chosen]
    assert place.registration.status in (mr.Status.SUCCESS, mr.Status.UNVERIFIED)


def write_double_pcd(path, points):
    """An ascii PCD of float64 coordinates, as a map in global (UTM) coordinates is stored."""
    header = (
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
        f"WIDTH {len(points)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(points)}\nDATA ascii\n"
    )
    with open(path, "w") as f:
        f.write(header)
        np.savetxt(f, points, fmt="%.17g")


def test_a_map_in_global_coordinates_is_taken_as_mac_relocalize_takes_it(mac_relocalize, tmp_path):
    # The lidar target scan put at a UTM-like place: float32 would space its points 0.5 m apart there.
    shift = np.array([512345.0, 5401234.0, 251.0])
    lidar_map = mr.load_cloud(repo_path("data/lidar/lidar_target_251370668.pcd")).points.astype(np.float64) + shift
    map_file = tmp_path / "utm_map.pcd"
    write_double_pcd(map_file, lidar_map)
    query_file = repo_path("data/lidar/lidar_source_251371071.pcd")
    preset = repo_path("config/map_relocalization.yaml")
    run = run_tool(mac_relocalize, str(map_file), query_file, "--config", preset,
                   "--set", "relocalization.time_limit=600")
    assert run.returncode in (0, 1), run.stderr
    T_cli = parse_matrix(run.stdout, "T_map_query")

    config = mr.Config(preset, relocalization_time_limit=600)
    query = mr.load_cloud(query_file)
    from_array = mr.describe_map(lidar_map, config)  # float64 in the map frame
    loaded = mr.load_map(map_file)
    assert loaded.origin[0] != 0 and np.abs(loaded.points).max() < 1e4
    from_file = mr.describe_map(loaded, config)
    np.testing.assert_array_equal(from_array.origin, from_file.origin)
    for described in (from_array, from_file):
        answer = mr.relocalize(described, query)
        assert answer.success == (run.returncode == 0), answer.message
        np.testing.assert_allclose(answer.T_map_query, T_cli, rtol=0, atol=1e-9)
    assert np.abs(T_cli[:3, 3] - shift).max() < 10.0  # the scan's pose: near the map's own origin
    with pytest.raises(ValueError, match="local frame"):
        mr.register_clouds(query, loaded)
