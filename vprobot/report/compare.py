"""Two `vprobot evaluate` tables compared cell by cell (`vprobot report compare`): the
behaviour-unchanged check.

Every row of the new table (episode, planner and carrier in an episodes table; planner and
carrier in a summary) must be in the old one; the metric columns they share are compared, the
timing columns left out (they vary from run to run).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from vprobot.files.atomic import read_table

TIMING = {"plan_s", "plan_ms_per_view", "episode_s"}
"""Columns of wall-clock time, not of behaviour."""
EPISODE_KEY = ("episode", "planner", "carrier")
"""What names a row of an episodes table."""
SUMMARY_KEY = ("planner", "carrier")
"""What names a row of a summary table."""


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a CSV table (`vprobot.files.atomic.read_table`).

    Raises:
        OSError: If it cannot be read.
        ValueError: If it is not UTF-8 text or a row is damaged.
    """
    return read_table(path)[1]


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


def compare_tables(old: Path, new: Path) -> tuple[list[str], int, int]:
    """Compare two tables of the same kind, both episodes tables or both summaries.

    Returns:
        The moved cells (`moved_cells`), the rows of `new` and the cells compared.

    Raises:
        ValueError: If a table has no rows (nothing would be compared), is damaged, or lacks a
            column that names the rows of `new` (one is an episodes table and the other a
            summary, or neither is an evaluation table).
        OSError: If a table cannot be read.
    """
    tables = [read_rows(old), read_rows(new)]
    for path, rows in zip((old, new), tables, strict=True):
        if not rows:
            raise ValueError(f"{path} has no rows (empty, or a header only): nothing to "
                             f"compare; give two tables of `vprobot evaluate`")
    # An episodes table has a row per episode, planner and carrier; a summary per planner and
    # carrier.
    key = EPISODE_KEY if "episode" in tables[1][0] else SUMMARY_KEY
    for path, rows in zip((old, new), tables, strict=True):
        missing = [name for name in key if name not in rows[0]]
        if missing:
            raise ValueError(f"{path} has no column {missing[0]!r}; give two episodes tables "
                             "or two summaries of `vprobot evaluate`")
    lines, compared = moved_cells(tables[0], tables[1], key)
    return lines, len(tables[1]), compared
