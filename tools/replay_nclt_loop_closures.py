#!/usr/bin/env python3
"""The loop-closure bridge's questions on the NCLT campus run, answered by mac_benchmark: what a SLAM stack
running scripts/loop_closure_bridge.py over this drive would have been told.

  source ../mac_registration_ws/devel/setup.bash   # the bridge imports the package's messages
  /usr/bin/python3 tools/replay_nclt_loop_closures.py [--nclt ../shared/data/nclt] [--out build/nclt_bridge] \\
      [--benchmark ../mac_registration_ws/devel/lib/mac_registration/mac_benchmark] [--config config/outdoor_lidar.yaml]

Each keyframe, in order, goes through the bridge's own functions with the bridge's defaults: kept when 1 m
of odometry (`lidar_pose`) from the last one, its candidates the 3 nearest earlier keyframes within 15 m by
odometry and 30 s older, each asked as its keyframe and as its submap (25 keyframes each side, joined by
the odometry, 0.2 m). Every question becomes a row of a pair table (the truth from `opti_pose_2`), which
mac_benchmark verify answers; a keyframe's answer is then its best verified candidate, as
~register_candidates orders them. Prints the loops reported, right and wrong (RE <= 5 deg, TE <= 0.6 m), and
how many keyframes that truly come back within 5 m of one 100 keyframes older got a loop.
"""
import argparse
import csv
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
sys.path.insert(0, HERE)
import rospy  # noqa: E402
from loop_closure_bridge import Keyframe, candidates, far_enough, submap  # noqa: E402
from make_nclt_tables import keyframe, poses, row_major, write_table  # noqa: E402

KEYFRAME_DISTANCE, SEARCH_RADIUS, MIN_TIME_GAP, MAX_CANDIDATES = 1.0, 15.0, 30.0, 3  # the bridge's defaults
SUBMAP_KEYFRAMES, SUBMAP_VOXEL = 25, 0.2
REVISIT_DISTANCE, REVISIT_GAP = 5.0, 100  # MANIFEST.md's revisits: within 5 m of a keyframe 100 older


def stamps(nclt):
    with open(os.path.join(nclt, "keyframes.txt")) as f:
        return {int(v[0]): float(v[1]) for v in (line.split() for line in f)}


def read_points(path):
    import open3d as o3d
    return np.asarray(o3d.io.read_point_cloud(path).points)


def write_points(path, points):
    import open3d as o3d
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(points)
    o3d.io.write_point_cloud(path, cloud)


def questions(nclt, out_dir):
    """The table's rows (name, source file, target file, T truth), the kept keyframes' ids and the truth."""
    odometry, truth, times = poses(nclt, 5), poses(nclt, 26), stamps(nclt)
    os.makedirs(os.path.join(out_dir, "submaps"), exist_ok=True)
    kept, ids, rows = [], [], []
    written = {}
    for index in sorted(odometry):
        if not far_enough(kept, odometry[index], KEYFRAME_DISTANCE):
            continue
        current = Keyframe(rospy.Time.from_sec(times[index]), odometry[index],
                           read_points(keyframe(nclt, index)), len(kept))
        for old in candidates(kept, current, SEARCH_RADIUS, MIN_TIME_GAP, MAX_CANDIDATES):
            old_id = ids[old.index]
            t = row_major(np.linalg.inv(truth[old_id]) @ truth[index])
            rows.append(("kf %d<-%d keyframe" % (old_id, index), keyframe(nclt, index), keyframe(nclt, old_id), t))
            joined = submap(kept, old.index, current, SUBMAP_KEYFRAMES, MIN_TIME_GAP, SUBMAP_VOXEL)
            if joined is None:
                continue
            around = kept[max(0, old.index - SUBMAP_KEYFRAMES):old.index + SUBMAP_KEYFRAMES + 1]
            key = (old.index, sum((current.stamp - k.stamp).to_sec() >= MIN_TIME_GAP for k in around))
            if key not in written:
                written[key] = os.path.abspath(os.path.join(out_dir, "submaps", "%d_%d.pcd" % key))
                write_points(written[key], joined)
            rows.append(("kf %d<-%d submap" % (old_id, index), keyframe(nclt, index), written[key], t))
        kept.append(current)
        ids.append(index)
    return rows, ids, truth


def revisiting(ids, truth):
    """The kept keyframes within REVISIT_DISTANCE of a kept keyframe at least REVISIT_GAP older (truth)."""
    out = set()
    for i, a in enumerate(ids):
        for b in ids[:i]:
            if a - b >= REVISIT_GAP and np.linalg.norm(truth[a][:3, 3] - truth[b][:3, 3]) <= REVISIT_DISTANCE:
                out.add(a)
                break
    return out


def summarize(csv_path, ids, truth):
    answers = {}
    for r in csv.DictReader(open(csv_path)):
        new = int(r["name"].split("<-")[1].split()[0])
        answers.setdefault(new, []).append(r)
    asked = len(answers)
    loops = {}
    for new, rs in answers.items():
        verified = [r for r in rs if r["success"] == "1"]
        if verified:
            loops[new] = max(verified, key=lambda r: float(r["confidence"]))
    right = [n for n, r in loops.items() if r["correct"] == "1"]
    wrong = [n for n, r in loops.items() if r["correct"] != "1"]
    back = revisiting(ids, truth)
    print("keyframes kept: %d; asked about (candidates by odometry): %d; questions: %d" %
          (len(ids), asked, sum(len(rs) for rs in answers.values())))
    named = ", ".join(loops[n]["name"] for n in wrong)
    print("loops reported: %d, right %d, WRONG %d%s" %
          (len(loops), len(right), len(wrong), ": " + named if wrong else ""))
    for kind in ("keyframe", "submap"):
        n = sum(1 for r in loops.values() if r["name"].endswith(kind))
        print("  of them answered by the %s: %d" % (kind, n))
    print("keyframes that come back within %g m of one %d older (truth): %d, with a right loop: %d" %
          (REVISIT_DISTANCE, REVISIT_GAP, len(back), len(back & set(right))))
    return 1 if wrong else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nclt", default=os.path.join("..", "shared", "data", "nclt"))
    parser.add_argument("--out", default=os.path.join("build", "nclt_bridge"))
    parser.add_argument("--benchmark", default=os.path.join("..", "mac_registration_ws", "devel", "lib",
                                                            "mac_registration", "mac_benchmark"))
    parser.add_argument("--config", default=os.path.join("config", "outdoor_lidar.yaml"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows, ids, truth = questions(args.nclt, args.out)
    table = os.path.join(args.out, "questions.tsv")
    write_table(table, rows)
    answers = os.path.join(args.out, "answers.csv")
    with open(os.path.join(args.out, "answers.log"), "w") as log:
        subprocess.run([args.benchmark, "verify", table, "--config", args.config, "--csv", answers],
                       stdout=log, stderr=subprocess.STDOUT, check=True)
    return summarize(answers, ids, truth)


if __name__ == "__main__":
    sys.exit(main())
