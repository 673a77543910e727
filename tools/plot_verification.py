#!/usr/bin/python3
"""Plots `mac_benchmark verify` CSVs (one row per case) as one PNG.

usage: /usr/bin/python3 tools/plot_verification.py LABEL=RESULTS.csv [LABEL=RESULTS.csv ...] --out FILE.png
       [--min-confidence 0.5]

Left: the confidence of every case that registered, one column per kind of case (right poses, wrong poses
of pairs with a right answer, each kind of negative), the threshold as a line. Right: for each CSV, the
recall (right poses accepted / pairs with a right answer) and the false-accept rate (negatives accepted
with a wrong pose / negatives) as min_confidence goes from 0 to 1.
Needs Debian's python3-matplotlib (the system python3: a pyenv one has no Debian packages).
"""
import argparse
import csv
import random
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt  # noqa: E402


def read_cases(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "confidence" not in rows[0]:
        sys.exit(f"{path}: not a mac_benchmark verify CSV (no 'confidence' column)")
    return rows


def category(row):
    if row["answerable"] == "1":
        return "right pose" if row["correct"] == "1" else "wrong pose"
    return "negative: " + (row["kind"] if row["kind"] != "pair" else row["subset"])


def accepted(row, threshold):
    return row["registered"] == "1" and float(row["confidence"]) >= threshold


def curves(rows, thresholds):
    positives = [r for r in rows if r["answerable"] == "1"]
    negatives = [r for r in rows if r["answerable"] != "1"]
    recall, false_accepts = [], []
    for t in thresholds:
        recall.append(sum(accepted(r, t) and r["correct"] == "1" for r in positives) / max(1, len(positives)))
        false_accepts.append(
            sum(accepted(r, t) and r["correct"] != "1" for r in negatives) / max(1, len(negatives)))
    return recall, false_accepts


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("inputs", nargs="+", help="LABEL=RESULTS.csv")
    parser.add_argument("--out", required=True)
    parser.add_argument("--min-confidence", type=float, default=0.5)
    args = parser.parse_args()
    sets = []
    for spec in args.inputs:
        label, _, path = spec.partition("=")
        if not path:
            sys.exit(f"'{spec}': expected LABEL=RESULTS.csv")
        sets.append((label, read_cases(path)))

    figure, (strip, sweep) = plt.subplots(1, 2, figsize=(15, 6), gridspec_kw={"width_ratios": [3, 2]})
    random.seed(1)
    order = []
    for _, rows in sets:
        for r in rows:
            if r["registered"] == "1" and category(r) not in order:
                order.append(category(r))
    order.sort(key=lambda c: (not c.startswith("right"), not c.startswith("wrong"), c))
    markers = "os^Dv<>"
    for s, (label, rows) in enumerate(sets):
        for r in rows:
            if r["registered"] != "1":
                continue
            c = category(r)
            x = order.index(c) + (s - (len(sets) - 1) / 2) * 0.18 + random.uniform(-0.05, 0.05)
            colour = "tab:green" if c.startswith("right") else "tab:red"
            strip.scatter(x, float(r["confidence"]), s=14, marker=markers[s % len(markers)], color=colour,
                          alpha=0.6, label=label if r is rows[0] else None)
    for s, (label, _) in enumerate(sets):
        strip.scatter([], [], marker=markers[s % len(markers)], color="grey", label=label)
    strip.axhline(args.min_confidence, color="black", linestyle="--", linewidth=1)
    strip.text(len(order) - 0.5, args.min_confidence + 0.02, f"min_confidence {args.min_confidence}",
               ha="right", fontsize=8)
    strip.set_xticks(range(len(order)))
    strip.set_xticklabels(order, rotation=30, ha="right", fontsize=8)
    strip.set_ylabel("confidence")
    strip.set_ylim(-0.03, 1.03)
    strip.set_title("confidence of every registered case (green: right pose, red: wrong)")
    handles, labels = strip.get_legend_handles_labels()
    unique = {l: h for h, l in zip(handles, labels)}
    strip.legend(unique.values(), unique.keys(), fontsize=8, loc="upper right")

    thresholds = [i / 100 for i in range(101)]
    for s, (label, rows) in enumerate(sets):
        recall, false_accepts = curves(rows, thresholds)
        line = sweep.plot(thresholds, recall, label=f"{label}: recall")[0]
        sweep.plot(thresholds, false_accepts, linestyle=":", color=line.get_color(),
                   label=f"{label}: false accepts")
    sweep.axvline(args.min_confidence, color="black", linestyle="--", linewidth=1)
    sweep.set_xlabel("verification.min_confidence")
    sweep.set_ylabel("share")
    sweep.set_ylim(-0.02, 1.02)
    sweep.set_title("recall (solid) and false-accept rate on negatives (dotted)")
    sweep.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
