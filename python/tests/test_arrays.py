"""Arrays in: shapes, dtypes, layouts, NaNs and empties, each taken or refused as README.md, "Python" says."""
import numpy as np
import pytest

import mac_registration as mr
from conftest import repo_path

ROWS = np.loadtxt(repo_path("test/data/redkitchen_24_59/correspondences.txt"))
SOURCE, TARGET = np.ascontiguousarray(ROWS[:, :3]), np.ascontiguousarray(ROWS[:, 3:])
CLOUD = mr.load_cloud(repo_path("data/redkitchen_4_0/source_cloud_bin_4.pcd")).points
CLOUD_TARGET = mr.load_cloud(repo_path("data/redkitchen_4_0/target_cloud_bin_0.pcd")).points


@pytest.fixture(scope="module")
def reference():
    return mr.register_correspondences(SOURCE, TARGET)


def same(result, reference):
    assert result.status == reference.status
    np.testing.assert_array_equal(result.T_target_source, reference.T_target_source)
    np.testing.assert_array_equal(result.inlier_indices, reference.inlier_indices)


def test_the_reference_registers(reference):
    assert reference.success and reference.status == mr.Status.SUCCESS
    assert reference.T_target_source.shape == (4, 4) and reference.T_target_source.dtype == np.float64
    assert reference.inlier_indices.dtype == np.int64 and len(reference.inlier_indices) == reference.counters.inliers
    assert 0 < reference.confidence <= 1 and reference.times.total_ms > 0
    assert not np.isnan(reference.verification.rival_ratio)
    assert np.isnan(reference.verification.aligned_overlap)  # a cloud signal: no clouds here
    assert reference.evidence and all(isinstance(term.log_odds, float) for term in reference.evidence)
    assert "rival_ratio" in reference.verification.as_dict()
    assert "SUCCESS" in repr(reference)


@pytest.mark.parametrize(
    "layout",
    ["fortran", "strided rows", "columns of a wider array", "float32 copy", "list", "big-endian", "longdouble"],
)
def test_every_float_layout_is_read_in_place_or_converted(reference, layout):
    if layout == "fortran":
        source, target = np.asfortranarray(SOURCE), np.asfortranarray(TARGET)
    elif layout == "strided rows":  # every other row of an array twice as long
        source, target = np.repeat(SOURCE, 2, axis=0)[::2], np.repeat(TARGET, 2, axis=0)[::2]
        assert not source.flags.c_contiguous
    elif layout == "columns of a wider array":  # x y z of an x y z intensity array
        wide = np.hstack([ROWS, np.ones((len(ROWS), 1))])
        source, target = wide[:, 0:3], wide[:, 3:6]
    elif layout == "list":
        source, target = SOURCE.tolist(), TARGET.tolist()
    elif layout == "big-endian":
        source, target = SOURCE.astype(">f8"), TARGET.astype(">f8")
    elif layout == "longdouble":
        source, target = SOURCE.astype(np.longdouble), TARGET.astype(np.longdouble)
    else:
        # float32 points are taken as they are: the same as their exact float64 values
        source32, target32 = SOURCE.astype(np.float32), TARGET.astype(np.float32)
        same(mr.register_correspondences(source32, target32),
             mr.register_correspondences(source32.astype(np.float64), target32.astype(np.float64)))
        return
    same(mr.register_correspondences(source, target), reference)


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.uint8, bool, np.complex128, object])
def test_a_non_float_dtype_is_a_type_error(dtype):
    with pytest.raises(TypeError, match=r"source: dtype .* is not a float type"):
        mr.register_correspondences(SOURCE.astype(dtype), TARGET)
    with pytest.raises(TypeError, match=r"target: dtype .* is not a float type"):
        mr.register_clouds(CLOUD, CLOUD.astype(dtype))


@pytest.mark.parametrize("shape", [(10, 2), (10, 4), (30,), (10, 3, 1), (3, 10)])
def test_a_wrong_shape_is_a_value_error(shape):
    with pytest.raises(ValueError, match=r"expected an \(N, 3\) array of points, got shape"):
        mr.register_correspondences(np.zeros(shape), np.zeros(shape))
    with pytest.raises(ValueError, match=r"expected an \(N, 3\) array"):
        mr.register_clouds(np.zeros(shape), CLOUD)


def test_source_and_target_must_pair_up():
    with pytest.raises(ValueError, match="one row per correspondence: 100 and 99 rows"):
        mr.register_correspondences(SOURCE[:100], TARGET[:99])


def test_non_finite_correspondences_are_dropped_and_counted_as_in_cpp(reference):
    source, target = SOURCE.copy(), TARGET.copy()
    holes = np.arange(0, len(source), 97)
    source[holes, 1] = np.nan
    target[holes[::2], 2] = np.inf
    result = mr.register_correspondences(source, target)
    assert result.counters.dropped_non_finite == len(holes)
    assert any("NaN/Inf" in w for w in result.warnings)
    keep = np.setdiff1d(np.arange(len(source)), holes)
    clean = mr.register_correspondences(SOURCE[keep], TARGET[keep])
    np.testing.assert_array_equal(result.T_target_source, clean.T_target_source)
    # the inlier indices are the caller's rows
    np.testing.assert_array_equal(result.inlier_indices, keep[clean.inlier_indices])


def test_non_finite_cloud_points_are_dropped_and_counted():
    source = CLOUD.copy()
    source[::50] = np.nan
    result = mr.register_clouds(source, CLOUD_TARGET)
    assert result.front_end.source_dropped == len(source[::50])
    assert result.front_end.source_points == len(source)


def test_sparse_keyframes_are_described_with_widened_radii():
    # NCLT keyframes (32-beam, thinned to 2-5k points): the outdoor preset's radii grow for them.
    query = mr.load_cloud(repo_path("data/nclt_campus/revisit_query.pcd")).points
    earlier = mr.load_cloud(repo_path("data/nclt_campus/revisit_earlier.pcd")).points
    outdoor = mr.Config(repo_path("config/outdoor_lidar.yaml"))
    widened = mr.register_clouds(query, earlier, outdoor).front_end.support_scale
    assert 1.0 < widened <= 4.0
    as_given = mr.Config(repo_path("config/outdoor_lidar.yaml"), {"features.min_feature_neighbours": 0})
    assert mr.register_clouds(query, earlier, as_given).front_end.support_scale == 1.0


def test_empty_and_unusable_input():
    # Too few correspondences is a result, as registerCorrespondences returns it (mac_register exits 1).
    for count in (0, 2):
        result = mr.register_correspondences(np.zeros((count, 3)), np.zeros((count, 3)))
        assert not result.success and result.status == mr.Status.TOO_FEW_CORRESPONDENCES
        assert not result.has_estimate and np.array_equal(result.T_target_source, np.eye(4))
    # A cloud that cannot be described is invalid input (mac_register exits 2): a ValueError.
    with pytest.raises(ValueError, match="empty"):
        mr.register_clouds(np.zeros((0, 3), np.float32), CLOUD_TARGET)
    with pytest.raises(ValueError, match="0 finite points .* at least 3 are needed"):
        mr.register_clouds(np.full((100, 3), np.nan), CLOUD_TARGET)


def test_arrays_out_are_the_callers_to_keep(reference):
    T = reference.T_target_source
    T[0, 0] = 42.0  # a copy: the result is unchanged
    assert reference.T_target_source[0, 0] != 42.0


def test_a_stop_flag_raised_before_the_call_cancels_it():
    stop = mr.StopFlag()
    stop.set()
    result = mr.register_correspondences(SOURCE, TARGET, stop=stop)
    assert result.status == mr.Status.CANCELLED and not result.success
    result = mr.register_clouds(CLOUD, CLOUD_TARGET, stop=stop)
    assert result.status == mr.Status.CANCELLED
    with pytest.raises(mr.Cancelled):
        mr.describe_map(CLOUD_TARGET, stop=stop)
