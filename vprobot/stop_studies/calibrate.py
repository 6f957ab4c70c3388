"""`vprobot stop calibrate`: the calibrated stop's probability and threshold
(`vprobot.stopping.confidence`) from rollouts on parts no fit saw, and their report.

Model-free planners run with the robot in the loop, no coverage goal, on the split's
calibration objects (new motors and new instances of the training families), one planner each
in turn. The estimate is stated on every view as `--stop estimate` states it; the episodes are
then split in two, each planner's episodes in turn (`fit_rows`): the first, third, ... of each
planner calibrate the probability (the conformal predictive system), the others choose the
threshold and when to give up (Learn-then-Test), so that neither sees the data of the other and
both hold every planner, and the report scores the probability on the second half too.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.episode import EpisodeSpec, seeded_episode
from vprobot.files.atomic import folder_lock, write_text
from vprobot.parts.splits import Split
from vprobot.planners.runner import make_planner
from vprobot.stop_studies.dataset import (
    DEFAULT_PLANNERS,
    Dataset,
    collect,
    drawn_alike,
    read_dataset,
    record_recipe,
    rollout_recipe,
)
from vprobot.stopping.confidence import (
    PLATEAU,
    Calibrated,
    GoalConfidence,
    calibration_table,
    false_give_ups,
    false_stops,
    first_crossings,
    give_up_share,
    give_ups,
    plateau_view,
    quiet_share,
    stop_threshold,
)
from vprobot.stopping.estimator import EstimateTracker, bundled_estimator, load_estimator
from vprobot.stopping.rules.confident import confidence_path

DEFAULT_RISK = 0.05
DEFAULT_DELTA = 0.1
TABLE = "calibration.csv"


def calibration_jobs(config: Config, count: int, seed: int,
                     planners: Sequence[str] = DEFAULT_PLANNERS,
                     split: Split | None = None) -> list[tuple[EpisodeSpec, str]]:
    """`count` episodes on the split's calibration objects, in turn, each with one planner in
    turn and a pose drawn from `seed`.

    Raises:
        ValueError: If count < 1, no planner is given or the split names no calibration
            objects.
    """
    if count < 1 or not planners:
        raise ValueError(f"calibration rollouts need count >= 1 and a planner, got {count} "
                         f"and {list(planners)}")
    objects = (split if split is not None else Split.load()).calibration_objects()
    poses = np.random.default_rng(seed).integers(0, 2**31 - 1, size=count)
    return [(seeded_episode(config.env, objects[number % len(objects)], int(pose)),
             planners[number % len(planners)]) for number, pose in enumerate(poses)]


def _episode_rows(data: Dataset, rows: np.ndarray) -> list[np.ndarray]:
    """The indices of the rows a mask keeps, episode by episode, each in view order."""
    episodes = [np.flatnonzero(rows & (data.episodes == number))
                for number in np.unique(data.episodes[rows])]
    return [one[np.argsort(data.views[one])] for one in episodes]


def stated_estimates(config: Config, estimator: Path, data: Dataset
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row, the estimate's mean and std as `--stop estimate` states them view by view
    (`EstimateTracker`), and whether `confident` may use it (not refused)."""
    model = load_estimator(estimator, config.sensor)
    mean, std = np.full(len(data.coverage), np.nan), np.full(len(data.coverage), np.nan)
    usable = np.zeros(len(data.coverage), bool)
    for rows in _episode_rows(data, np.ones(len(data.coverage), bool)):
        tracker = EstimateTracker(model, config, str(data.planners[rows[0]]))
        for row in rows:
            stated = tracker.update(data.features[row])
            mean[row], std[row] = stated.mean, stated.std
            usable[row] = not stated.refused
    return mean, std, usable


def fit_rows(data: Dataset) -> np.ndarray:
    """Whether each row belongs to the probability's half of the episodes: the first, third,
    ... episode of its planner (by episode number); the others are Learn-then-Test's."""
    fit = np.zeros(len(data.episodes), dtype=bool)
    for planner in np.unique(data.planners):
        episodes = np.unique(data.episodes[data.planners == planner])
        fit |= np.isin(data.episodes, episodes[::2]) & (data.planners == planner)
    return fit


def _episodes(data: Dataset, probability: np.ndarray, rows: np.ndarray
              ) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """The selected rows' probabilities, coverages, view counts and quiet shares, episode by
    episode."""
    ordered = _episode_rows(data, rows)
    quiet = quiet_share(data.features)
    return ([probability[one] for one in ordered], [data.coverage[one] for one in ordered],
            [data.views[one] for one in ordered], [quiet[one] for one in ordered])


def calibrate_stop(config: Config, out_dir: str | Path, estimator: str | Path | None = None,
                   episodes: int = 200, seed: int = 0, planners: Sequence[str] | None = None,
                   risk: float = DEFAULT_RISK, delta: float = DEFAULT_DELTA,
                   progress: bool = True) -> dict[str, Any]:
    """Collect the rollouts (if missing), calibrate, write the estimator's copy, its
    calibration (`confidence.npz`, beside it) and the report into `out_dir`.

    Returns:
        The report's figures.

    Raises:
        ValueError: For bad counts, planners, risk or delta, an estimator that cannot be read,
            or a folder holding rollouts drawn otherwise or in use by another process.
    """
    planners = tuple(planners) if planners is not None else DEFAULT_PLANNERS
    for planner in planners:
        make_planner(planner, config)
    if not 0.0 < risk < 1.0 or not 0.0 < delta < 1.0:
        raise ValueError(f"--risk and --delta must lie in (0, 1), got {risk} and {delta}")
    source = Path(estimator) if estimator is not None else bundled_estimator(config.sensor)
    load_estimator(source, config.sensor)
    split = Split.load()
    jobs = calibration_jobs(config, episodes, seed, planners, split)
    recipe = rollout_recipe(config, planners, split=split.version, episodes=episodes, seed=seed)
    out = Path(out_dir)
    with folder_lock(out, str(out)):
        meta = out / "dataset.json"
        if not drawn_alike(meta, recipe):
            record_recipe(meta, recipe, [out / TABLE])
        collect(config, jobs, out / TABLE, progress)
        copy = out / "estimator.npz"
        shutil.copyfile(source, copy)
        return _calibrate(config, out, copy, read_dataset(out / TABLE), risk, delta)


def _calibrate(config: Config, out: Path, estimator: Path, data: Dataset, risk: float,
               delta: float) -> dict[str, Any]:
    mean, std, usable = stated_estimates(config, estimator, data)
    fit = fit_rows(data)
    kept = fit & usable
    if not kept.any():
        raise ValueError(f"the estimate {estimator} was refused on every view of the calibration "
                         f"episodes (fit for another sensor?): nothing to calibrate")
    goal = config.env.coverage_goal
    partial = GoalConfidence(data.coverage[kept] - mean[kept], std[kept], data.views[kept],
                             None, risk, delta, 0, Calibrated.of(config, estimator))
    probability = np.zeros(len(data.coverage))
    probability[usable] = partial.probability(mean[usable], std[usable], data.views[usable])
    tested, coverage, views, quiet = _episodes(data, probability, ~fit)
    threshold = stop_threshold(tested, coverage, goal, risk, delta)
    give_up = (None if threshold is None else
               give_up_share(tested, quiet, coverage, goal, threshold, risk, delta))
    confidence = GoalConfidence(partial.residuals, partial.sigmas, partial.views, threshold,
                                risk, delta, len(tested), partial.calibrated, give_up)
    confidence.save(confidence_path(estimator))
    figures = _figures(confidence, tested, coverage, views, quiet, probability[~fit & usable],
                       data.coverage[~fit & usable] >= goal)
    write_text(out / "calibration.md", _markdown(figures, config))
    return figures


def _figures(confidence: GoalConfidence, probabilities: list[np.ndarray],
             coverages: list[np.ndarray], views: list[np.ndarray], quiet: list[np.ndarray],
             claimed: np.ndarray, reached: np.ndarray) -> dict[str, Any]:
    goal = confidence.calibrated.goal
    figures: dict[str, Any] = {
        "threshold": confidence.threshold, "risk": confidence.risk, "delta": confidence.delta,
        "calibration_views": len(confidence.residuals), "mondrian": confidence.mondrian,
        "threshold_episodes": len(probabilities), "give_up": confidence.give_up,
        "out_of_reach": sum(bool((c < goal).all()) for c in coverages),
        "table": calibration_table(claimed, reached)}
    if confidence.threshold is not None and confidence.give_up is not None:
        share = np.array([confidence.give_up])
        given = [int(give_ups(p, q, confidence.threshold, share)[0])
                 for p, q in zip(probabilities, quiet, strict=True)]
        # Where the goal is out of reach: the views between giving up and the plateau.
        gaps = [index - plateau_view(c) for index, c in zip(given, coverages, strict=True)
                if index < len(c) and (c < goal).all()]
        figures |= {
            "gave_up": sum(index < len(c) for index, c in zip(given, coverages, strict=True)),
            "false_give_ups": int(false_give_ups(probabilities, quiet, coverages, goal,
                                                 confidence.threshold, share)[:, 0].sum()),
            "gave_up_out_of_reach": len(gaps),
            "plateau_gaps": sorted(gaps)}
    if confidence.threshold is not None:
        # Only the certified threshold: Learn-then-Test scored them all.
        threshold = np.array([confidence.threshold])
        false = false_stops(probabilities, coverages, goal, threshold)[:, 0]
        crossing = [int(first_crossings(p, threshold)[0]) for p in probabilities]
        stopped = np.array([index < len(p) for index, p in zip(crossing, probabilities,
                                                               strict=True)])
        at_goal = [int(np.argmax(c >= goal)) if (c >= goal).any() else None for c in coverages]
        extra = [float(v[index] - v[reached_at]) for index, reached_at, v
                 in zip(crossing, at_goal, views, strict=True)
                 if index < len(v) and reached_at is not None]
        figures |= {"stopped": int(stopped.sum()), "false_stops": int(false.sum()),
                    "extra_views_median": float(np.median(extra)) if extra else None}
    return figures


def _markdown(figures: dict[str, Any], config: Config) -> str:
    goal = 100 * config.env.coverage_goal
    lines = [
        "# Calibrated stop", "",
        f"Robot {config.cell.robot}, sensor sensing `{config.sensor.sensing}`, coverage goal "
        f"{goal:g} %. The probability P(coverage ≥ goal) is calibrated on "
        f"{figures['calibration_views']} views of half of each planner's episodes "
        f"({'Mondrian by views taken' if figures['mondrian'] else 'pooled'}); the threshold is "
        f"chosen by Learn-then-Test on the other {figures['threshold_episodes']} "
        f"(the threshold episodes), for false stops at most {100 * figures['risk']:g} % with "
        f"{100 * (1 - figures['delta']):g} % confidence.", ""]
    if figures["threshold"] is None:
        lines += ["No threshold was certified: even the highest stops below the goal too often "
                  "on these episodes.", ""]
    else:
        extra = figures["extra_views_median"]
        lines += [f"Threshold: {figures['threshold']:g}. On the threshold episodes it stops "
                  f"{figures['stopped']} of {figures['threshold_episodes']}, "
                  f"{figures['false_stops']} of them below the goal; median views beyond the "
                  f"goal's: {'-' if extra is None else f'{extra:g}'}.", ""]
    if figures.get("gave_up") is not None:
        gaps = figures["plateau_gaps"]
        lines += [f"Giving up: under a quiet share of {100 * figures['give_up']:g} % (each of the "
                  f"latest 2 acquisitions added less to the occupied voxels). On the threshold "
                  f"episodes it gives up on {figures['gave_up']}, {figures['false_give_ups']} of "
                  f"them below the goal where more views reached it; of the "
                  f"{figures['out_of_reach']} episodes whose goal was out of reach it gave up on "
                  f"{figures['gave_up_out_of_reach']}, at views from their plateau (the first "
                  f"view within {100 * PLATEAU:g} pp of their highest coverage): "
                  f"{'-' if not gaps else ', '.join(f'{gap:+d}' for gap in gaps)}.", ""]
    elif figures["threshold"] is not None:
        lines += ["Giving up: no quiet share was certified; the rule never gives up.", ""]
    lines += ["Claimed P against the observed share at the goal, on the views of the threshold "
              "episodes where a stop may use the estimate:", "",
              "| claimed P in | views | mean claimed P | observed share at goal |",
              "|---|---|---|---|"]
    for row in figures["table"]:
        claimed = "-" if np.isnan(row["claimed"]) else f"{row['claimed']:.3f}"
        observed = "-" if np.isnan(row["observed"]) else f"{row['observed']:.3f}"
        lines.append(f"| [{row['low']:g}, {row['high']:g}) | {row['views']} | {claimed} | "
                     f"{observed} |")
    return "\n".join(lines) + "\n"
