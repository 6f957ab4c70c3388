"""Compare two `vprobot evaluate` tables cell by cell (behaviour-unchanged checks).

Every row of NEW (episode, planner and carrier in an episodes table; planner and carrier in a
summary) must be in OLD; the metric columns they share are compared
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
from collections.abc import Sequence

TIMING = {"plan_s", "plan_ms_per_view", "episode_s"}
"""Columns of wall-clock time, not of behaviour."""


def moved_cells(old: Sequence[dict[str, str]], new: Sequence[dict[str, str]],
                key: Sequence[str]) -> tuple[list[str], int]:
    """The cells of `new` that differ from `old`, rows matched by the `key` columns.

    Returns:
        One line per moved cell and per row of `new` missing from `old`; and the number of
        cells compared.
    """
    before = {tuple(row[name] for name in key): row for row in old}
    after = {tuple(row[name] for name in key): row for row in new}
    lines: list[str] = []
    compared = 0
    for name, row in after.items():
        if name not in before:
            lines.append(f"{name}: not in the old table")
            continue
        for column in sorted((set(row) & set(before[name])) - TIMING - set(key)):
            was, now = before[name][column], row[column]
            compared += 1
            if not _same(was, now):
                lines.append(f"{name} {column}: {was} -> {now}")
    return lines, compared


def _same(was: str, now: str) -> bool:
    """Equal text, or numbers equal to rounding (a CSV float may be written differently)."""
    if was == now:
        return True
    try:
        return math.isclose(float(was), float(now), rel_tol=1e-9, abs_tol=1e-12)
    except ValueError:
        return False


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    args = parser.parse_args()
    tables = []
    for path in (args.old, args.new):
        with open(path, newline="") as stream:
            tables.append(list(csv.DictReader(stream)))
    # An episodes table has a row per episode, planner and carrier; a summary per planner and
    # carrier.
    key = (("episode", "planner", "carrier") if tables[1] and "episode" in tables[1][0]
           else ("planner", "carrier"))
    lines, compared = moved_cells(*tables, key)
    for line in lines:
        print(line)
    print(f"{len(tables[1])} rows, {compared} cells compared, {len(lines)} moved")
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
