#!/usr/bin/env python3
"""Builds the outdoor lidar motion set: real scan pairs over a range of translations and headings.

Every pair i < j of a sequence whose reference transform exists (directly or by composing two references
through the sequence's first scan) is kept, so frames skipped give translations up to ~12 m; each source
scan is also turned about its z axis by every yaw of --yaws, so that a loop closure from any heading is
represented. The references are other registrations' estimates (an ICP for the KITTI-like scans and the
Luminar bag, fast_gicp for its pair), not ground truth.

Writes the turned and extracted clouds as PCD (x y z, float32) into --out and a table that
`mac_benchmark pairs` reads (columns scene, i_target, j_source, benchmark, name, target_file,
source_file, T), with two extra columns it ignores: translation_m and yaw_deg (the motion of the pair).

  /usr/bin/python3 tools/make_lidar_motion_pairs.py --out build/lidar_motion
"""

import argparse
import math
import os
import sys

import numpy as np

DEFAULT_YAWS_DEG = (0, 30, 60, 90, 135, 180)


def rz(theta_rad):
    """Rotation about z by theta [rad] as a 4x4 homogeneous matrix."""
    c, s = math.cos(theta_rad), math.sin(theta_rad)
    T = np.eye(4)
    T[0, 0], T[0, 1], T[1, 0], T[1, 1] = c, -s, s, c
    return T


def compose_turned_source(T_target_source, yaw_rad):
    """The reference for the source turned by Rz(yaw): p' = Rz p, so T' = T Rz^-1 maps p' to T p."""
    return T_target_source @ np.linalg.inv(rz(yaw_rad))


def turn_points(points, yaw_rad):
    """The points (N x 3) turned about z by yaw [rad]."""
    R = rz(yaw_rad)[:3, :3]
    return points @ R.T


def row_major(T):
    return " ".join("%.9f" % v for v in T.reshape(-1))


def parse_row_major(fields, context):
    if len(fields) != 16:
        raise ValueError("%s: expected 16 numbers (row-major 4x4), got %d" % (context, len(fields)))
    return np.array([float(v) for v in fields]).reshape(4, 4)


def read_kitti_bin(path):
    data = np.fromfile(path, dtype=np.float32)
    if data.size % 4:
        raise ValueError("'%s' is not a KITTI .bin cloud (float32 x y z intensity)" % path)
    return data.reshape(-1, 4)[:, :3].astype(np.float64)


def read_pcd(path):
    """x y z of an ascii or binary PCD whose fields are all 4-byte floats."""
    with open(path, "rb") as f:
        header = {}
        while True:
            line = f.readline()
            if not line:
                raise ValueError("'%s': the PCD header has no DATA line" % path)
            words = line.decode("ascii", "replace").split()
            if not words or words[0].startswith("#"):
                continue
            header[words[0].upper()] = words[1:]
            if words[0].upper() == "DATA":
                break
        fields = header["FIELDS"]
        if header.get("SIZE") != ["4"] * len(fields) or header.get("TYPE") != ["F"] * len(fields):
            raise ValueError("'%s': only PCDs of 4-byte float fields are read here" % path)
        count = int(header["POINTS"][0])
        kind = header["DATA"][0]
        if kind == "binary":
            data = np.frombuffer(f.read(4 * len(fields) * count), dtype="<f4").reshape(count, len(fields))
        elif kind == "ascii":
            data = np.loadtxt(f, dtype=np.float64, ndmin=2)
        else:
            raise ValueError("'%s': PCD DATA %s is not read here (ascii or binary)" % (path, kind))
    xyz = data[:, [fields.index(c) for c in ("x", "y", "z")]].astype(np.float64)
    return xyz[np.all(np.isfinite(xyz), axis=1)]


def write_pcd(path, points):
    points = np.ascontiguousarray(points, dtype="<f4")
    header = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
              "WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA binary\n" % (len(points), len(points)))
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(points.tobytes())


def read_kitti_references(path):
    """{j: T_0_j} from reference_transforms_OURS_icp.tsv (header: i j fit ... T), all with i = 0."""
    refs = {0: np.eye(4)}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split("\t")
            if line.startswith("#") or not line.strip() or fields[0] == "i":
                continue
            i, j = int(fields[0]), int(fields[1])
            if i != 0:
                raise ValueError("%s:%d: expected references into scan 0" % (path, number))
            refs[j] = parse_row_major(fields[6].split(), "%s:%d" % (path, number))
    return refs


def read_luminar_references(path):
    """{j: T_0_j} from luminar_5_scans_reference.tsv (j, then T row-major)."""
    refs = {0: np.eye(4)}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if line.startswith("#") or not line.strip():
                continue
            fields = line.split()
            refs[int(fields[0])] = parse_row_major(fields[1:], "%s:%d" % (path, number))
    return refs


def extract_bag_clouds(bag_path, topic, out_dir):
    """The bag's PointCloud2 messages on topic as PCDs, in order; returns their paths."""
    import rosbag  # only here: the composition above needs no ROS
    from sensor_msgs import point_cloud2

    paths = []
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=[topic]):
            points = np.array(list(point_cloud2.read_points(msg, ("x", "y", "z"), skip_nans=True)))
            path = os.path.join(out_dir, "luminar_%d.pcd" % len(paths))
            write_pcd(path, points)
            paths.append(path)
    if not paths:
        raise ValueError("'%s' has no messages on %s" % (bag_path, topic))
    return paths


def pairs_of_sequence(scene, refs, files):
    """(scene, i, j, target_file, source_file, T_i_j) for every i < j with a reference into scan 0."""
    keys = sorted(k for k in refs if k in files)
    for a, i in enumerate(keys):
        for j in keys[a + 1:]:
            yield scene, i, j, files[i], files[j], np.linalg.inv(refs[i]) @ refs[j]


def main(argv=None):
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(here)
    lidar = os.path.join(os.path.dirname(repo), "shared", "data", "lidar")
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lidar", default=lidar, help="the shared lidar folder [%(default)s]")
    parser.add_argument("--bag", default=os.path.join(repo, "test", "data", "luminar_5_scans.bag"))
    parser.add_argument("--bag-reference", default=os.path.join(repo, "test", "data", "luminar_5_scans_reference.tsv"))
    parser.add_argument("--topic", default="/luminar_pointcloud")
    parser.add_argument("--yaws", default=",".join(str(y) for y in DEFAULT_YAWS_DEG),
                        help="headings the source is turned by [deg], comma separated [%(default)s]")
    parser.add_argument("--out", default=os.path.join(repo, "build", "lidar_motion"), help="output folder")
    args = parser.parse_args(argv)
    yaws = [float(y) for y in args.yaws.split(",")]
    os.makedirs(args.out, exist_ok=True)

    kitti_dir = os.path.join(args.lidar, "kitti_seq00_unverified")
    kitti_refs = read_kitti_references(os.path.join(kitti_dir, "reference_transforms_OURS_icp.tsv"))
    kitti_files = {j: os.path.join(kitti_dir, "%06d.bin" % j) for j in kitti_refs}
    luminar_refs = read_luminar_references(args.bag_reference)
    luminar_files = dict(enumerate(extract_bag_clouds(args.bag, args.topic, args.out)))
    gicp_dir = os.path.join(args.lidar, "fast_gicp")
    with open(os.path.join(gicp_dir, "relative.txt")) as f:
        gicp_T = parse_row_major(f.read().split(), os.path.join(gicp_dir, "relative.txt"))

    base = list(pairs_of_sequence("kitti00", kitti_refs, kitti_files))
    base += list(pairs_of_sequence("luminar", luminar_refs, luminar_files))
    base.append(("fast_gicp", 251370668, 251371071, os.path.join(gicp_dir, "251370668.pcd"),
                 os.path.join(gicp_dir, "251371071.pcd"), gicp_T))
    subsets = {"kitti00": "KITTI-ICP-ref", "luminar": "Luminar-ICP-ref", "fast_gicp": "gicp-ref"}

    table = os.path.join(args.out, "pairs.tsv")
    turned = {}
    with open(table, "w") as out:
        out.write("# Lidar motion set: real scans, reference transforms of other registrations (ICP, fast_gicp),\n"
                  "# NOT ground truth; sources turned about z by yaw_deg. Built by tools/make_lidar_motion_pairs.py.\n")
        out.write("scene\ti_target\tj_source\tbenchmark\tname\ttarget_file\tsource_file\tT\ttranslation_m\tyaw_deg\n")
        for scene, i, j, target, source, T in base:
            for yaw in yaws:
                source_file = source
                if yaw != 0:
                    key = (source, yaw)
                    if key not in turned:
                        points = read_kitti_bin(source) if source.endswith(".bin") else read_pcd(source)
                        stem = os.path.splitext(os.path.basename(source))[0]
                        turned[key] = os.path.join(args.out, "%s_%s_yaw%g.pcd" % (scene, stem, yaw))
                        write_pcd(turned[key], turn_points(points, math.radians(yaw)))
                    source_file = turned[key]
                T_turned = compose_turned_source(T, math.radians(yaw))
                name = "%s->%s yaw %g" % (j, i, yaw)
                out.write("%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%.3f\t%g\n" % (
                    scene, i, j, subsets[scene], name, os.path.abspath(target), os.path.abspath(source_file),
                    row_major(T_turned), np.linalg.norm(T[:3, 3]), yaw))
    print("%d pairs (%d scan pairs x %d yaws): %s" % (len(base) * len(yaws), len(base), len(yaws), table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
