#!/usr/bin/python3
"""Plots a mac_benchmark CSV (one row per pair and method) as one PNG.

usage: /usr/bin/python3 tools/plot_benchmark.py RESULTS.csv [--out RESULTS.png] [--title TEXT]

Three panels: registration recall per subset and method; each pair's rotation and translation error
against the inlier ratio of its correspondences (failures at the top edge); the median time of each stage.
Needs Debian's python3-matplotlib (the system python3: a pyenv one has no Debian packages).
"""
import argparse
import csv
import math
import statistics
import sys
from collections import OrderedDict

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402

FRONT_END = ["resolution_ms", "downsample_ms", "normals_ms", "fpfh_ms", "matching_ms"]
METHOD_STAGES = ["graph_ms", "second_order_ms", "clique_search_ms", "selection_ms", "hypotheses_ms",
                 "evaluation_ms", "refinement_ms", "verification_ms"]


def read_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "recalled" not in rows[0]:
        sys.exit(f"{path}: not a mac_benchmark CSV (no 'recalled' column)")
    return rows


def as_float(text):
    try:
        return float(text)
    except ValueError:
        return math.nan


def recall_table(rows):
    """{subset: {method: (recalled, pairs)}}; a pair that could not be run is a miss for every method."""
    methods = list(OrderedDict.fromkeys(r["method"] for r in rows if r["method"]))
    pairs = OrderedDict()
    for r in rows:
        pairs.setdefault((r["subset"], r["pair"]), {})[r["method"]] = r["recalled"] == "1"
    subsets = list(OrderedDict.fromkeys(subset for subset, _ in pairs))
    groups = subsets + (["all"] if len(subsets) > 1 else [])
    table = OrderedDict((g, OrderedDict((m, [0, 0]) for m in methods)) for g in groups)
    for (subset, _), outcome in pairs.items():
        for group in (subset, "all") if len(subsets) > 1 else (subset,):
            for m in methods:
                table[group][m][0] += int(outcome.get(m, False))
                table[group][m][1] += 1
    return table, methods


def plot_recall(ax, table, methods):
    width = 0.8 / max(1, len(methods))
    for k, m in enumerate(methods):
        xs = [i + k * width for i in range(len(table))]
        values = [100.0 * table[s][m][0] / table[s][m][1] for s in table]
        bars = ax.bar(xs, values, width, label=m)
        for bar, s in zip(bars, table):
            hit, total = table[s][m]
            ax.annotate(f"{hit}/{total}", (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                        ha="center", va="bottom", fontsize=8)
    ax.set_xticks([i + width * (len(methods) - 1) / 2 for i in range(len(table))])
    ax.set_xticklabels(list(table))
    ax.set_ylim(0, 110)
    ax.set_ylabel("registration recall [%]")
    ax.legend()


def plot_errors(ax, rows, methods):
    for m, marker in zip(methods, "os^dv"):
        mine = [r for r in rows if r["method"] == m]
        ratios = [100.0 * max(as_float(r["inlier_ratio"]), 1e-3) for r in mine]
        # a method without a transform (NaN error) is drawn at the top edge
        errors = [min(as_float(r["rotation_error_deg"]), 180.0) if not math.isnan(as_float(r["rotation_error_deg"]))
                  else 180.0 for r in mine]
        colors = ["tab:green" if r["recalled"] == "1" else "tab:red" for r in mine]
        ax.scatter(ratios, errors, c=colors, marker=marker, label=m, alpha=0.7, edgecolors="k", linewidths=0.3)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("inlier ratio of the correspondences [%]")
    ax.set_ylabel("rotation error [deg] (green: recalled)")
    ax.legend()


def median_of(rows, column):
    values = [as_float(r.get(column, "nan")) for r in rows]  # older CSVs lack verification_ms
    values = [v for v in values if not math.isnan(v)]
    return statistics.median(values) if values else 0.0


def plot_times(ax, rows, methods):
    """Stacked medians: the front end's stages, then the method's (a baseline reports only its total)."""
    per_method = {m: [r for r in rows if r["method"] == m] for m in methods}
    bottom = {m: 0.0 for m in methods}
    colors = iter(plt.get_cmap("tab20").colors)
    for column in FRONT_END + METHOD_STAGES:
        values = [median_of(per_method[m], column) for m in methods]
        if not any(values):
            continue
        ax.bar(methods, values, bottom=[bottom[m] for m in methods], label=column[:-3], color=next(colors))
        for m, v in zip(methods, values):
            bottom[m] += v
    totals = [median_of(per_method[m], "method_total_ms")
              if not any(median_of(per_method[m], c) for c in METHOD_STAGES) else 0.0 for m in methods]
    if any(totals):
        ax.bar(methods, totals, bottom=[bottom[m] for m in methods], color="tab:gray", label="method (total)")
    ax.set_ylabel("median time per stage [ms]")
    ax.legend(fontsize=7)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv")
    parser.add_argument("--out", help="PNG to write (default: the CSV's name with .png)")
    parser.add_argument("--title", default="")
    args = parser.parse_args()
    rows = read_rows(args.csv)
    table, methods = recall_table(rows)
    ran = [r for r in rows if r["method"]]
    fig, axes = plt.subplots(1, 3, figsize=(16, 5))
    plot_recall(axes[0], table, methods)
    plot_errors(axes[1], ran, methods)
    plot_times(axes[2], ran, methods)
    fig.suptitle(args.title or args.csv)
    fig.tight_layout()
    out = args.out or (args.csv.rsplit(".", 1)[0] + ".png")
    fig.savefig(out, dpi=100)
    print(out)


if __name__ == "__main__":
    main()
