#!/usr/bin/python3
"""Plots mac_benchmark CSVs as PNGs.

usage: /usr/bin/python3 tools/plot_benchmark.py RESULTS.csv [--out RESULTS.png] [--title TEXT]
       /usr/bin/python3 tools/plot_benchmark.py --scaling SYNTHETIC.csv --out PNG [--title TEXT]
       /usr/bin/python3 tools/plot_benchmark.py --points PAIRS.csv [PAIRS.csv...] [--connect] --out PNG

RESULTS.csv (pairs, gtlog, sets modes: one row per pair and method): three panels, registration recall
per subset and method; each pair's rotation and translation error against the inlier ratio of its
correspondences (failures at the top edge); the median time of each stage.
--scaling (the synthetic mode's CSV, with --baseline fgr for the FGR line): median time against the
number of correspondences, one panel per inlier ratio, ours stacked stage by stage, FGR's total beside it.
--points (pairs CSVs with --baseline open3d): each pair's total time (front end + registration) against
the number of points of its two clouds (the median of pairs of the same size), ours and Open3D; --connect joins each file's pairs in order of
size (a sweep of one pair, see tools/benchmark/subsample_pairs.py).
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


SYNTHETIC_STAGES = [("graph_ms", "graph"), ("second_order_ms", "SOG"), ("clique_search_ms", "cliques"),
                    ("selection_ms", "selection"), ("hypotheses_ms", "hypotheses"), ("evaluation_ms", "evaluation"),
                    ("refinement_ms", "refinement"), ("verification_ms", "verification")]


def read_csv(path, required):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or required not in rows[0]:
        sys.exit(f"{path}: not the expected mac_benchmark CSV (no '{required}' column)")
    return rows


def plot_scaling(path, out, title):
    """Time against N per inlier ratio: ours stage by stage (stacked), FGR's total as a line."""
    rows = read_csv(path, "n")
    ratios = sorted({float(r["inlier_ratio"]) for r in rows})
    fig, axes = plt.subplots(1, len(ratios), figsize=(4.5 * len(ratios), 4.5), squeeze=False)
    colors = plt.get_cmap("tab10").colors
    for ax, ratio in zip(axes[0], ratios):
        mine = sorted((r for r in rows if float(r["inlier_ratio"]) == ratio), key=lambda r: int(r["n"]))
        n = [int(r["n"]) for r in mine]
        stacks = [[as_float(r.get(column, "0")) for r in mine] for column, _ in SYNTHETIC_STAGES]
        ax.stackplot(n, stacks, labels=[label for _, label in SYNTHETIC_STAGES], colors=colors, alpha=0.85)
        ax.plot(n, [as_float(r["total_ms"]) for r in mine], "k-", linewidth=1, label="ours, total")
        fgr = [as_float(r.get("fgr_ms", "")) for r in mine]
        if any(not math.isnan(v) for v in fgr):
            ax.plot(n, fgr, "r--o", markersize=3, label="FGR (Open3D)")
        ax.set_xscale("log")
        ax.set_xlabel("correspondences N")
        ax.set_title(f"{100 * ratio:g} % inliers")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("median time [ms]")
    axes[0][-1].legend(fontsize=7, loc="upper left")
    fig.suptitle(title or "time against N, synthetic sets (ours stacked per stage)")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    print(out)


def plot_points(paths, out, title, connect):
    """Each pair's total time against the points of its two clouds, ours against Open3D; `connect` joins
    each file's pairs in order of size (for a sweep of one pair's subsets)."""
    fig, ax = plt.subplots(figsize=(7, 5))
    styles = {"MAC": ("tab:blue", "ours (FPFH + MAC)"), "Open3D": ("tab:orange", "Open3D (FPFH + RANSAC)")}
    for path, marker in zip(paths, "os^dv"):
        rows = read_csv(path, "total_ms")
        for method, (color, label) in styles.items():
            mine = [r for r in rows if r["method"] == method]
            if not mine:
                continue
            # pairs of the same size (a sweep's repeats): their median
            by_size = OrderedDict()
            for r in sorted(mine, key=lambda r: int(r["source_points"]) + int(r["target_points"])):
                by_size.setdefault(int(r["source_points"]) + int(r["target_points"]), []).append(
                    as_float(r["total_ms"]))
            points = list(by_size)
            ax.plot(points, [statistics.median(v) for v in by_size.values()], color=color, marker=marker, alpha=0.8,
                    markeredgecolor="k", markeredgewidth=0.3, linewidth=0.8 if connect else 0,
                    label=f"{label}, {path.rsplit('/', 1)[-1]}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("points of the two clouds as read")
    ax.set_ylabel("front end + registration per pair [ms]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(title or "clouds in: time against cloud size")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    print(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", nargs="?")
    parser.add_argument("--out", help="PNG to write (default: the CSV's name with .png)")
    parser.add_argument("--title", default="")
    parser.add_argument("--scaling", metavar="SYNTHETIC_CSV", help="time against N (synthetic mode's CSV)")
    parser.add_argument("--points", metavar="PAIRS_CSV", nargs="+", help="time against cloud size")
    parser.add_argument("--connect", action="store_true",
                        help="--points: join each file's pairs by size (a sweep, e.g. subsample_pairs.py)")
    args = parser.parse_args()
    if args.scaling or args.points:
        if not args.out:
            parser.error("--scaling and --points need --out")
        if args.scaling:
            plot_scaling(args.scaling, args.out, args.title)
        else:
            plot_points(args.points, args.out, args.title, args.connect)
        return
    if not args.csv:
        parser.error("a results CSV, --scaling or --points is needed")
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
