#!/usr/bin/python3
"""Plots a `mac_benchmark threedmatch` CSV: registration recall against false-accept rate as
verification.min_confidence varies, one curve per benchmark, from the one run's confidences.

usage: /usr/bin/python3 tools/plot_threedmatch.py RESULTS.csv --out FILE.png [--min-confidence 0.5]
       [--thresholds 0,0.1,...,0.9] [--title TEXT]

At a threshold t, a pair counts as a success when the verification judged its pose (status success or
unverified) with a confidence >= t, as a run at t would have reported it; recall = successes within the
criterion / all pairs of the benchmark, false-accept rate = successes outside it / successes. The thin line
is the sweep in steps of 0.01, the labelled points the thresholds, the ringed one the run's own.
Needs Debian's python3-matplotlib (the system python3: a pyenv one has no Debian packages).
"""
import argparse
import csv
import math
import sys
from collections import OrderedDict

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402


def read_benchmarks(path):
    """{benchmark: (pairs, [(confidence, within criterion) of each judged MAC pose])}."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "confidence" not in rows[0] or "within_criterion" not in rows[0]:
        sys.exit(f"{path}: not a mac_benchmark threedmatch CSV (no 'confidence' or 'within_criterion' column)")
    pairs = OrderedDict()
    judged = {}
    for r in rows:
        pairs.setdefault(r["subset"], set()).add(r["pair"])  # a pair that could not be run is a miss
        if r["method"] != "MAC" or not (r["registered"] == "1" or r["status"] == "unverified"):
            continue
        confidence = float(r["confidence"]) if r["confidence"] else math.nan
        if not math.isnan(confidence):
            judged.setdefault(r["subset"], []).append((confidence, r["within_criterion"] == "1"))
    return OrderedDict((b, (len(p), judged.get(b, []))) for b, p in pairs.items())


def sweep(pairs, judged, thresholds):
    """Recall and false-accept rate [%] at each threshold."""
    recall, false_accepts = [], []
    for t in thresholds:
        accepted = [right for confidence, right in judged if confidence >= t]
        recall.append(100.0 * sum(accepted) / max(1, pairs))
        false_accepts.append(100.0 * (len(accepted) - sum(accepted)) / max(1, len(accepted)))
    return recall, false_accepts


def same_point_runs(thresholds, xs, ys):
    """Consecutive thresholds at the same point, one label each: (first, last, x, y)."""
    runs = []
    for t, x, y in zip(thresholds, xs, ys):
        if runs and (runs[-1][2], runs[-1][3]) == (x, y):
            runs[-1][1] = t
        else:
            runs.append([t, t, x, y])
    return runs


def zoom(ax, points):
    """Limits around `points` (x, y) with a margin: nearby thresholds apart, far ones left out."""
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    dx, dy = max(0.5, 0.15 * (max(xs) - min(xs))), max(0.5, 0.15 * (max(ys) - min(ys)))
    ax.set_xlim(max(0.0, min(xs) - dx), max(xs) + dx)
    ax.set_ylim(min(ys) - dy, max(ys) + dy)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv")
    parser.add_argument("--out", required=True)
    parser.add_argument("--min-confidence", type=float, default=0.5)
    parser.add_argument("--thresholds", default="0,0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9")
    parser.add_argument("--title", default="MAC, our FPFH front end: recall against false accepts")
    args = parser.parse_args()
    thresholds = [float(t) for t in args.thresholds.split(",")]
    benchmarks = read_benchmarks(args.csv)

    figure, axes = plt.subplots(1, len(benchmarks), figsize=(6 * len(benchmarks), 5), squeeze=False)
    for ax, (benchmark, (pairs, judged)), colour in zip(axes[0], benchmarks.items(), ["tab:blue", "tab:orange"] * 9):
        fine_recall, fine_false = sweep(pairs, judged, [i / 100 for i in range(101)])
        ax.plot(fine_false, fine_recall, linewidth=0.8, alpha=0.5, color=colour, label="steps of 0.01")
        recall, false_accepts = sweep(pairs, judged, thresholds)
        ax.plot(false_accepts, recall, "o", color=colour, label="thresholds")
        own_recall, own_false = sweep(pairs, judged, [args.min_confidence])
        ax.plot(own_false, own_recall, "o", markersize=14, markerfacecolor="none", color="black",
                label=f"the run's min_confidence {args.min_confidence:g}")
        # Zero accepts every judged pose: far from the others, it would squeeze them together.
        shown = [(x, y) for t, x, y in zip(thresholds, false_accepts, recall) if t > 0] or \
            list(zip(false_accepts, recall))
        zoom(ax, shown)
        x_max, y_min = ax.get_xlim()[1], ax.get_ylim()[0]
        outside = []
        for first, last, x, y in same_point_runs(thresholds, false_accepts, recall):
            label = f"{first:g}" if first == last else f"{first:g}–{last:g}"
            if x > x_max or y < y_min:
                outside.append(f"{label}: recall {y:.2f} %, false accepts {x:.2f} %")
            else:
                ax.annotate(label, (x, y), textcoords="offset points", xytext=(5, 3), fontsize=8)
        if outside:
            ax.text(0.98, 0.03, "off the axes: " + "; ".join(outside), transform=ax.transAxes, ha="right",
                    fontsize=7)
        ax.set_xlabel("false-accept rate: wrong successes / successes [%]")
        ax.set_ylabel("registration recall [%]")
        ax.grid(alpha=0.3)
        ax.set_title(f"{benchmark}, {pairs} pairs", fontsize=10)
        ax.legend(fontsize=7, loc="upper left")
    figure.suptitle(args.title, fontsize=11)
    figure.tight_layout()
    figure.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
