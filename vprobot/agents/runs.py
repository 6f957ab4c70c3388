"""What a run directory says about itself without loading a model: whether its training has
finished, and which of its evaluations its best model is."""

from __future__ import annotations

import csv
from collections.abc import Mapping
from pathlib import Path

from vprobot.config import Selection

RESULT_FILE = "result.json"
"""Written into a run directory when its training has finished (sweep trials, seed runs)."""


def evaluation_score(row: Mapping[str, str | float], select: Selection) -> tuple[float, ...]:
    """How evaluations rank under `agent.select` (the higher the better): coverage, then the
    fewer acquisitions; or the goal rate, then the fewer acquisitions, then coverage."""
    coverage, acquisitions = float(row["coverage"]), float(row["acquisitions"])
    if select == "goal_then_views":
        return float(row["success"]), -acquisitions, coverage
    return coverage, -acquisitions


def best_evaluation(path: Path, select: Selection) -> dict[str, str] | None:
    """The row of an evaluations file whose model `best_model.zip` is under `agent.select`
    (the earliest of equal ones), None when there is none."""
    rows = list(csv.DictReader(path.read_text().splitlines())) if path.is_file() else []
    return max(rows, key=lambda row: evaluation_score(row, select)) if rows else None
