"""What a run directory says about itself without loading a model: whether its training has
finished, and which of its evaluations its best model is."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vprobot.config import Selection
from vprobot.files.atomic import read_text

RESULT_FILE = "result.json"
"""Written into a run directory when its training has finished (sweep trials, seed runs)."""


OLD_COLUMNS = {"coverage": ("coverage_pct", 100.0), "success": ("success_pct", 100.0),
               "reachable_share": ("reachable_pct", 100.0),
               "ms_per_view": ("plan_ms_per_view", 1.0),
               "travel_joint_time": ("joint_time_s", 1.0),
               "travel_joint_path": ("joint_path_rad", 1.0),
               "travel_cartesian": ("cartesian_m", 1.0), "travel_paper": ("paper_m", 1.0)}
"""Column of an older `evaluations.csv` or `result.json`: (today's column, factor)."""


def current_names(row: dict[str, Any]) -> dict[str, Any]:
    """A row of `evaluations.csv` or `result.json` in today's columns (those of `vprobot
    evaluate`'s table, `vprobot.training.evaluation.SUMMARY_KEYS`).

    Runs written before the one summary had their own columns: fractions (`coverage`,
    `success`, `reachable_share`), `ms_per_view`, and k_cum as `travel_<cost>` (today one step's
    travel in the env's info). The committed runs under results/ and the bundled agents keep
    those files; they are read here, and only here, in today's columns and units.
    """
    return {OLD_COLUMNS[key][0] if key in OLD_COLUMNS else key:
            float(value) * OLD_COLUMNS[key][1] if key in OLD_COLUMNS and value not in (None, "")
            else value for key, value in row.items()}


def read_result(run_dir: Path) -> dict[str, Any]:
    """The `RESULT_FILE` of a finished run (the final evaluation, steps, wall time)."""
    return current_names(json.loads((run_dir / RESULT_FILE).read_text()))


def evaluation_score(row: Mapping[str, Any], select: Selection) -> tuple[float, ...]:
    """How evaluations rank under `agent.select` (the higher the better): coverage, then the
    fewer acquisitions; or the goal rate, then the fewer acquisitions, then coverage; or the goal
    rate, then the fewer requests (a failed request costs the cell time too), then the shorter
    cycle (none, e.g. no robot or a row written before cycles were timed, ranks last), then
    coverage."""
    coverage, acquisitions = float(row["coverage_pct"]), float(row["acquisitions"])
    if select == "goal_then_views":
        return float(row["success_pct"]), -acquisitions, coverage
    if select == "goal_then_cycle":
        cycle = row.get("cycle_time_s")
        return (float(row["success_pct"]), -float(row["requested"]),
                -float(cycle) if cycle not in (None, "") else -math.inf, coverage)
    return coverage, -acquisitions


def best_evaluation(path: Path, select: Selection) -> dict[str, Any] | None:
    """The row of an evaluations file whose model `best_model.zip` is under `agent.select`
    (the earliest of equal ones), in today's columns (`current_names`), None when there is
    none."""
    rows = ([current_names(row) for row in csv.DictReader(read_text(path).splitlines())]
            if path.is_file() else [])
    return max(rows, key=lambda row: evaluation_score(row, select)) if rows else None


def best_validation(run_dir: Path, select: Selection) -> dict[str, float]:
    """The row of `evaluations.csv` whose model `best_model.zip` is: the best under `select`
    (`agent.select`), the earliest of equal ones (as the training callback keeps it), in the
    units of `vprobot evaluate` (percentages).

    Raises:
        ValueError: If the run has no evaluation.
    """
    best = best_evaluation(run_dir / "evaluations.csv", select)
    if best is None:
        raise ValueError(f"{run_dir} holds no validation evaluation (evaluations.csv)")
    return {key: float(best[key])
            for key in ("coverage_pct", "acquisitions", "success_pct", "step")}
