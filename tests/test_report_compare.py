"""`vprobot report compare`: two evaluation tables compared cell by cell, timing columns left
out, exit 1 when a cell moved."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest

from vprobot.cli import main
from vprobot.evaluation import CURVE_COLUMNS, EPISODE_COLUMNS, EPISODES_NAME


def _row(episode: int, acquisitions: int, plan_s: float) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(EPISODE_COLUMNS, "")
    row.update({"episode": episode, "planner": "bscp", "carrier": "robot", "part": "m.stl",
                "seed": 0, "coverage_pct": 90.0, "acquisitions": acquisitions,
                "requested": acquisitions + 1, "failed_requests": 1, "success": True,
                "cycle_time_s": 10.0, "paper_m": 1.0, "plan_s": plan_s,
                "plan_ms_per_view": 1.0, "episode_s": 1.0,
                **dict.fromkeys(CURVE_COLUMNS, 90.0)})
    return row


def _table(path: Path, rows: list[dict[str, Any]], columns: list[str]) -> Path:
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


def test_comparing_episode_tables_matches_every_episode_not_one_per_planner(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two episodes tables that differ in the first of two episodes of a planner (and in a
    timing column, which is left out): the moved cells are found (rows keyed by episode
    too)."""
    columns = list(EPISODE_COLUMNS)
    old = _table(tmp_path / "old.csv", [_row(0, 3, 0.1), _row(1, 4, 0.1)], columns)
    new = _table(tmp_path / EPISODES_NAME, [_row(0, 5, 0.1), _row(1, 4, 9.0)], columns)
    assert main(["report", "compare", str(old), str(new)]) == 1
    # acquisitions and requested (acquisitions + 1 in `_row`) of episode 0 moved; 28 columns
    # compared per row (the 34 less the key and the timing columns).
    assert capsys.readouterr().out.splitlines() == [
        "('0', 'bscp', 'robot') acquisitions: 3 -> 5", "('0', 'bscp', 'robot') requested: 4 -> 6",
        "2 rows, 56 cells compared, 2 moved"]
    assert main(["report", "compare", str(old), str(old)]) == 0
    assert capsys.readouterr().out == "2 rows, 56 cells compared, 0 moved\n"


def test_an_episodes_table_against_a_summary_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    summary = _table(tmp_path / "evaluation.csv", [_row(0, 3, 0.1)],
                     ["planner", "carrier", "coverage_pct"])
    episodes = _table(tmp_path / EPISODES_NAME, [_row(0, 3, 0.1)], list(EPISODE_COLUMNS))
    assert main(["report", "compare", str(summary), str(episodes)]) == 2
    assert capsys.readouterr().err == (
        f"vprobot report compare: error: {summary} has no column 'episode'; give two episodes "
        "tables or two summaries of `vprobot evaluate`\n")


@pytest.mark.parametrize("content", [b"", ",".join(EPISODE_COLUMNS).encode() + b"\n"])
def test_a_table_without_rows_is_refused_naming_it(content: bytes, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """An empty table (0 bytes, or a header only) would compare nothing and pass."""
    old = _table(tmp_path / "old.csv", [_row(0, 3, 0.1)], list(EPISODE_COLUMNS))
    empty = tmp_path / "empty.csv"
    empty.write_bytes(content)
    assert main(["report", "compare", str(old), str(empty)]) == 2
    assert capsys.readouterr().err == (
        f"vprobot report compare: error: {empty} has no rows (empty, or a header only): "
        f"nothing to compare; give two tables of `vprobot evaluate`\n")


def test_a_table_that_is_not_utf8_or_has_a_short_row_is_named(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old = _table(tmp_path / "old.csv", [_row(0, 3, 0.1), _row(1, 4, 0.1)],
                 list(EPISODE_COLUMNS))
    binary = tmp_path / "binary.csv"
    binary.write_bytes(old.read_bytes().replace(b"m.stl", b"\xff.stl"))
    short = tmp_path / "short.csv"
    header, first, second = old.read_text().splitlines()
    short.write_text("\n".join([header, first[:30], second]) + "\n")
    assert main(["report", "compare", str(old), str(binary)]) == 2
    assert capsys.readouterr().err.startswith(
        f"vprobot report compare: error: {binary} is not UTF-8 text")
    assert main(["report", "compare", str(old), str(short)]) == 2
    assert capsys.readouterr().err.startswith(
        f"vprobot report compare: error: {short}, line 2: ")
