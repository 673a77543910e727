#!/usr/bin/python3
"""Chooses the anchors and slopes of the verification's fitted evidence terms (inlier planarity, fine
alignment move, fine alignment not settled; src/core/verification.cpp) from labelled outcomes, and
measures the choice by leaving one group of cases out at a time.

usage: /usr/bin/python3 tools/fit_verification_terms.py GROUP=CSV... [--cost 10]

Each CSV is a `mac_benchmark verify ... --csv` table; GROUP names its cases' group, or is `scene` to group
3DMatch cases by their scene (the first word of the case name). Every registered case (success or
unverified) is a row, right where the table's `correct` column says so and the case has an answer (a
negative, `answerable` 0, is wrong whatever pose it ends at: its correspondences hold none, so a fine
alignment that lands at the right pose from them is luck). The other evidence terms stay as they are
(their sum is read from the `evidence` column); the three fitted ones are recomputed for every candidate
on a grid, and a case counts as accepted where the total log-odds is >= 0 (verification.min_confidence
0.5). The candidate chosen minimises `cost` x wrong accepted - right accepted: first on all groups but one,
scored on the one left out (each group in turn), then on all of them (the values to use).
Needs numpy (Debian's python3-numpy).
"""
import argparse
import csv
import itertools
import math
import sys

import numpy as np

FITTED = ("inlier_planarity", "fine_alignment_move", "fine_alignment_converged")
# As src/core/verification.cpp: no move term where the fine pose keeps this many of the correspondences'
# inliers per inlier at their own pose (kMoveFollowed).
MOVE_FOLLOWED = 0.8

# The candidates: (relative planarity free from, slope per e-fold below it, move free up to [tau], slope per
# tau beyond it, log-odds when the fine alignment did not settle). Relative planarity: the inliers' planarity
# as a share of all matched source points' (inlier_planarity / scene_planarity).
GRID = list(
    itertools.product(
        [0.01, 0.02, 0.05, 0.1, 0.2],
        [0.0, 1.0, 2.0, 4.0, 8.0],
        [1.0, 1.5, 2.0, 3.0],
        [0.0, 0.5, 1.0, 2.0, 4.0],
        [0.0, 0.5, 1.0, 2.0, 4.0],
    )
)


def number(row, key, missing=math.nan):
    try:
        return float(row[key])
    except (KeyError, ValueError):
        return missing


def base_log_odds(row):
    """The sum of the evidence terms that are not fitted here."""
    total = 0.0
    for item in row["evidence"].split():
        signal, value = item.rsplit(":", 1)
        if signal not in FITTED:
            total += float(value)
    return total


def read_cases(specs):
    rows = []
    for spec in specs:
        group, _, path = spec.partition("=")
        if not path:
            sys.exit("expected GROUP=CSV, got " + spec)
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                if row["registered"] != "1":
                    continue
                row["group"] = row["name"].split()[0] if group == "scene" else group
                rows.append(row)
    if not rows:
        sys.exit("no registered case in the tables")
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("tables", nargs="+", metavar="GROUP=CSV")
    parser.add_argument("--cost", type=float, default=5.0, help="right poses one wrong success is worth")
    args = parser.parse_args()
    rows = read_cases(args.tables)
    right = np.array([r["correct"] == "1" and r.get("answerable") != "0" for r in rows])
    base = np.array([base_log_odds(r) for r in rows])
    planarity = np.array(
        [max(number(r, "inlier_planarity"), 1e-9) / max(number(r, "scene_planarity"), 1e-9) for r in rows]
    )
    move = np.array([number(r, "fine_alignment_move") for r in rows])
    settled = np.array([number(r, "fine_alignment_converged") for r in rows])
    followed = np.array([number(r, "fine_alignment_support") >= MOVE_FOLLOWED for r in rows])
    groups = np.array([r["group"] for r in rows])

    def accepted(candidate):
        free_planarity, planarity_slope, free_move, move_slope, unsettled = candidate
        log_odds = base.copy()
        measured = ~np.isnan(planarity)
        log_odds[measured] -= planarity_slope * np.maximum(
            0.0, np.log(free_planarity / np.maximum(planarity[measured], 1e-9))
        )
        measured = ~np.isnan(move) & ~followed
        log_odds[measured] -= move_slope * np.maximum(0.0, move[measured] - free_move)
        log_odds[settled == 0.0] -= unsettled
        return log_odds >= 0.0

    decisions = [accepted(c) for c in GRID]

    def best(within):
        costs = [args.cost * np.sum(d & within & ~right) - np.sum(d & within & right) for d in decisions]
        return int(np.argmin(costs))

    names = sorted(set(groups))
    held_out = np.zeros(len(rows), bool)
    print("left out | chosen (relative planarity free, slope, move free [tau], slope, unsettled)")
    for name in names:
        choice = best(groups != name)
        held_out[groups == name] = decisions[choice][groups == name]
        print("%s | %s" % (name, GRID[choice]))
    choice = best(np.ones(len(rows), bool))
    print("all | %s\n" % (GRID[choice],))
    print("| group | cases | right, other terms alone | wrong, other terms alone | right, left out | wrong, left out "
          "| right, all | wrong, all |")
    print("|---|---|---|---|---|---|---|---|")
    before = base >= 0.0
    for name in names:
        g = groups == name
        counts = [np.sum(d & g & right) for d in (before,)] + [np.sum(before & g & ~right)]
        counts += [np.sum(held_out & g & right), np.sum(held_out & g & ~right)]
        counts += [np.sum(decisions[choice] & g & right), np.sum(decisions[choice] & g & ~right)]
        print("| %s | %d | %s |" % (name, np.sum(g), " | ".join(str(int(c)) for c in counts)))


if __name__ == "__main__":
    main()
