#!/usr/bin/python3
"""Writes random subsets of one benchmark pair's clouds and a pairs table of them, for time against
cloud size (mac_benchmark pairs OUT/pairs.tsv --baseline open3d).

usage: /usr/bin/python3 tools/benchmark/subsample_pairs.py TABLE.tsv --row K --out-dir DIR
           [--fractions 0.05,0.1,0.25,0.5,1] [--repeats R] [--seed 1] [--label TEXT]

TABLE.tsv is a mac_benchmark pairs table (columns source_file, target_file and the T column; paths
relative to the table). Row K (1-based, data rows only) is read; for each fraction f, each cloud keeps
a uniformly random f of its points (numpy's generator seeded with --seed, the same draw for every run)
and is written to DIR as binary PCD (x y z, float32). DIR/pairs.tsv lists them with the row's ground
truth, each subset R times (default 3: a machine's noise is judged by the median of repeated runs);
the benchmark column is --label (default "subsampled"), the name "<f> x <points> #<repeat>".
Needs python3-open3d (reading .ply/.pcd; KITTI .bin read as float32 x y z intensity).
"""
import argparse
import csv
import os
import sys

import numpy as np


def read_table(path):
    with open(path, newline="") as f:
        lines = [line for line in f if line.strip() and not line.startswith("#")]
    rows = list(csv.reader(lines, delimiter="\t"))
    header = rows[0]
    t_column = next((k for k, name in enumerate(header) if name.startswith("T")), None)
    if t_column is None or "source_file" not in header or "target_file" not in header:
        sys.exit(f"{path}: needs source_file, target_file and a T column")
    return header, rows[1:], t_column


def read_points(o3d, path):
    if path.endswith(".bin"):
        return np.fromfile(path, dtype=np.float32).reshape(-1, 4)[:, :3].astype(np.float64)
    points = np.asarray(o3d.io.read_point_cloud(path).points)
    if len(points) == 0:
        sys.exit(f"'{path}' holds no points or cannot be read")
    return points


def write_pcd(o3d, path, points):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float32).astype(np.float64)))
    if not o3d.io.write_point_cloud(path, cloud, write_ascii=False):
        sys.exit(f"cannot write '{path}'")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table")
    parser.add_argument("--row", type=int, required=True, help="1-based data row of the table")
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--fractions", default="0.05,0.1,0.25,0.5,1")
    parser.add_argument("--repeats", type=int, default=3, help="rows per subset, >= 1")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--label", default="subsampled")
    args = parser.parse_args()
    try:
        import open3d as o3d
    except ImportError as e:
        sys.exit(f"cannot import open3d ({e}): install Debian's python3-open3d")
    header, rows, t_column = read_table(args.table)
    if not 1 <= args.row <= len(rows):
        sys.exit(f"{args.table}: --row {args.row} is not in 1..{len(rows)}")
    row = rows[args.row - 1]
    base = os.path.dirname(os.path.abspath(args.table))
    clouds = {}
    for column in ("source_file", "target_file"):
        path = row[header.index(column)]
        clouds[column] = read_points(o3d, path if os.path.isabs(path) else os.path.join(base, path))
    os.makedirs(args.out_dir, exist_ok=True)
    generator = np.random.default_rng(args.seed)
    lines = ["name\tbenchmark\tsource_file\ttarget_file\tT"]
    for fraction in (float(f) for f in args.fractions.split(",")):
        files = {}
        for column, points in clouds.items():
            keep = max(1, int(round(fraction * len(points))))
            chosen = points[np.sort(generator.choice(len(points), keep, replace=False))]
            files[column] = os.path.abspath(os.path.join(args.out_dir, f"{column[:6]}_{fraction:g}.pcd"))
            write_pcd(o3d, files[column], chosen)
        total = sum(max(1, int(round(fraction * len(p)))) for p in clouds.values())
        for repeat in range(1, max(1, args.repeats) + 1):
            lines.append(f"{fraction:g} x {total} #{repeat}\t{args.label}\t{files['source_file']}\t"
                         f"{files['target_file']}\t{row[t_column]}")
    table = os.path.join(args.out_dir, "pairs.tsv")
    with open(table, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(table)


if __name__ == "__main__":
    main()
