"""Fit the coverage estimate and report its error and calibration (`vprobot stop fit`), and
score a fitted one on episode lists (`vprobot stop error`).

`stop fit` writes into one folder: the rollouts (`training.csv`, `validation.csv`, with
`dataset.json` saying how they were drawn; reused when present and drawn alike, so that a run cut
short goes on where it stopped), the estimator (`estimator.npz`), the mean absolute error per view
count on the validation episodes (`mae_per_view.csv`), the calibration (`calibration.csv`,
`reliability.png`) and a Markdown summary (`estimate.md`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.evaluation import evaluation_episodes
from vprobot.files import csv_text, write_text
from vprobot.planners.runner import make_planner
from vprobot.splits import Split
from vprobot.stopping.calibration import (
    LEVELS,
    interval_coverage,
    mae_per_view,
    plot_reliability,
    reliability,
)
from vprobot.stopping.dataset import (
    COLUMNS,
    DEFAULT_PLANNERS,
    collect,
    read_dataset,
    training_jobs,
    validation_jobs,
)
from vprobot.stopping.estimator import fit, load_estimator
from vprobot.stopping.features import FEATURES

ESTIMATOR_NAME = "estimator.npz"


def _dataset(out: Path, config: Config, episodes: int, seed: int, planners: Sequence[str],
             split: Split, progress: bool) -> dict[str, float]:
    """Collect the rollouts that are missing; the seconds each collection took."""
    for planner in planners:
        make_planner(planner, config)
    # Drawn before anything is written: a bad count is refused with the folder untouched.
    jobs = {"training": training_jobs(config, episodes, seed, planners, split),
            "validation": validation_jobs(planners, split)}
    recipe = {"split": split.version, "episodes": episodes, "seed": seed,
              "planners": list(planners), "features": list(FEATURES)}
    meta = out / "dataset.json"
    if meta.is_file():
        if json.loads(meta.read_text()) != recipe:
            raise ValueError(f"{out} holds rollouts drawn otherwise ({meta}); use another --out")
    else:
        out.mkdir(parents=True, exist_ok=True)
        for name in jobs:
            (out / f"{name}.csv").unlink(missing_ok=True)
        write_text(meta, json.dumps(recipe, indent=1) + "\n")
    seconds = {}
    for name, listed in jobs.items():
        path = out / f"{name}.csv"
        if path.is_file():
            continue
        start = time.perf_counter()
        write_text(path, csv_text(COLUMNS, collect(config, listed, progress)))
        seconds[name] = time.perf_counter() - start
    return seconds


def fit_estimate(config: Config, out_dir: str | Path, episodes: int = 400, seed: int = 0,
                 planners: Sequence[str] | None = None, progress: bool = True
                 ) -> dict[str, Any]:
    """Collect the rollouts (if missing), fit the estimator, write the report into `out_dir`.

    Args:
        config: The configuration (cell, sensor, robot, view budget).
        out_dir: The folder (created if missing).
        episodes: Training episodes (one planner each, in turn).
        seed: Seeds the training episodes and the networks.
        planners: Model-free planners of the rollouts (default `DEFAULT_PLANNERS`).
        progress: Show progress bars.

    Returns:
        The report's figures: MAE per view count, calibration, collection seconds.

    Raises:
        ValueError: For bad counts or planners, or a folder holding rollouts drawn otherwise.
    """
    planners = tuple(planners) if planners is not None else DEFAULT_PLANNERS
    out = Path(out_dir)
    split = Split.load()
    seconds = _dataset(out, config, episodes, seed, planners, split, progress)
    training = read_dataset(out / "training.csv")
    validation = read_dataset(out / "validation.csv")
    start = time.perf_counter()
    estimator = fit(training.features, training.coverage, validation.features,
                    validation.coverage, FEATURES, seed)
    seconds["fit"] = time.perf_counter() - start
    estimator.save(out / ESTIMATOR_NAME)
    mean, std = estimator.estimate(validation.features)
    truth = validation.coverage
    error = np.abs(truth - mean)
    per_view = mae_per_view(mean, truth, validation.views)
    per_planner = {planner: dict((view, mae) for view, mae, _ in
                                 mae_per_view(mean[validation.planners == planner],
                                              truth[validation.planners == planner],
                                              validation.views[validation.planners == planner]))
                   for planner in planners}
    observed = interval_coverage(mean, std, truth)
    bins = reliability(std, error)
    write_text(out / "mae_per_view.csv", csv_text(
        ("view", "mae_pp", "rows", *(f"mae_pp_{p}" for p in planners)),
        [{"view": view, "mae_pp": 100 * mae, "rows": rows,
          **{f"mae_pp_{p}": (100 * per_planner[p][view] if view in per_planner[p] else None)
             for p in planners}} for view, mae, rows in per_view]))
    write_text(out / "calibration.csv", csv_text(
        ("level", "observed"), [{"level": level, "observed": share}
                                for level, share in zip(LEVELS, observed, strict=True)]))
    plot_reliability(std, error, observed, out / "reliability.png",
                     f"Coverage estimate on the validation episodes ({len(truth)} views)")
    figures = {"mae_pp": 100 * float(error.mean()), "per_view": per_view,
               "per_planner": per_planner, "levels": list(LEVELS),
               "observed": observed.tolist(), "reliability": bins, "seconds": seconds,
               "training_rows": len(training.coverage), "validation_rows": len(truth)}
    write_text(out / "estimate.md", _markdown(figures, planners))
    return figures


def _markdown(figures: dict[str, Any], planners: Sequence[str]) -> str:
    lines = [
        "# Coverage estimate: validation episodes of split v1",
        "",
        f"Rows (views): {figures['training_rows']} training, {figures['validation_rows']} "
        f"validation. Mean absolute error over all validation views: "
        f"{figures['mae_pp']:.2f} pp.",
        "",
        "| views | MAE pp | rows | " + " | ".join(planners) + " |",
        "|---" * (3 + len(planners)) + "|",
    ]
    for view, mae, rows in figures["per_view"]:
        cells = [f"{100 * figures['per_planner'][p][view]:.2f}"
                 if view in figures["per_planner"][p] else "-" for p in planners]
        lines.append(f"| {view} | {100 * mae:.2f} | {rows} | " + " | ".join(cells) + " |")
    lines += ["", "Calibration: the share of validation views whose true coverage lies within "
              "the stated two-sided interval.", "", "| stated level % | observed % |",
              "|---|---|"]
    lines += [f"| {100 * level:.0f} | {100 * share:.1f} |"
              for level, share in zip(figures["levels"], figures["observed"], strict=True)]
    lines += ["", "Reliability (bins of equal counts of the stated std):", "",
              "| stated std pp | observed RMS error pp | rows |", "|---|---|---|"]
    lines += [f"| {100 * std:.2f} | {100 * rms:.2f} | {rows} |"
              for std, rms, rows in figures["reliability"]]
    seconds = figures["seconds"]
    lines += ["", "Seconds (this run): " + ", ".join(f"{name} {value:.0f}"
                                                    for name, value in seconds.items())]
    return "\n".join(lines) + "\n"


def score_estimate(config: Config, out_dir: str | Path, lists: Sequence[str],
                   planners: Sequence[str] | None = None, estimator: str | Path | None = None,
                   progress: bool = True) -> list[dict[str, Any]]:
    """The estimator's error per view count on episode lists (for reporting: the test lists).

    Rollouts as `stop fit` draws them (robot in the loop, no coverage goal) are written to
    `out_dir/<list>.csv` and reused when present; `error.csv` and `error.md` hold the mean
    absolute error per list and view count, and the calibration per list.

    Args:
        config: The configuration (cell, sensor, robot, view budget).
        out_dir: The folder (created if missing).
        lists: Episode lists, bundled names or files.
        planners: Model-free planners of the rollouts (default `DEFAULT_PLANNERS`).
        estimator: An `estimator.npz` (default: the bundled one).
        progress: Show progress bars.

    Returns:
        One row per list and view count (`list`, `view`, `mae_pp`, `rows`), then one per list
        with `view` "all".

    Raises:
        ValueError: For an unknown list, planner or estimator file.
    """
    planners = tuple(planners) if planners is not None else DEFAULT_PLANNERS
    for planner in planners:
        make_planner(planner, config)
    model = load_estimator(estimator)
    specs = {Path(name).stem: evaluation_episodes(config, episodes=name) for name in lists}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    lines = ["# Coverage estimate on episode lists", "",
             f"Planners of the rollouts: {', '.join(planners)}; robot in the loop, no coverage "
             f"goal. Mean absolute error (pp) per view count, then the share of views whose "
             f"true coverage lies within the stated two-sided interval.", "",
             "| list | " + " | ".join(str(view) for view in range(1, 12)) + " | all |",
             "|---" * 13 + "|"]
    calibration = ["", "| list | " + " | ".join(f"{100 * level:.0f} %" for level in LEVELS)
                   + " |", "|---" * (1 + len(LEVELS)) + "|"]
    for name, listed in specs.items():
        path = out / f"{name}.csv"
        if not path.is_file():
            jobs = [(spec, planner) for spec in listed for planner in planners]
            write_text(path, csv_text(COLUMNS, collect(config, jobs, progress)))
        data = read_dataset(path)
        mean, std = model.estimate(data.features)
        per_view = mae_per_view(mean, data.coverage, data.views)
        rows += [{"list": name, "view": view, "mae_pp": 100 * mae, "rows": count}
                 for view, mae, count in per_view]
        overall = 100 * float(np.abs(data.coverage - mean).mean())
        rows.append({"list": name, "view": "all", "mae_pp": overall, "rows": len(mean)})
        by_view = {view: f"{100 * mae:.2f}" for view, mae, _ in per_view}
        lines.append(f"| {name} | " + " | ".join(by_view.get(view, "-") for view in range(1, 12))
                     + f" | {overall:.2f} |")
        shares = interval_coverage(mean, std, data.coverage)
        calibration.append(f"| {name} | " + " | ".join(f"{100 * share:.1f}" for share in shares)
                           + " |")
    write_text(out / "error.csv", csv_text(("list", "view", "mae_pp", "rows"), rows))
    write_text(out / "error.md", "\n".join([*lines, *calibration]) + "\n")
    return rows
