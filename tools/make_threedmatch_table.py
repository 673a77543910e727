#!/usr/bin/python3
"""Writes one pairs table (the format `mac_benchmark pairs` and `verify` read) of every 3DMatch and 3DLoMatch
gt.log pair whose two fragments are present: what `mac_benchmark verify` needs to label every pair of the
benchmark with its verification signals (tools/fit_verification_terms.py reads the CSV it writes).

usage: /usr/bin/python3 tools/make_threedmatch_table.py FRAGMENTS_ROOT BENCHMARKS_ROOT --out TABLE.tsv

FRAGMENTS_ROOT/<scene>/cloud_bin_<k>.ply, BENCHMARKS_ROOT/<3DMatch|3DLoMatch>/<scene>/gt.log. A gt.log record
is a line `i j n` and the 4 x 4 matrix that maps fragment j into fragment i: the table's target is fragment i,
its source fragment j, its T that matrix (T_target_source). Scenes without fragments are named and skipped.
"""
import argparse
import os
import sys

BENCHMARKS = ("3DMatch", "3DLoMatch")


def gt_log_records(path):
    """(i, j, the 16 numbers of the matrix as text) for each record of a gt.log."""
    with open(path) as f:
        lines = [line.split() for line in f if line.strip()]
    if len(lines) % 5:
        sys.exit(f"{path}: {len(lines)} non-empty lines, not records of 5")
    for k in range(0, len(lines), 5):
        header, rows = lines[k], lines[k + 1 : k + 5]
        if len(header) < 2 or any(len(r) != 4 for r in rows):
            sys.exit(f"{path}: record at line {k + 1} is not 'i j n' and four rows of four")
        yield int(header[0]), int(header[1]), " ".join(v for r in rows for v in r)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fragments_root")
    parser.add_argument("benchmarks_root")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    rows, skipped = [], set()
    for benchmark in BENCHMARKS:
        folder = os.path.join(args.benchmarks_root, benchmark)
        for scene in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
            gt_log = os.path.join(folder, scene, "gt.log")
            if not os.path.isfile(gt_log):
                continue
            fragments = os.path.join(args.fragments_root, scene)
            for i, j, matrix in gt_log_records(gt_log):
                target = os.path.join(fragments, f"cloud_bin_{i}.ply")
                source = os.path.join(fragments, f"cloud_bin_{j}.ply")
                if not (os.path.isfile(target) and os.path.isfile(source)):
                    skipped.add(scene)
                    continue
                rows.append((scene, str(i), str(j), benchmark, target, source, matrix))
    if not rows:
        sys.exit("no gt.log pair with both fragments present")
    with open(args.out, "w") as f:
        f.write("scene\ti_target\tj_source\tbenchmark\ttarget_file\tsource_file\tT\n")
        for row in rows:
            f.write("\t".join(row) + "\n")
    print(f"{len(rows)} pairs -> {args.out}")
    if skipped:
        print("pairs skipped, fragments missing: " + " ".join(sorted(skipped)))


if __name__ == "__main__":
    main()
