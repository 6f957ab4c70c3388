"""What a run directory says about itself without loading a model: whether its training has
finished, and which of its evaluations its best model is."""

from __future__ import annotations

import csv
from pathlib import Path

RESULT_FILE = "result.json"
"""Written into a run directory when its training has finished (sweep trials, seed runs)."""


def evaluation_score(row: dict[str, str]) -> tuple[float, float]:
    """How evaluations rank: the higher coverage, then the fewer acquisitions."""
    return float(row["coverage"]), -float(row["acquisitions"])


def best_evaluation(path: Path) -> dict[str, str] | None:
    """The row of an evaluations file whose model `best_model.zip` is (the earliest of equal
    ones), None when there is none."""
    rows = list(csv.DictReader(path.read_text().splitlines())) if path.is_file() else []
    return max(rows, key=evaluation_score) if rows else None
