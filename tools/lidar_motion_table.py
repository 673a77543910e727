#!/usr/bin/env python3
"""Recall per motion bin of `mac_benchmark pairs --csv` runs on the lidar motion set.

  /usr/bin/python3 tools/lidar_motion_table.py build/lidar_motion/pairs.tsv LABEL=RUN.csv...

Prints one markdown row per run: recall (RE/TE criterion of the run) per translation bin and per yaw bin,
the median end-to-end time (front end + MAC + verification, loading excluded), and the false successes
(status success with a pose outside the criterion) with the largest error among them. The motion of each pair comes from the table's
translation_m and yaw_deg columns (tools/make_lidar_motion_pairs.py).
"""

import csv
import statistics
import sys

TRANSLATION_BINS_M = ((0, 1), (1, 3), (3, 6), (6, 13))
YAW_BINS_DEG = ((0, 0), (30, 60), (90, 135), (180, 180))
STAGES_MS = ("resolution_ms", "downsample_ms", "normals_ms", "fpfh_ms", "matching_ms", "method_total_ms")


def read_motions(table):
    motions = {}
    with open(table) as f:
        rows = csv.DictReader((line for line in f if not line.startswith("#")), delimiter="\t")
        for row in rows:
            motions[row["scene"] + " " + row["name"]] = (float(row["translation_m"]), float(row["yaw_deg"]))
    return motions


def read_run(path, motions):
    pairs = []
    with open(path) as f:
        for row in csv.DictReader(f):
            if row["pair"] not in motions:
                raise ValueError("'%s': pair '%s' is not in the motion table" % (path, row["pair"]))
            t, yaw = motions[row["pair"]]
            recalled = row["recalled"] == "1"
            pairs.append({"t": t, "yaw": yaw, "recalled": recalled,
                          "false_success": row["status"] == "success" and not recalled,
                          "re": float(row["rotation_error_deg"] or "nan"),
                          "te": float(row["translation_error_m"] or "nan"),
                          "ms": sum(float(row[s] or 0) for s in STAGES_MS)})
    return pairs


def fraction(pairs):
    return "%d/%d" % (sum(p["recalled"] for p in pairs), len(pairs)) if pairs else "–"


def row_of(label, pairs):
    cells = [label]
    cells += [fraction([p for p in pairs if lo <= p["t"] < hi]) for lo, hi in TRANSLATION_BINS_M]
    cells += [fraction([p for p in pairs if lo <= p["yaw"] <= hi]) for lo, hi in YAW_BINS_DEG]
    false_successes = [p for p in pairs if p["false_success"]]
    worst = max(false_successes, key=lambda p: (p["te"], p["re"]), default=None)
    cells += [fraction(pairs), "%.0f" % statistics.median(p["ms"] for p in pairs),
              str(len(false_successes)) + ("" if worst is None else " (worst %.1f°, %.2f m)" % (worst["re"], worst["te"]))]
    return "| " + " | ".join(cells) + " |"


def main(argv):
    if any(a in ("-h", "--help") for a in argv):
        print(__doc__)
        return 0
    if len(argv) < 2:
        sys.exit(__doc__)
    motions = read_motions(argv[0])
    header = (["setting"] + ["t %g–%g m" % b for b in TRANSLATION_BINS_M] +
              ["yaw %g–%g°" % b if b[0] != b[1] else "yaw %g°" % b[0] for b in YAW_BINS_DEG] +
              ["all", "median ms", "false successes"])
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for run in argv[1:]:
        label, _, path = run.rpartition("=")
        print(row_of(label or path, read_run(path, motions)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
