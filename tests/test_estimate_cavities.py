"""The estimate rule does not stop while more space is unexplored than on the training views
where the estimate claimed the goal (issue 30): a cavity no view has seen into looks like solid
material to the estimate, which then claims the goal too early."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest
from helpers import COVERAGE_CPU_MARGIN

from vprobot.config import Config, replace
from vprobot.episode import PartScene, seeded_episode
from vprobot.planners.runner import run, summary
from vprobot.stop_studies.dataset import read_dataset
from vprobot.stopping.estimator import (
    CoverageEstimator,
    EstimateTracker,
    claim_limits,
    load_estimator,
)
from vprobot.stopping.features import FEATURES

CONFIG = Config()
Z = 1.6448536  # one-sided 95 %, the rule's default
RESULTS = Path(__file__).resolve().parent.parent / "results" / "stop_estimate"


def test_the_limits_of_a_stop_are_the_98th_percentile_of_unexplored_space_on_training_claims(
) -> None:
    estimator = load_estimator()
    assert estimator.domain is not None and estimator.domain.claimed is not None
    training = read_dataset(RESULTS / "training.csv")
    mean, std = estimator.estimate(training.features)
    claims = training.features[mean - Z * std >= CONFIG.env.coverage_goal]
    assert len(claims) == 562  # of 3198 training views
    expected = np.full(len(FEATURES), np.inf)
    for name in ("unknown", "rear_side", "open_surface", "hull_unknown"):
        column = FEATURES.index(name)
        expected[column] = np.quantile(claims[:, column], 0.98)
    np.testing.assert_allclose(estimator.domain.claimed, expected)


def test_claim_limits_take_the_quantile_over_the_claimed_rows_only() -> None:
    rows = np.arange(20 * len(FEATURES), dtype=float).reshape(20, len(FEATURES))
    claimed = np.arange(20) % 2 == 0  # the even rows: mean 0.99, std 0.01; the odd: mean 0.5
    estimator = types.SimpleNamespace(
        features=FEATURES, estimate=lambda x: (np.where(claimed, 0.99, 0.5), np.full(20, 0.01)))
    limits = claim_limits(estimator, rows, 0.9, 0.95)  # type: ignore[arg-type]
    rear_side, extent = FEATURES.index("rear_side"), FEATURES.index("extent")
    assert limits[rear_side] == np.quantile(rows[claimed, rear_side], 0.98)
    assert limits[rear_side] < rows[claimed, rear_side].max()
    assert limits[extent] == np.inf  # not a feature of unexplored space
    # No claim in training: nothing shows where one holds, so no stop.
    assert claim_limits(estimator, rows, 0.999, 0.95)[rear_side] == -np.inf  # type: ignore


@pytest.mark.parametrize(("part", "seed", "old_stop"), [
    pytest.param("foreign/t_slot.stl", 0, 7, marks=pytest.mark.xfail(strict=True, reason=(
        "issue 45's grid integration moved the features the bundled estimate was fitted on: nbv "
        "takes other views, the estimate no longer claims the goal at view 7, and it stops at "
        "view 9 at 89.06 %, below the goal; the paper cell's bundled estimate is still the fit "
        "on the sampled grid (issue 47 rebuilds the stop rule and its fits)"))),
    ("foreign-b/egg_with_hole.stl", 0, 6)])
def test_the_estimate_rule_does_not_stop_below_the_goal_on_unseen_cavities(
        part: str, seed: int, old_stop: int) -> None:
    # Before, nbv stopped here at 85.9 % (the T-slot's undercut chambers) and 85.1 % (the egg's
    # blind hole), the estimate claiming 95.8 and 96.8 %.
    # Straight-line moves and no clearance or joint-limit margins, as in the rollouts the bundled
    # estimate was fitted and checked on: the episodes are those of the issue-30 study (planned
    # paths and margins reach other views; with the default margins the T-slot's estimate stops
    # at 87.1 % at view 7, a stop the domain guard does not hold back).
    config = replace(replace(CONFIG, "kinematics", path_planner="line"), "cell", safety={
        "clearance_m": 0.0, "part_clearance_m": 0.0, "joint_limit_margin_deg": 0.0})
    path = RESULTS / part
    scene = PartScene.load(config, path, 0.001)
    spec = seeded_episode(config.env, path, seed, 0.001)
    result = run(config, scene, "nbv", spec, "robot", stop="estimate", estimates=True)
    views = result.record.views
    assert result.estimates is not None
    # The estimate itself is unchanged: at the old stop it still claims the goal.
    mean, std = result.estimates[old_stop - 1]
    assert mean - Z * std >= CONFIG.env.coverage_goal > views[old_stop - 1].coverage
    assert len(views) > old_stop
    if result.stop_reason.startswith("estimate"):
        # The T-slot's stop lands at 89.9-90.04 % depending on the CPU: at the goal within
        # the margin, 4 pp above the old stop.
        assert views[-1].coverage >= CONFIG.env.coverage_goal - COVERAGE_CPU_MARGIN
    assert "  estimate held back from a stop: " in summary(result, config)


def test_a_held_estimate_is_stated_as_before_and_says_which_space_is_unexplored() -> None:
    estimator = load_estimator()
    domain = estimator.domain
    assert domain is not None and domain.claimed is not None
    rear_side = FEATURES.index("rear_side")
    inside = (domain.low + domain.high) / 2.0
    inside = np.minimum(inside, domain.claimed)
    free = EstimateTracker(estimator, CONFIG).update(inside)
    assert free.held is None
    above = inside.copy()
    above[rear_side] = domain.claimed[rear_side] * 1.01
    held = EstimateTracker(estimator, CONFIG).update(above)
    assert (held.mean, held.std) == tuple(float(value) for value in estimator.estimate(above))
    assert held.held == (
        f"held back from a stop: rear_side above {domain.claimed[rear_side]:.4g}, the 98th "
        f"percentile over the training views on which it claimed the goal (space it was not "
        f"shown to judge)")


def test_the_limits_survive_a_save_and_a_format_3_file_still_loads_without_them(
        tmp_path: Path) -> None:
    estimator = load_estimator()
    loaded = CoverageEstimator.load(estimator.save(tmp_path / "estimator.npz"))
    assert loaded.domain is not None and estimator.domain is not None
    assert estimator.domain.claimed is not None
    assert np.array_equal(loaded.domain.claimed, estimator.domain.claimed)  # type: ignore[arg-type]
    with np.load(tmp_path / "estimator.npz") as data:
        arrays = {key: data[key] for key in data.files if key != "domain_claimed"}
    np.savez(tmp_path / "old.npz", **(arrays | {"format": np.array(3)}))
    old = CoverageEstimator.load(tmp_path / "old.npz")
    assert old.domain is not None and old.domain.claimed is None
    assert np.array_equal(old.domain.low, estimator.domain.low)
    assert EstimateTracker(old, CONFIG).notes == [
        "not checked for unexplored space beyond that of its claims in training: its file "
        "records no limits (format before 4)"]
