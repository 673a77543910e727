#!/usr/bin/python3
"""Open3D 0.16 as the benchmarks' peer, run by mac_benchmark (--baseline open3d / fgr) or by hand.

usage:
  open3d_baseline.py check
  open3d_baseline.py clouds SOURCE TARGET --voxel V [--seed S]
  open3d_baseline.py fgr --distance D CORRESPONDENCES...

clouds: Open3D's own global-registration pipeline on two clouds (.pcd/.ply through Open3D, KITTI .bin
  as float32 x y z intensity): voxel grid of V metres, normals in a 2 V ball (at most 30 neighbours),
  FPFH in a 5 V ball (at most 100 neighbours), then RANSAC on the FPFH matches
  (registration_ransac_based_on_feature_matching: mutual filter on, distance 1.5 V, point-to-point
  estimation without scale, 3-point samples, edge-length checker 0.9 and distance checker 1.5 V,
  at most 100 000 iterations, confidence 0.999) -- the values of Open3D's global registration
  tutorial, in units of its voxel size.
fgr: Fast Global Registration on given correspondences (registration_fgr_based_on_correspondence;
  each file "xs ys zs xt yt zt" a line, correspondence k pairs source point k with target point k):
  absolute scale, maximum_correspondence_distance D metres, Open3D's other defaults (division factor
  1.4, 64 iterations, decreasing mu).

Output, one "key value..." per line (times in ms, wall clock; peak_rss_mb from getrusage's ru_maxrss
of this whole process, interpreter and Open3D included); T is T_target_source, 16 numbers row-major.
clouds: open3d_version, source_points, target_points, source_keypoints, target_keypoints, read_ms
  (not part of the total), downsample_ms, normals_ms, fpfh_ms, registration_ms (matching + RANSAC),
  total_ms, fitness, inlier_rmse, inliers, T, peak_rss_mb.
fgr: open3d_version, then per file: file PATH, correspondences, fgr_ms (the call alone), T; last
  peak_rss_mb.
Exit status 0, 2 on bad arguments or unreadable input, 3 when Open3D cannot be imported.
"""
import argparse
import resource
import sys
import time

MISSING_OPEN3D = 3


def import_open3d():
    try:
        import open3d
    except ImportError as e:
        sys.stderr.write("open3d_baseline: cannot import open3d (%s); install Debian's python3-open3d "
                         "(apt-get install python3-open3d) and run this with /usr/bin/python3\n" % e)
        sys.exit(MISSING_OPEN3D)
    return open3d


def milliseconds_since(start):
    return 1000.0 * (time.perf_counter() - start)


def peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux reports KiB


def print_transform(T):
    print("T " + " ".join("%.12g" % T[r][c] for r in range(4) for c in range(4)))


def read_cloud(o3d, path):
    if path.endswith(".bin"):  # KITTI velodyne scan: float32 x y z intensity per point
        import numpy
        xyzi = numpy.fromfile(path, dtype=numpy.float32)
        if xyzi.size == 0 or xyzi.size % 4 != 0:
            raise ValueError("'%s' is not a KITTI scan (float32 x y z intensity records)" % path)
        cloud = o3d.geometry.PointCloud()
        cloud.points = o3d.utility.Vector3dVector(xyzi.reshape(-1, 4)[:, :3].astype(numpy.float64))
        return cloud
    cloud = o3d.io.read_point_cloud(path)
    if len(cloud.points) == 0:
        raise ValueError("'%s' holds no points or cannot be read" % path)
    return cloud


def describe(o3d, cloud, voxel):
    """The tutorial's preprocessing: keypoints, their normals and FPFH; the time of each step."""
    times = {}
    start = time.perf_counter()
    keypoints = cloud.voxel_down_sample(voxel)
    times["downsample_ms"] = milliseconds_since(start)
    start = time.perf_counter()
    keypoints.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2.0 * voxel, max_nn=30))
    times["normals_ms"] = milliseconds_since(start)
    start = time.perf_counter()
    fpfh = o3d.pipelines.registration.compute_fpfh_feature(
        keypoints, o3d.geometry.KDTreeSearchParamHybrid(radius=5.0 * voxel, max_nn=100))
    times["fpfh_ms"] = milliseconds_since(start)
    return keypoints, fpfh, times


def run_clouds(o3d, args):
    if args.seed is not None:
        o3d.utility.random.seed(args.seed)
    start = time.perf_counter()
    source = read_cloud(o3d, args.source)
    target = read_cloud(o3d, args.target)
    read_ms = milliseconds_since(start)
    source_keypoints, source_fpfh, source_times = describe(o3d, source, args.voxel)
    target_keypoints, target_fpfh, target_times = describe(o3d, target, args.voxel)
    registration = o3d.pipelines.registration
    distance = 1.5 * args.voxel
    start = time.perf_counter()
    result = registration.registration_ransac_based_on_feature_matching(
        source_keypoints, target_keypoints, source_fpfh, target_fpfh, True, distance,
        registration.TransformationEstimationPointToPoint(False), 3,
        [registration.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         registration.CorrespondenceCheckerBasedOnDistance(distance)],
        registration.RANSACConvergenceCriteria(100000, 0.999))
    registration_ms = milliseconds_since(start)
    stages = {key: source_times[key] + target_times[key] for key in source_times}
    stages["registration_ms"] = registration_ms
    print("open3d_version %s" % o3d.__version__)
    print("source_points %d" % len(source.points))
    print("target_points %d" % len(target.points))
    print("source_keypoints %d" % len(source_keypoints.points))
    print("target_keypoints %d" % len(target_keypoints.points))
    print("read_ms %.4f" % read_ms)
    for key in ("downsample_ms", "normals_ms", "fpfh_ms", "registration_ms"):
        print("%s %.4f" % (key, stages[key]))
    print("total_ms %.4f" % sum(stages.values()))
    print("fitness %.6g" % result.fitness)
    print("inlier_rmse %.6g" % result.inlier_rmse)
    print("inliers %d" % len(result.correspondence_set))
    print_transform(result.transformation)
    print("peak_rss_mb %.2f" % peak_rss_mb())


def read_correspondences(np, path):
    rows = np.loadtxt(path, comments="#", ndmin=2)
    if rows.shape[1] != 6:
        raise ValueError("'%s': expected 6 numbers a line (xs ys zs xt yt zt), got %d" % (path, rows.shape[1]))
    return rows


def run_fgr(o3d, args):
    import numpy as np
    option = o3d.pipelines.registration.FastGlobalRegistrationOption(
        use_absolute_scale=True, maximum_correspondence_distance=args.distance)
    print("open3d_version %s" % o3d.__version__)
    for path in args.files:
        rows = read_correspondences(np, path)
        source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(rows[:, :3]))
        target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(rows[:, 3:]))
        index = np.arange(len(rows), dtype=np.int32)
        pairs = o3d.utility.Vector2iVector(np.stack([index, index], axis=1))
        start = time.perf_counter()
        result = o3d.pipelines.registration.registration_fgr_based_on_correspondence(
            source, target, pairs, option)
        fgr_ms = milliseconds_since(start)
        print("file %s" % path)
        print("correspondences %d" % len(rows))
        print("fgr_ms %.4f" % fgr_ms)
        print_transform(result.transformation)
    print("peak_rss_mb %.2f" % peak_rss_mb())


def positive(text):
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError("must be > 0, got %s" % text)
    return value


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    modes = parser.add_subparsers(dest="mode", required=True)
    modes.add_parser("check", help="exit 0 when Open3D can be imported, 3 when not")
    clouds = modes.add_parser("clouds", help="Open3D's pipeline on two clouds")
    clouds.add_argument("source")
    clouds.add_argument("target")
    clouds.add_argument("--voxel", type=positive, required=True, help="voxel size [m]")
    clouds.add_argument("--seed", type=int, help="seed of Open3D's random generator")
    fgr = modes.add_parser("fgr", help="FGR on correspondence files")
    fgr.add_argument("--distance", type=positive, required=True,
                     help="maximum_correspondence_distance [m] (absolute scale)")
    fgr.add_argument("files", nargs="+")
    args = parser.parse_args()
    o3d = import_open3d()
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    if args.mode == "check":
        print("open3d_version %s" % o3d.__version__)
        return 0
    try:
        run_clouds(o3d, args) if args.mode == "clouds" else run_fgr(o3d, args)
    except (OSError, ValueError) as e:
        sys.stderr.write("open3d_baseline: %s\n" % e)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
