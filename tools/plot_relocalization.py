#!/usr/bin/python3
"""Plots `mac_benchmark relocalize` CSVs of one query table against maps of several sizes: the share of
queries localized right, and the median query time with its ranking part, against the map's keypoints.

usage: /usr/bin/python3 tools/plot_relocalization.py KEYPOINTS=RESULTS.csv... --out FILE.png [--title TEXT]

KEYPOINTS is the map's keypoint count, as the run printed it ("map: ... N keypoints"). Needs Debian's
python3-matplotlib (the system python3).
"""
import argparse
import csv
import statistics
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402


def summary(path):
    """(share localized right, median total ms, median ranking ms) of one run."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "ranking_ms" not in rows[0]:
        sys.exit(f"{path}: not a mac_benchmark relocalize CSV")
    right = sum(r["right"] == "1" for r in rows) / len(rows)
    return (right, statistics.median(float(r["total_ms"]) for r in rows),
            statistics.median(float(r["ranking_ms"]) for r in rows))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", help="KEYPOINTS=RESULTS.csv")
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="Relocalization against map size")
    args = parser.parse_args()
    points = []
    for run in args.runs:
        keypoints, _, path = run.partition("=")
        points.append((int(keypoints),) + summary(path))
    points.sort()
    sizes = [p[0] for p in points]
    figure, (recall_axis, time_axis) = plt.subplots(1, 2, figsize=(10, 4))
    recall_axis.plot(sizes, [100 * p[1] for p in points], "o-")
    recall_axis.set(xscale="log", xlabel="map keypoints", ylabel="queries localized right [%]", ylim=(0, 100))
    time_axis.plot(sizes, [p[2] / 1000 for p in points], "o-", label="query (median)")
    time_axis.plot(sizes, [p[3] / 1000 for p in points], "s--", label="of it, ranking the places")
    time_axis.set(xscale="log", yscale="log", xlabel="map keypoints", ylabel="time [s]")
    time_axis.legend()
    for axis in (recall_axis, time_axis):
        axis.grid(True, which="both", alpha=0.3)
    figure.suptitle(args.title)
    figure.tight_layout()
    figure.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
