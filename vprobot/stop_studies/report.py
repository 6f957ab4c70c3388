"""Fit the coverage estimate and report its error and calibration (`vprobot stop fit`), and
score a fitted one on episode lists (`vprobot stop error`).

`stop fit` writes into one folder: the rollouts (`training.csv`, `validation.csv`, with
`dataset.json` saying how they were drawn; written an episode at a time and reused when drawn
alike, so that a run cut short goes on where it stopped), the leave-one-family-out estimators
(`folds/`, reused likewise) and their estimates of the families they never saw
(`family_folds.csv`), the estimator with its widening for unseen families (`estimator.npz`), the
mean absolute error per view count on the validation episodes (`mae_per_view.csv`), the
calibration (`calibration.csv`, `reliability.png`) and a Markdown summary (`estimate.md`).
"""

from __future__ import annotations

import dataclasses
import shutil
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.episode import EpisodeSpec
from vprobot.evaluation import evaluation_episodes
from vprobot.files.atomic import csv_text, folder_lock, write_text
from vprobot.parts.splits import Split
from vprobot.planners.runner import make_planner
from vprobot.stop_studies.calibration import (
    LEVELS,
    UNSEEN_LEVEL,
    interval_coverage,
    mae_per_view,
    plot_reliability,
    reliability,
    two_sided_z,
    unseen_scale,
)
from vprobot.stop_studies.dataset import (
    DEFAULT_PLANNERS,
    collect,
    drawn_alike,
    read_dataset,
    record_recipe,
    rollout_recipe,
    training_jobs,
    validation_jobs,
)
from vprobot.stop_studies.folds import FOLDS_DIR, family_folds
from vprobot.stop_studies.study import list_names
from vprobot.stopping.estimator import (
    CoverageEstimator,
    TrainingDomain,
    claim_limits,
    fit,
    load_estimator,
    widened_std,
)
from vprobot.stopping.features import FEATURES
from vprobot.stopping.rules.estimate import DEFAULT_CONFIDENCE

ESTIMATOR_NAME = "estimator.npz"


def _dataset(out: Path, config: Config, jobs: dict[str, list[tuple[EpisodeSpec, str]]],
             recipe: dict[str, Any], progress: bool) -> dict[str, float]:
    """Collect the rollouts that are missing; the seconds each collection took."""
    meta = out / "dataset.json"
    if not drawn_alike(meta, recipe):
        record_recipe(meta, recipe, [out / f"{name}.csv" for name in jobs])
    seconds = {}
    for name, listed in jobs.items():
        start = time.perf_counter()
        if collect(config, listed, out / f"{name}.csv", progress):
            # The folds' estimators were fit on other rollouts.
            shutil.rmtree(out / FOLDS_DIR, ignore_errors=True)
            seconds[name] = time.perf_counter() - start
    return seconds


def fit_estimate(config: Config, out_dir: str | Path, episodes: int = 400, seed: int = 0,
                 planners: Sequence[str] | None = None, progress: bool = True
                 ) -> dict[str, Any]:
    """Collect the rollouts (if missing), fit the estimator and the leave-one-family-out folds
    (if missing), widen the estimate for unseen families, write the report into `out_dir`.

    Args:
        config: The configuration (cell, sensor, robot, view budget).
        out_dir: The folder (created if missing).
        episodes: Training episodes (one planner each, in turn).
        seed: Seeds the training episodes and the networks.
        planners: Model-free planners of the rollouts (default `DEFAULT_PLANNERS`).
        progress: Show progress bars.

    Returns:
        The report's figures: MAE per view count, calibration (as the ensemble states it and
        widened), the folds' errors, seconds.

    Raises:
        ValueError: For bad counts or planners, a count that draws no episode of a training
            family, a folder holding rollouts drawn otherwise or in use by another process.
    """
    planners = tuple(planners) if planners is not None else DEFAULT_PLANNERS
    for planner in planners:
        make_planner(planner, config)
    split = Split.load()
    # Drawn before anything is written: a bad count is refused with the folder untouched.
    jobs = {"training": training_jobs(config, episodes, seed, planners, split),
            "validation": validation_jobs(planners, split)}
    recipe = rollout_recipe(config, planners, split=split.version, episodes=episodes, seed=seed)
    out = Path(out_dir)
    with folder_lock(out, str(out)):
        seconds = _dataset(out, config, jobs, recipe, progress)
        return _fit_and_report(out, config, seed, planners, split, seconds, progress)


def _fit_and_report(out: Path, config: Config, seed: int, planners: Sequence[str],
                    split: Split, seconds: dict[str, float], progress: bool) -> dict[str, Any]:
    """`fit_estimate` once the rollouts are in `out` (whose lock this process holds)."""
    training = read_dataset(out / "training.csv")
    validation = read_dataset(out / "validation.csv")
    start = time.perf_counter()
    stated = fit(training.features, training.coverage, validation.features,
                 validation.coverage, FEATURES, seed)
    seconds["fit"] = time.perf_counter() - start
    start = time.perf_counter()
    folds = family_folds(training, validation, split.training_families, FEATURES, seed, out,
                         progress)
    seconds["folds"] = time.perf_counter() - start
    scale = unseen_scale(folds.mean, folds.std, folds.disagreement, folds.truth)
    widened = dataclasses.replace(stated, unseen_scale=scale)
    estimator = dataclasses.replace(widened, domain=TrainingDomain.of(
        training.features, config.sensor, planners, claim_limits(
            widened, training.features, config.env.coverage_goal, DEFAULT_CONFIDENCE)))
    estimator.save(out / ESTIMATOR_NAME)
    write_text(out / "family_folds.csv", csv_text(
        ("family", "planner", "view", "coverage", "mean", "std", "disagreement"),
        [{"family": family, "planner": planner, "view": view, "coverage": truth, "mean": mean,
          "std": std, "disagreement": spread} for family, planner, view, truth, mean, std,
         spread in zip(folds.families, folds.planners, folds.views.tolist(),
                       folds.truth.tolist(), folds.mean.tolist(), folds.std.tolist(),
                       folds.disagreement.tolist(), strict=True)]))
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
    stated_std = stated.estimate(validation.features)[1]
    stated_observed = interval_coverage(mean, stated_std, truth)
    widened_folds = widened_std(folds.std ** 2, folds.disagreement, scale)
    bins = reliability(std, error)
    write_text(out / "mae_per_view.csv", csv_text(
        ("view", "mae_pp", "rows", *(f"mae_pp_{p}" for p in planners)),
        [{"view": view, "mae_pp": 100 * mae, "rows": rows,
          **{f"mae_pp_{p}": (100 * per_planner[p][view] if view in per_planner[p] else None)
             for p in planners}} for view, mae, rows in per_view]))
    write_text(out / "calibration.csv", csv_text(
        ("level", "observed", "observed_stated"),
        [{"level": level, "observed": share, "observed_stated": before}
         for level, share, before in zip(LEVELS, observed, stated_observed, strict=True)]))
    folds_error = np.abs(folds.truth - folds.mean)
    plot_reliability({"validation, stated": (stated_std, error),
                      "validation, widened": (std, error),
                      "left-out families, stated": (folds.std, folds_error),
                      "left-out families, widened": (widened_folds, folds_error)},
                     out / "reliability.png",
                     f"Coverage estimate: validation ({len(truth)} views) and each training "
                     f"family estimated without it ({len(folds.truth)})")
    figures = {"mae_pp": 100 * float(error.mean()), "per_view": per_view,
               "per_planner": per_planner, "levels": list(LEVELS),
               "observed": observed.tolist(), "observed_stated": stated_observed.tolist(),
               "reliability": bins, "seconds": seconds,
               "training_rows": len(training.coverage), "validation_rows": len(truth),
               "unseen_scale": scale,
               "folds": [_fold_row(folds.mean, folds.std, widened_folds, folds.truth,
                                   folds.families == family) | {"family": family}
                         for family in split.training_families]}
    write_text(out / "estimate.md", _markdown(figures, planners))
    return figures


def _fold_row(mean: np.ndarray, stated: np.ndarray, widened: np.ndarray, truth: np.ndarray,
              rows: np.ndarray) -> dict[str, Any]:
    """A left-out family's bias, error, and the share its 95 % intervals hold."""
    error = mean[rows] - truth[rows]
    return {"rows": int(rows.sum()), "bias_pp": 100 * float(error.mean()),
            "mae_pp": 100 * float(np.abs(error).mean()),
            **{name: float(interval_coverage(mean[rows], std[rows], truth[rows],
                                             (UNSEEN_LEVEL,))[0])
               for name, std in (("stated", stated), ("widened", widened))}}


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
    lines += ["", "Leave-one-family-out: each training family's rows estimated by an estimator "
              "fit without it; the share of its views within the 95 % interval as the "
              "ensemble states it and widened for an unseen family (in sample: the widening "
              "is learned from these rows).", "",
              "| left out | rows | bias pp | MAE pp | stated 95 % holds % | widened % |",
              "|---|---|---|---|---|---|"]
    lines += [f"| {row['family']} | {row['rows']} | {row['bias_pp']:+.2f} | {row['mae_pp']:.2f}"
              f" | {100 * row['stated']:.1f} | {100 * row['widened']:.1f} |"
              for row in figures["folds"]]
    lines += ["", f"Widening for an unseen family: {figures['unseen_scale']:.2f} times the "
              f"members' disagreement (the variance of their means) added to the variance."]
    lines += ["", "Calibration: the share of validation views whose true coverage lies within "
              "the two-sided interval, as the ensemble states it and widened.", "",
              "| level % | stated: observed % | widened: observed % |", "|---|---|---|"]
    lines += [f"| {100 * level:.0f} | {100 * before:.1f} | {100 * share:.1f} |"
              for level, before, share in zip(figures["levels"], figures["observed_stated"],
                                              figures["observed"], strict=True)]
    lines += ["", "Reliability of the widened estimate (bins of equal counts of the std):", "",
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
    `out_dir/<list>.csv` an episode at a time and reused when drawn alike (`<list>.json` says
    how); `error.csv` and `error.md` hold the mean absolute error per list and view count, and
    the calibration per list (as the ensemble states its std and widened for unseen families),
    which `reliability.png` plots.

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
        ValueError: For an unknown list, planner or estimator file, an estimator fitted on
            another sensor or sensing model, two lists of one name, or a folder holding rollouts
            drawn otherwise or in use by another process.
    """
    planners = tuple(planners) if planners is not None else DEFAULT_PLANNERS
    for planner in planners:
        make_planner(planner, config)
    model = load_estimator(estimator, config.sensor)
    mismatch = None if model.domain is None else model.domain.sensor_mismatch(config.sensor)
    if mismatch is not None:
        raise ValueError(f"the estimator cannot be scored on these rollouts: {mismatch}; fit one "
                         f"on this sensor with `vprobot stop fit`")
    specs = {name: evaluation_episodes(config, episodes=entry)
             for name, entry in zip(list_names(lists), lists, strict=True)}
    recipes = {name: rollout_recipe(config, planners,
                                    episodes=[spec.as_dict() for spec in listed])
               for name, listed in specs.items()}
    out = Path(out_dir)
    with folder_lock(out, str(out)):
        # Every list's record checked before any is written or any rollout runs.
        fresh = [name for name, recipe in recipes.items()
                 if not drawn_alike(out / f"{name}.json", recipe)]
        for name in fresh:
            record_recipe(out / f"{name}.json", recipes[name], [out / f"{name}.csv"])
        for name, listed in specs.items():
            collect(config, [(spec, planner) for spec in listed for planner in planners],
                    out / f"{name}.csv", progress)
        return _error_report(out, model, planners, list(specs))


def _error_report(out: Path, model: CoverageEstimator, planners: Sequence[str],
                  names: Sequence[str]) -> list[dict[str, Any]]:
    """`score_estimate`'s tables and plot from the rollouts of the lists `names` in `out`
    (whose lock this process holds)."""
    rows: list[dict[str, Any]] = []
    lines = ["# Coverage estimate on episode lists", "",
             f"Planners of the rollouts: {', '.join(planners)}; robot in the loop, no coverage "
             f"goal. Mean absolute error (pp) per view count, then the share of views whose "
             f"true coverage lies within the two-sided interval.", "",
             "| list | " + " | ".join(str(view) for view in range(1, 12)) + " | all |",
             "|---" * 13 + "|"]
    stated = dataclasses.replace(model, unseen_scale=0.0)
    z = two_sided_z(UNSEEN_LEVEL)
    calibration = ["", f"Intervals as the ensemble states them, then widened for an unseen family "
                   f"(the estimate `--stop estimate` uses); the last column is the mean half-width "
                   f"of the {100 * UNSEEN_LEVEL:.0f} % interval.", "",
                   "| list | std | " + " | ".join(f"{100 * level:.0f} %" for level in LEVELS)
                   + f" | {100 * UNSEEN_LEVEL:.0f} % half-width pp |",
                   "|---" * (3 + len(LEVELS)) + "|"]
    series: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name in names:
        data = read_dataset(out / f"{name}.csv")
        mean, std = model.estimate(data.features)
        per_view = mae_per_view(mean, data.coverage, data.views)
        rows += [{"list": name, "view": view, "mae_pp": 100 * mae, "rows": count}
                 for view, mae, count in per_view]
        overall = 100 * float(np.abs(data.coverage - mean).mean())
        rows.append({"list": name, "view": "all", "mae_pp": overall, "rows": len(mean)})
        by_view = {view: f"{100 * mae:.2f}" for view, mae, _ in per_view}
        lines.append(f"| {name} | " + " | ".join(by_view.get(view, "-") for view in range(1, 12))
                     + f" | {overall:.2f} |")
        for label, deviation in (("stated", stated.estimate(data.features)[1]),
                                 ("widened", std)):
            series[f"{name}, {label}"] = (deviation, np.abs(data.coverage - mean))
            shares = interval_coverage(mean, deviation, data.coverage)
            calibration.append(f"| {name} | {label} | "
                               + " | ".join(f"{100 * share:.1f}" for share in shares)
                               + f" | {100 * z * float(deviation.mean()):.2f} |")
    write_text(out / "error.csv", csv_text(("list", "view", "mae_pp", "rows"), rows))
    write_text(out / "error.md", "\n".join([*lines, *calibration]) + "\n")
    plot_reliability(series, out / "reliability.png",
                     "Coverage estimate on episode lists: as stated and widened")
    return rows
