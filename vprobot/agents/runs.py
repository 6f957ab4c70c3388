"""What a run directory says about itself without loading a model: whether its training has
finished, and which of its evaluations its best model is."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

RESULT_FILE = "result.json"
"""Written into a run directory when its training has finished (sweep trials, seed runs)."""


def current_names(row: dict[str, Any]) -> dict[str, Any]:
    """A row of `evaluations.csv` or `result.json` under today's names.

    Runs written before k_cum had one name call it `travel_<cost>` there (today one step's
    travel in the env's info); the committed runs under results/ and the bundled agents keep
    those files, so they are read as `travel_sum_<cost>`.
    """
    return {f"travel_sum_{key.removeprefix('travel_')}"
            if key.startswith("travel_") and not key.startswith("travel_sum_") else key: value
            for key, value in row.items()}


def read_result(run_dir: Path) -> dict[str, Any]:
    """The `RESULT_FILE` of a finished run (the final evaluation, steps, wall time)."""
    return current_names(json.loads((run_dir / RESULT_FILE).read_text()))


def evaluation_score(row: dict[str, str]) -> tuple[float, float]:
    """How evaluations rank: the higher coverage, then the fewer acquisitions."""
    return float(row["coverage"]), -float(row["acquisitions"])


def best_evaluation(path: Path) -> dict[str, str] | None:
    """The row of an evaluations file whose model `best_model.zip` is (the earliest of equal
    ones), None when there is none."""
    rows = list(csv.DictReader(path.read_text().splitlines())) if path.is_file() else []
    return current_names(max(rows, key=evaluation_score)) if rows else None
