#!/usr/bin/env python3
"""Pair tables (mac_benchmark pairs / verify) and a first-pass map from the NCLT campus run in ../shared/data/nclt.

  /usr/bin/python3 tools/make_nclt_tables.py [--nclt ../shared/data/nclt] [--out build/nclt] [--map-voxel 0.2]

Writes into --out:
  revisits.tsv   each revisit keyframe (source) against its nearest earlier keyframe (target), T from revisits.tsv
  loops.tsv      the mapping run's loop closures: keyframe b (source) against keyframe a (target), T = T_ab
  map.tsv        every sixth revisit keyframe against the map of the first pass (T = T_map_query)
  map_first_pass.pcd   keyframes 0-489 under opti_pose_2, voxel-downsampled (what map.tsv's target is)
  relocalize_single.tsv    each revisit keyframe as a query in that map (mac_benchmark relocalize)
  relocalize_windows.tsv   each revisit with the keyframes of the seconds before it (up to WINDOW, none of
                           the first pass) joined into its frame by the odometry (lidar_pose): windows/Q.pcd
  relocalize_*_every6.tsv  every sixth query of each
  revisits_submap.tsv, loops_submap.tsv   the same pairs with the earlier keyframe's submap as the target: the
                       keyframes within SUBMAP of it (none of the last GAP before the source) joined in its
                       frame under opti_pose_2, as LIO-SAM registers a loop candidate: submaps/A_B.pcd
  map_ten_times.pcd    with --larger-map: the first-pass map and 9 mirror images of it, 1-5 km away (a map
                       ten times larger whose look-alikes keep every length but are no rigid copy)
The keyframe files are referenced where they are (their headers say WIDTH 0 HEIGHT 0; mac_registration reads
them with a warning). Needs numpy and Open3D (python3-open3d) for the map.
"""
import argparse
import os
import sys

import numpy as np

FIRST_PASS_END = 490  # keyframes before the run comes back (MANIFEST.md)
WINDOW = 16  # keyframes of a window query: about 16 m of travel
# Keyframes on each side of a loop candidate joined into its submap: LIO-SAM's historyKeyframeSearchNum
# (25); the keyframes here are about 1 m apart.
SUBMAP = 25
GAP = 100  # a revisit or a loop comes back at least this many keyframes later (MANIFEST.md)


def matrix_of(x, y, z, qx, qy, qz, qw):
    """4x4 of a pose given as translation and a Hamilton quaternion (scalar last)."""
    t = np.eye(4)
    t[:3, :3] = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                 [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                 [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
    t[:3, 3] = [x, y, z]
    return t


def row_major(t):
    return " ".join("%.9f" % v for v in np.asarray(t).reshape(-1))


def write_table(path, rows, header="name\tsource_file\ttarget_file\tT", what="pairs"):
    with open(path, "w") as out:
        out.write(header + "\n")
        for row in rows:
            out.write("\t".join(row) + "\n")
    print("wrote %s (%d %s)" % (path, len(rows), what))


def keyframe(nclt, index):
    return os.path.abspath(os.path.join(nclt, "keyframes", "%d.pcd" % index))


def revisit_rows(nclt):
    rows = []
    with open(os.path.join(nclt, "revisits.tsv")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            query, earlier, _, t_map_query, t_earlier_query = line.rstrip("\n").split("\t")
            rows.append((int(query), int(earlier), t_map_query, t_earlier_query))
    return rows


def loop_pairs(nclt):
    """(name, source keyframe, target keyframe, T_target_source) of each loop the mapping run closed."""
    rows = []
    with open(os.path.join(nclt, "loops.txt")) as f:
        for line in f:
            v = line.split()
            if len(v) < 10:
                continue
            a, b = int(v[0]), int(v[1])
            t_ab = matrix_of(*map(float, v[3:10]))
            rows.append(("loop %d<-%d" % (a, b), b, a, row_major(t_ab)))
    return rows


def build_map(nclt, path, voxel):
    import open3d as o3d  # only the map needs it
    points = []
    with open(os.path.join(nclt, "keyframes.txt")) as f:
        for line in f:
            v = line.split()
            index = int(v[0])
            if index >= FIRST_PASS_END:
                continue
            t = matrix_of(*map(float, v[26:33]))  # opti_pose_2, the loop-closed poses the map is built with
            p = np.asarray(o3d.io.read_point_cloud(keyframe(nclt, index)).points)
            points.append(p @ t[:3, :3].T + t[:3, 3])
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.concatenate(points))
    cloud = cloud.voxel_down_sample(voxel)
    o3d.io.write_point_cloud(path, cloud)
    print("wrote %s (%d points, voxel %g m)" % (path, len(cloud.points), voxel))


def build_larger_map(map_path, path, mirrors=9):
    """The map and `mirrors` mirror images of it (x -> -x about its centre, turned by 36 deg steps), the k-th
    centred 0.5 k + 0.5 km from it at 40 k deg: far apart, each place's look-alike is a reflection."""
    import open3d as o3d
    points = np.asarray(o3d.io.read_point_cloud(map_path).points)
    centre = points.mean(axis=0)
    local = points - centre
    parts = [points]
    for k in range(1, mirrors + 1):
        turn, bearing, distance = np.radians(36.0 * k), np.radians(40.0 * k), 500.0 * k + 500.0
        c, s = np.cos(turn), np.sin(turn)
        rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([-1.0, 1.0, 1.0])
        shift = centre + distance * np.array([np.cos(bearing), np.sin(bearing), 0.0])
        parts.append(local @ rotation.T + shift)
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.concatenate(parts))
    o3d.io.write_point_cloud(path, cloud)
    print("wrote %s (%d points: the map and %d mirror images)" % (path, len(cloud.points), mirrors))


def poses(nclt, first_column):
    """Each keyframe's pose of the 7 columns from `first_column` (5: lidar_pose, 26: opti_pose_2)."""
    out = {}
    with open(os.path.join(nclt, "keyframes.txt")) as f:
        for line in f:
            v = line.split()
            out[int(v[0])] = matrix_of(*map(float, v[first_column:first_column + 7]))
    return out


def write_relocalization_table(path, rows):
    write_table(path, rows, "name\tquery\tT_map_query", "queries")


def write_windows(nclt, out_dir, revisits):
    """The window queries: keyframes max(first pass end, q - WINDOW + 1)..q in q's frame, by the odometry."""
    import open3d as o3d
    odometry = poses(nclt, 5)
    os.makedirs(os.path.join(out_dir, "windows"), exist_ok=True)
    rows = []
    for q, _, t_map_query, _ in revisits:
        inverse = np.linalg.inv(odometry[q])
        points = []
        for k in range(max(FIRST_PASS_END, q - WINDOW + 1), q + 1):
            t = inverse @ odometry[k]
            p = np.asarray(o3d.io.read_point_cloud(keyframe(nclt, k)).points)
            points.append(p @ t[:3, :3].T + t[:3, 3])
        cloud = o3d.geometry.PointCloud()
        cloud.points = o3d.utility.Vector3dVector(np.concatenate(points))
        path = os.path.abspath(os.path.join(out_dir, "windows", "%d.pcd" % q))
        o3d.io.write_point_cloud(path, cloud)
        rows.append(("window %d" % q, path, t_map_query))
    return rows


def write_submaps(nclt, out_dir, pairs):
    """Each (name, source id, target id, T) as the source keyframe against the target's submap, in the
    target's frame: keyframes target-SUBMAP..target+SUBMAP older than source-GAP, under opti_pose_2."""
    import open3d as o3d
    optimised = poses(nclt, 26)
    os.makedirs(os.path.join(out_dir, "submaps"), exist_ok=True)
    rows = []
    for name, source, target, t in pairs:
        last = min(target + SUBMAP, source - GAP)
        path = os.path.abspath(os.path.join(out_dir, "submaps", "%d_%d.pcd" % (target, last)))
        if not os.path.exists(path):
            inverse = np.linalg.inv(optimised[target])
            points = []
            for k in range(max(0, target - SUBMAP), last + 1):
                pose = inverse @ optimised[k]
                p = np.asarray(o3d.io.read_point_cloud(keyframe(nclt, k)).points)
                points.append(p @ pose[:3, :3].T + pose[:3, 3])
            cloud = o3d.geometry.PointCloud()
            cloud.points = o3d.utility.Vector3dVector(np.concatenate(points))
            o3d.io.write_point_cloud(path, cloud.voxel_down_sample(0.2))
        rows.append((name + " submap", keyframe(nclt, source), path, t))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nclt", default=os.path.join("..", "shared", "data", "nclt"))
    parser.add_argument("--out", default=os.path.join("build", "nclt"))
    parser.add_argument("--map-voxel", type=float, default=0.2, help="[m] leaf of the map's voxel grid")
    parser.add_argument("--larger-map", action="store_true", help="also write map_ten_times.pcd")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    revisits = revisit_rows(args.nclt)
    pairs = {"revisits": [("rev %d->%d" % (q, e), q, e, t) for q, e, _, t in revisits],
             "loops": loop_pairs(args.nclt)}
    for kind, rows in pairs.items():
        write_table(os.path.join(args.out, kind + ".tsv"),
                    [(name, keyframe(args.nclt, s), keyframe(args.nclt, t), T) for name, s, t, T in rows])
        write_table(os.path.join(args.out, kind + "_submap.tsv"), write_submaps(args.nclt, args.out, rows))
    map_path = os.path.abspath(os.path.join(args.out, "map_first_pass.pcd"))
    write_table(os.path.join(args.out, "map.tsv"),
                [("map %d" % q, keyframe(args.nclt, q), map_path, t) for q, _, t, _ in revisits[::6]])
    build_map(args.nclt, map_path, args.map_voxel)
    if args.larger_map:
        build_larger_map(map_path, os.path.join(args.out, "map_ten_times.pcd"))
    single = [("scan %d" % q, keyframe(args.nclt, q), t) for q, _, t, _ in revisits]
    windows = write_windows(args.nclt, args.out, revisits)
    for name, rows in (("single", single), ("windows", windows)):
        write_relocalization_table(os.path.join(args.out, "relocalize_%s.tsv" % name), rows)
        # every sixth query: for a peer that takes a minute a query
        write_relocalization_table(os.path.join(args.out, "relocalize_%s_every6.tsv" % name), rows[::6])
    return 0


if __name__ == "__main__":
    sys.exit(main())
