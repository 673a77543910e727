"""Config: presets and overrides through the parameter table, refused as the C++ refuses them."""
import numpy as np
import pytest

import mac_registration as mr
from conftest import repo_path, run_tool

CORRESPONDENCES = repo_path("test/data/redkitchen_24_59/correspondences.txt")


def refusal(callable_, *args, **kwargs):
    with pytest.raises(ValueError) as error:
        callable_(*args, **kwargs)
    return str(error.value)


def test_none_is_the_built_in_defaults():
    defaults = mr.Config().as_dict()
    assert defaults == {row["key"]: row["default"] for row in mr.parameters()}
    assert repr(mr.Config()) == "Config(defaults)"
    assert repr(mr.Config(graph_t_cmp=0.995)) == "Config(defaults, graph.t_cmp=0.995)"


def test_a_preset_then_overrides_in_every_form():
    lidar = repo_path("config/outdoor_lidar.yaml")
    assert mr.Config(lidar)["features.voxel_size"] == 0.5
    assert mr.Config(lidar, {"features.voxel_size": 0.3})["features.voxel_size"] == 0.3
    assert mr.Config(lidar, ["features.voxel_size=0.3", "graph.t_cmp=0.95"])["graph.t_cmp"] == 0.95
    assert mr.Config(lidar, features_voxel_size=0.25)["features.voxel_size"] == 0.25
    config = mr.Config(num_threads=1, graph_second_order=False, graph_score="quadratic", features_voxel_size="auto")
    assert config["num_threads"] == 1 and config["graph.second_order"] is False
    assert config["graph.score"] == "quadratic" and config["features.voxel_size"] == 0.0
    assert config["cliques.max_cliques"] == 200000 and isinstance(config["cliques.max_cliques"], int)
    # numpy scalars are numbers like any other
    assert mr.Config(graph_t_cmp=np.float32(0.5), num_threads=np.int64(2))["num_threads"] == 2


def test_an_unknown_key_is_refused_as_mac_register_refuses_it(mac_register):
    message = refusal(mr.Config, None, {"graph.t_cmpp": 0.9})
    assert message == "unknown parameter 'graph.t_cmpp'"
    run = run_tool(mac_register, "--correspondences", CORRESPONDENCES, "--set", "graph.t_cmpp=0.9")
    assert run.returncode == 2 and f"mac_register: {message}\n" in run.stderr
    assert refusal(mr.Config, None, ["graph.t_cmpp=0.9"]) == message
    assert refusal(mr.Config, graph_t_cmpp=0.9) == "unknown parameter 'graph_t_cmpp'"
    with pytest.raises(KeyError):
        mr.Config()["graph.t_cmpp"]


def test_an_out_of_range_value_is_refused_with_the_cpp_message(mac_register):
    message = refusal(mr.Config, graph_t_cmp=1.5)
    assert message.startswith("graph.t_cmp = 1.5 is out of range: must be in (0, 1)")
    run = run_tool(mac_register, "--correspondences", CORRESPONDENCES, "--set", "graph.t_cmp=1.5")
    assert run.returncode == 2 and f"invalid parameters: {message}" in run.stderr
    # the front end's ranges, as registering clouds words them
    message = refusal(mr.Config, features_voxel_size=-1)
    cloud = repo_path("data/redkitchen_4_0/source_cloud_bin_4.pcd")
    run = run_tool(mac_register, cloud, cloud, "--set", "features.voxel_size=-1")
    assert run.returncode == 2 and message in run.stderr


def test_values_of_the_wrong_type_are_refused_with_the_cpp_message(mac_register):
    message = refusal(mr.Config, graph_second_order="maybe")
    assert message == "graph.second_order: 'maybe' is not true/false"
    run = run_tool(mac_register, "--correspondences", CORRESPONDENCES, "--set", "graph.second_order=maybe")
    assert run.returncode == 2 and message in run.stderr
    assert "graph.score" in refusal(mr.Config, graph_score="cubic")
    assert "cliques.max_cliques" in refusal(mr.Config, cliques_max_cliques=-3)
    with pytest.raises(TypeError):
        mr.Config(graph_t_cmp=[0.9])


def test_a_preset_with_an_unknown_key_names_file_and_line(tmp_path):
    preset = tmp_path / "bad.yaml"
    preset.write_text("graph:\n  t_cmp: 0.9\n  t_cmpp: 0.9\n")
    message = refusal(mr.Config, str(preset))
    assert str(preset) + ":3" in message and "t_cmpp" in message
    with pytest.raises(FileNotFoundError):
        mr.register_correspondences(np.zeros((3, 3)), np.zeros((3, 3)), str(tmp_path / "missing.yaml"))


def test_setting_an_item_checks_it_and_keeps_the_config_on_refusal():
    config = mr.Config()
    config["graph.t_cmp"] = 0.995
    assert config["graph.t_cmp"] == 0.995
    with pytest.raises(ValueError, match=r"graph.t_cmp = 2 is out of range"):
        config["graph.t_cmp"] = 2
    assert config["graph.t_cmp"] == 0.995
    copy = config.copy()
    copy["graph.t_cmp"] = 0.9
    assert config["graph.t_cmp"] == 0.995


def test_auto_distances_need_clouds_as_in_cpp(mac_register):
    rows = np.loadtxt(CORRESPONDENCES)
    config = mr.Config(evaluation_inlier_threshold="auto")  # accepted: a cloud registration derives it
    message = refusal(mr.register_correspondences, rows[:, :3], rows[:, 3:], config)
    run = run_tool(mac_register, "--correspondences", CORRESPONDENCES, "--set", "evaluation.inlier_threshold=auto")
    assert run.returncode == 2 and f"mac_register: {message}\n" in run.stderr


def test_a_dict_or_a_preset_path_is_a_config_too():
    rows = np.loadtxt(CORRESPONDENCES)[:500]
    by_config = mr.register_correspondences(rows[:, :3], rows[:, 3:], mr.Config(graph_t_cmp=0.995))
    by_dict = mr.register_correspondences(rows[:, :3], rows[:, 3:], {"graph.t_cmp": 0.995})
    np.testing.assert_array_equal(by_config.T_target_source, by_dict.T_target_source)
    with pytest.raises(TypeError, match="config"):
        mr.register_correspondences(rows[:, :3], rows[:, 3:], 0.995)


def test_the_parameter_table_is_listed():
    table = {row["key"]: row for row in mr.parameters()}
    assert set(table) == set(mr.Config().keys())
    assert table["graph.t_cmp"]["range"] == "in (0, 1)" and table["graph.t_cmp"]["default"] == 0.99
    assert table["graph.score"]["choices"] == ["gaussian", "quadratic"]
    assert "graph.t_cmp = 0.99" in mr.Config().describe()
