"""The package's Python side: the functions around the extension module _mac and the records' repr.

Kept out of __init__.py, which catkin's devel space runs through a relay (exec of its text): code here
keeps its file name in tracebacks.
"""


import os as _os
from typing import NamedTuple as _NamedTuple

try:
    from . import _mac
except ImportError as _error:  # a catkin build without the module: the messages still import
    _mac = None
    _mac_import_error = _error

# What the package exports: its functions, and the extension module's classes where it loaded.
_FUNCTIONS = [
    "Cloud",
    "describe_map",
    "load_cloud",
    "load_map",
    "register_clouds",
    "register_correspondences",
    "relocalize",
]
_EXTENSION_NAMES = [
    "Alternative",
    "Cancelled",
    "Config",
    "Counters",
    "DescribedMap",
    "EvidenceTerm",
    "FineAlignment",
    "FrontEndStats",
    "Outcome",
    "PlaceCandidate",
    "RelocalizationResult",
    "Result",
    "StageTimes",
    "Status",
    "StopFlag",
    "VerificationSignals",
    "kernels_in_use",
    "parameters",
]
__all__ = _FUNCTIONS + (_EXTENSION_NAMES if _mac is not None else [])


def _require_module():
    if _mac is None:
        raise ImportError(
            "mac_registration's extension module _mac was not built or cannot be loaded "
            f"({_mac_import_error}); build the package with pybind11-dev installed "
            "(catkin: -DMAC_REGISTRATION_PYTHON=ON, the default), or `pip install --no-build-isolation .`"
        )
    return _mac


class Cloud(_NamedTuple):
    """A cloud read by load_cloud() or load_map(): its points, where its sensor was, what it was read despite."""

    points: "object"  # (N, 3) float32 [m]: the file's coordinates less `origin` (NaN points kept)
    viewpoint: "object"  # (3,) float64 [m], in the points' frame: a PCD's VIEWPOINT, else the origin
    warnings: list  # a sentence for each fault of the file it was read despite
    origin: "object"  # (3,) float64 [m]: where the points' frame lies in the file's (load_cloud: zero)


def load_cloud(path):
    """Reads a .pcd, .ply or KITTI .bin cloud as mac_register does (loadCloud, features/cloud_io.hpp).

    Returns a Cloud; register_clouds() and the others take it as it is, viewpoint included. Raises OSError
    naming the file and the reason when it is missing or malformed.
    """
    points, viewpoint, warnings, origin = _require_module()._load_cloud(_os.fspath(path), False)
    return Cloud(points, viewpoint, list(warnings), origin)


def load_map(path):
    """Reads a map as mac_relocalize does (loadLocalCloud): one in global coordinates (UTM, stored in double)
    comes in a local frame, its origin in `Cloud.origin`, which describe_map() takes along."""
    points, viewpoint, warnings, origin = _require_module()._load_cloud(_os.fspath(path), True)
    return Cloud(points, viewpoint, list(warnings), origin)


def _config(config):
    """None (the built-in defaults), a Config, a preset file, or a dict of overrides of the defaults."""
    if config is None or isinstance(config, _require_module().Config):
        return config
    if isinstance(config, (str, bytes, _os.PathLike)):
        path = _os.fspath(config)
        if not _os.path.isfile(path):
            raise FileNotFoundError(f"preset '{path}' does not exist")
        return _mac.Config(path)
    if isinstance(config, dict):
        return _mac.Config(None, config)
    raise TypeError(
        f"config: expected a Config, a preset path or a dict of overrides, got {type(config).__name__}"
    )


def _points_and_viewpoint(cloud, viewpoint):
    if isinstance(cloud, Cloud):
        if cloud.origin is not None and any(cloud.origin):
            raise ValueError(
                f"a Cloud in a local frame (origin {list(cloud.origin)}, from load_map) goes to describe_map; "
                "elsewhere give its points in one frame: cloud.points + cloud.origin"
            )
        return cloud.points, cloud.viewpoint if viewpoint is None else viewpoint
    return cloud, viewpoint


def register_correspondences(source, target, config=None, *, stop=None):
    """Registers putative correspondences: row i of `source` matches row i of `target` ((N, 3) each, metres).

    The C++ registerCorrespondences(). `config`: a Config, a preset file, a dict of overrides, or None for
    the built-in defaults (mac_register's without --config). Rows with a NaN or Inf are dropped and
    counted (result.counters.dropped_non_finite). Returns a Result, success or not; raises ValueError
    where mac_register exits 2 (invalid parameters or input, message as the C++ words it), TypeError for
    a non-float dtype. `stop`: a StopFlag another thread may set to end it (status CANCELLED).
    """
    return _require_module()._register_correspondences(source, target, _config(config), stop=stop)


def register_clouds(source, target, config=None, *, source_viewpoint=None, target_viewpoint=None, stop=None):
    """Registers two clouds with the PCL front end then MAC: T_target_source maps `source` into `target`.

    The C++ registerClouds(), as `mac_register SOURCE TARGET`. `source`, `target`: (N, 3) and (M, 3)
    arrays [m] (NaN points are dropped and counted) or Clouds from load_cloud(). The viewpoints (where each
    sensor was, for the free-space verification) default to a Cloud's, else the frame's origin. Returns a
    Result whose `correspondences` are the front end's matches its inlier_indices refer to; raises
    ValueError for invalid parameters or an unusable cloud (fewer than 3 finite points, empty).
    """
    source, source_viewpoint = _points_and_viewpoint(source, source_viewpoint)
    target, target_viewpoint = _points_and_viewpoint(target, target_viewpoint)
    return _require_module()._register_clouds(
        source,
        target,
        _config(config),
        source_viewpoint=source_viewpoint,
        target_viewpoint=target_viewpoint,
        stop=stop,
    )


def describe_map(map_points, config=None, *, map_origin=None, stop=None):
    """Describes a map cloud once (keypoints, FPFH, the places' grid) for relocalize(): a DescribedMap.

    The C++ describeMap(). `map_points`: (N, 3) [m] in the map frame, z up (a float64 array in global
    coordinates is taken to a local frame as mac_relocalize takes a map file: the median, rounded, where
    the coordinates go beyond 10 km), or the points less `map_origin` when that is given, or a Cloud from
    load_map() (its origin along). Every pose of relocalize()'s answers is in the map frame. `config` as
    register_clouds()'s (config/map_relocalization.yaml is the lidar map preset); an auto voxel size is
    refused.
    """
    if isinstance(map_points, Cloud):
        map_points, map_origin = map_points.points, map_points.origin if map_origin is None else map_origin
    return _require_module()._describe_map(map_points, _config(config), map_origin=map_origin, stop=stop)


def relocalize(map, query_points, config=None, *, search_centre=None, search_radius=None, viewpoint=None, stop=None):
    """Localizes a query cloud (its own frame) in a DescribedMap: a RelocalizationResult with T_map_query.

    The C++ relocalize(), as mac_relocalize. `config` defaults to the one the map was described with;
    another must describe alike (voxel size, radii). `search_centre` (x, y) and `search_radius` [m], given
    together, rank only the places within that radius (a prior, as rviz's pose estimate gives).
    """
    query_points, viewpoint = _points_and_viewpoint(query_points, viewpoint)
    return _require_module()._relocalize(
        map,
        query_points,
        _config(config),
        search_centre=search_centre,
        search_radius=search_radius,
        viewpoint=viewpoint,
        stop=stop,
    )


# ---- the classes and helpers of the extension module, with a repr and as_dict() for the plain records

def _as_dict(self):
    return {name: getattr(self, name) for name in type(self)._fields}


def _record_repr(self):
    fields = ", ".join(f"{name}={getattr(self, name)!r}" for name in type(self)._fields if name != "covariance")
    return f"{type(self).__name__}({fields})"


def _result_repr(self):
    lines = [
        f"Result({self.status.name}: {self.message})",
        "T_target_source =",
        *("  " + " ".join(f"{v:10.4f}" for v in row) for row in self.T_target_source),
        f"inliers {len(self.inlier_indices)} of {self.counters.correspondences} correspondences, "
        f"confidence {self.confidence:.2f}, {self.times.total_ms:.0f} ms",
    ]
    lines += [f"warning: {w}" for w in self.warnings]
    return "\n".join(lines)


def _relocalization_repr(self):
    return (
        f"RelocalizationResult({self.outcome.name}: {self.message or 'localized'}, "
        f"confidence {self.confidence:.2f}, {len(self.candidates)} places, {self.total_ms:.0f} ms)"
    )


if _mac is not None:
    from ._mac import (  # noqa: E402,F401
        Alternative,
        Cancelled,
        Config,
        Counters,
        DescribedMap,
        EvidenceTerm,
        FineAlignment,
        FrontEndStats,
        Outcome,
        PlaceCandidate,
        RelocalizationResult,
        Result,
        StageTimes,
        Status,
        StopFlag,
        VerificationSignals,
        kernels_in_use,
        parameters,
    )

    for _record in (Alternative, Counters, EvidenceTerm, FineAlignment, FrontEndStats, StageTimes, VerificationSignals):
        _record.as_dict = _as_dict
        _record.__repr__ = _record_repr
    Result.__repr__ = _result_repr
    RelocalizationResult.__repr__ = _relocalization_repr
    del _record

