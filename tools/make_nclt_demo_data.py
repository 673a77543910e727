#!/usr/bin/env python3
"""Small relocalization demo data from the NCLT campus run in ../shared/data/nclt (see its MANIFEST.md).

  /usr/bin/python3 tools/make_nclt_demo_data.py [--nclt ../shared/data/nclt] [--out data/nclt_campus]

The defaults make the shipped files: a 100 m square around the corner at (-165, -105) in the map frame,
the window ending at revisit keyframe 610 and the unmapped window ending at keyframe 1000.

Writes into --out (all PCD binary_compressed, float32 x y z, metres):
  map.pcd                       the first-pass map (keyframes 0-489 under opti_pose_2, voxel 0.2 m, as
                                tools/make_nclt_tables.py builds it), cropped to a square in the x-y plane
                                and downsampled again; in the run's map frame (coordinates kept)
  query_window.pcd              a window query: keyframes QUERY-15..QUERY joined by the odometry (lidar_pose)
                                in the frame of keyframe QUERY, downsampled
  T_map_query.txt               its ground truth: opti_pose_2 of keyframe QUERY (4x4, maps the query into the map)
  unmapped_query_window.pcd     a window the same way from a place the crop does not cover
  revisit_query.pcd,            a loop-closure pair: revisit keyframe REVISIT and its nearest earlier keyframe
  revisit_earlier.pcd           (revisits.tsv), copied as the run stores them (thinned HDL-32E scans, each in
                                its own body frame)
  T_earlier_query.txt           their relative pose from opti_pose_2 (4x4, maps the query into the earlier scan)
Needs numpy and Open3D.
"""
import argparse
import os
import shutil
import sys

import numpy as np
import open3d as o3d

# The first pass, the window length and the pose rows as the benchmark's tables read them.
from make_nclt_tables import FIRST_PASS_END, WINDOW, matrix_of  # tools/, beside this script


def poses(nclt, first_column):
    """Each keyframe's pose of the 7 columns from `first_column` (5: lidar_pose, 26: opti_pose_2)."""
    rows = np.loadtxt(os.path.join(nclt, "keyframes.txt"))
    return {int(r[0]): matrix_of(*r[first_column:first_column + 7]) for r in rows}


def joined(nclt, frames, pose, reference):
    """The keyframes' points in the frame `reference` (a 4x4 in the poses' frame), as one array."""
    inverse = np.linalg.inv(reference)
    points = []
    for k in frames:
        t = inverse @ pose[k]
        p = np.asarray(o3d.io.read_point_cloud(os.path.join(nclt, "keyframes", "%d.pcd" % k)).points)
        points.append(p @ t[:3, :3].T + t[:3, 3])
    return np.concatenate(points)


def voxel(points, leaf):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return np.asarray(cloud.voxel_down_sample(leaf).points)


def write(path, points):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    o3d.io.write_point_cloud(path, cloud, write_ascii=False, compressed=True)  # x y z float32
    print("wrote %s (%d points, %d bytes)" % (path, len(points), os.path.getsize(path)))


def window(nclt, odometry, q, leaf):
    """Keyframes q-WINDOW+1..q joined by the odometry into the frame of keyframe q, downsampled."""
    return voxel(joined(nclt, range(q - WINDOW + 1, q + 1), odometry, odometry[q]), leaf)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nclt", default=os.path.join("..", "shared", "data", "nclt"))
    parser.add_argument("--out", default=os.path.join("data", "nclt_campus"))
    parser.add_argument("--center", type=float, nargs=2, default=(-165.0, -105.0), help="[m] crop centre, x y")
    parser.add_argument("--side", type=float, default=100.0, help="[m] side of the square crop")
    parser.add_argument("--map-voxel", type=float, default=0.5, help="[m] leaf of the cropped map")
    parser.add_argument("--query", type=int, default=610, help="revisit keyframe the query window ends at")
    parser.add_argument("--unmapped", type=int, default=1000, help="keyframe the unmapped window ends at")
    parser.add_argument("--revisit", type=int, default=559, help="revisit keyframe of the loop-closure pair")
    parser.add_argument("--query-voxel", type=float, default=0.4, help="[m] leaf of the query windows")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    opti, odometry = poses(args.nclt, 26), poses(args.nclt, 5)

    whole = voxel(joined(args.nclt, range(FIRST_PASS_END), opti, np.eye(4)), 0.2)  # map_first_pass.pcd
    inside = np.all(np.abs(whole[:, :2] - args.center) <= args.side / 2, axis=1)
    write(os.path.join(args.out, "map.pcd"), voxel(whole[inside], args.map_voxel))

    assert args.query >= FIRST_PASS_END + WINDOW - 1, "the query window must not hold first-pass keyframes"
    write(os.path.join(args.out, "query_window.pcd"), window(args.nclt, odometry, args.query, args.query_voxel))
    path = os.path.join(args.out, "T_map_query.txt")
    np.savetxt(path, opti[args.query], fmt="%.9f")
    print("wrote %s (opti_pose_2 of keyframe %d)" % (path, args.query))
    write(os.path.join(args.out, "unmapped_query_window.pcd"),
          window(args.nclt, odometry, args.unmapped, args.query_voxel))
    copy_revisit(args.nclt, args.revisit, args.out)
    return 0


def copy_revisit(nclt, query, out):
    """The revisit keyframe `query`, its nearest earlier keyframe and their relative pose, from revisits.tsv."""
    with open(os.path.join(nclt, "revisits.tsv")) as f:
        rows = [line.split("\t") for line in f if line.strip() and not line.startswith("#")]
    row = next((r for r in rows if int(r[0]) == query), None)
    if row is None:
        sys.exit("keyframe %d is not a revisit in %s/revisits.tsv" % (query, nclt))
    earlier = int(row[1])
    for frame, name in ((query, "revisit_query.pcd"), (earlier, "revisit_earlier.pcd")):
        shutil.copyfile(os.path.join(nclt, "keyframes", "%d.pcd" % frame), os.path.join(out, name))
    path = os.path.join(out, "T_earlier_query.txt")
    np.savetxt(path, np.array(row[4].split(), dtype=float).reshape(4, 4), fmt="%.9f")
    print("wrote %s (keyframe %d into keyframe %d)" % (path, query, earlier))


if __name__ == "__main__":
    sys.exit(main())
