#!/usr/bin/env python3
"""Registers two clouds from Python, prints the result and draws the aligned clouds into a picture.

    python3 examples/register_clouds.py                        # the shipped indoor pair, built-in defaults
    python3 examples/register_clouds.py SOURCE TARGET --config config/outdoor_lidar.yaml --picture out.png

numpy in, numpy out: the clouds are (N, 3) arrays (here read with mac_registration.load_cloud; any array of
float32 or float64 coordinates in metres will do), the result's T_target_source a 4 x 4 array that maps
source points into the target's frame. The picture (matplotlib, written to a file) shows the clouds from
above before and after: the target in grey, the source in orange.
"""
import argparse
import os

import numpy as np

import mac_registration as mr

HERE = os.path.dirname(os.path.abspath(__file__))
PAIR = os.path.join(HERE, "..", "data", "redkitchen_4_0")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", default=os.path.join(PAIR, "source_cloud_bin_4.pcd"))
    parser.add_argument("target", nargs="?", default=os.path.join(PAIR, "target_cloud_bin_0.pcd"))
    parser.add_argument("--config", help="a preset (config/*.yaml); default: the built-in defaults")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a parameter")
    parser.add_argument("--picture", default="registered_clouds.png", help="where to write the picture")
    args = parser.parse_args()

    source, target = mr.load_cloud(args.source), mr.load_cloud(args.target)
    config = mr.Config(args.config, args.set)
    result = mr.register_clouds(source, target, config)

    print(result)  # status, T_target_source, inliers, confidence, time
    print(f"front end: {result.front_end.source_keypoints} / {result.front_end.target_keypoints} keypoints, "
          f"{result.counters.correspondences} correspondences; "
          f"time {result.times.front_end_ms:.0f} ms front end + {result.times.total_ms - result.times.front_end_ms:.0f} ms MAC")
    if not result.success and result.alternatives:
        for alternative in result.alternatives:
            print(f"  competing pose: {alternative.rotation_deg:.0f} deg away, score ratio {alternative.score_ratio:.2f}")

    T = result.T_target_source
    aligned = source.points @ T[:3, :3].T.astype(np.float32) + T[:3, 3].astype(np.float32)
    draw(source.points, target.points, aligned, result, args.picture)
    print(f"picture: {os.path.abspath(args.picture)}")
    return 0 if result.success else 1


def draw(source, target, aligned, result, path):
    import matplotlib

    matplotlib.use("Agg")  # a file, no window
    import matplotlib.pyplot as plt

    def thin(points, at_most=6000):  # every k-th point: enough to see, quick to draw
        points = points[np.isfinite(points).all(axis=1)]
        return points[:: max(1, len(points) // at_most)]

    # Seen along the target's least spread direction (from above for a scan of a floor or a street).
    centre = np.nanmean(target, axis=0)
    _, _, axes_of_spread = np.linalg.svd(thin(target) - centre, full_matrices=False)
    view = axes_of_spread[:2].T  # the two directions of largest spread

    figure, axes = plt.subplots(1, 2, figsize=(12, 6), constrained_layout=True)
    for ax, moved, title in ((axes[0], source, "as given"), (axes[1], aligned, f"aligned: {result.status.name}")):
        t, s = (thin(target) - centre) @ view, (thin(moved) - centre) @ view
        ax.scatter(t[:, 0], t[:, 1], s=2, c="0.35", alpha=0.45, linewidths=0, label="target")
        ax.scatter(s[:, 0], s[:, 1], s=2, c="tab:orange", alpha=0.45, linewidths=0, label="source")
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("[m]")
        ax.legend(loc="upper right", markerscale=12)
    figure.suptitle(
        f"{len(result.inlier_indices)} inliers of {result.counters.correspondences} correspondences, "
        f"confidence {result.confidence:.2f}"
    )
    figure.savefig(path, dpi=110)
    plt.close(figure)


if __name__ == "__main__":
    raise SystemExit(main())
