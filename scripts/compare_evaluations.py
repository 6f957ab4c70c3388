"""Compare two `vprobot evaluate` tables cell by cell (behaviour-unchanged checks).

Every row of NEW (planner, carrier) must be in OLD; the metric columns they share are compared
(timing columns, which vary from run to run, are left out). Prints the cells that moved and
exits 1 if any did.

Usage:
    python scripts/compare_evaluations.py results/motors/evaluation.csv \
        results/regenerated/motors-evaluation.csv
"""

from __future__ import annotations

import argparse
import csv
import math
import sys

TIMING = {"plan_s", "plan_ms_per_view", "episode_s"}
"""Columns of wall-clock time, not of behaviour."""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    args = parser.parse_args()
    with open(args.old, newline="") as stream:
        old = {(row["planner"], row["carrier"]): row for row in csv.DictReader(stream)}
    with open(args.new, newline="") as stream:
        new = {(row["planner"], row["carrier"]): row for row in csv.DictReader(stream)}
    moved = compared = 0
    for key, row in new.items():
        if key not in old:
            print(f"{key}: not in {args.old}")
            moved += 1
            continue
        for column in sorted((set(row) & set(old[key])) - TIMING - {"planner", "carrier"}):
            before, after = old[key][column], row[column]
            compared += 1
            same = before == after or (before and after and math.isclose(
                float(before), float(after), rel_tol=1e-9, abs_tol=1e-12))
            if not same:
                moved += 1
                print(f"{key} {column}: {before} -> {after}")
    print(f"{len(new)} rows, {compared} cells compared, {moved} moved")
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main())
