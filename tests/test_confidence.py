"""The calibrated stop (`vprobot.stopping.confidence`, `--stop confident`): the probability
against the conformal formula counted by hand, the false stops against a loop over views, and
Learn-then-Test's guarantee on synthetic episodes whose true risk is known."""

from __future__ import annotations

import dataclasses
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from vprobot.cli import main
from vprobot.config import load_config, replace
from vprobot.parts.splits import Split
from vprobot.planners.runner import plan_part
from vprobot.stop_studies import dataset
from vprobot.stop_studies.calibrate import _calibrate, calibration_jobs, stated_estimates
from vprobot.stop_studies.dataset import COLUMNS, read_dataset
from vprobot.stopping.confidence import (
    GIVE_UP_SHARES,
    MIN_PER_CATEGORY,
    THRESHOLDS,
    Calibrated,
    GoalConfidence,
    calibration_table,
    false_give_ups,
    false_stops,
    give_up_share,
    give_ups,
    quiet_share,
    stop_threshold,
    view_category,
)
from vprobot.stopping.estimator import BUNDLED_ESTIMATOR, Stated
from vprobot.stopping.features import FEATURES
from vprobot.stopping.rules import make_stop_rule
from vprobot.stopping.rules.confident import GAVE_UP, ConfidentStop, confidence_path

ROOT = Path(__file__).resolve().parents[1]
GOAL = 0.9
CALIBRATED = Calibrated("ur5", "ideal", (60.0, 45.0, 0.1, 1.0, 0.4), GOAL, "0" * 64)
GROWING = np.ones(len(FEATURES))
"""Features of a view after which the seen surface still grows (no quiet share below 1)."""


def confidence(count: int, views: np.ndarray | None = None, seed: int = 0,
               threshold: float | None = 0.95) -> GoalConfidence:
    rng = np.random.default_rng(seed)
    return GoalConfidence(rng.normal(0.0, 0.03, count), rng.uniform(0.01, 0.05, count),
                          views if views is not None else rng.integers(1, 12, count),
                          threshold, 0.05, 0.1, 100, CALIBRATED)


def by_hand(model: GoalConfidence, mean: float, std: float, rows: np.ndarray) -> float:
    """The conformal P(coverage >= goal) counted over the calibration rows `rows`: the share
    of their normalised residuals at or above the goal's, out of one more than their number
    (the conservative, unsmoothed form)."""
    scores = model.residuals[rows] / model.sigmas[rows]
    return float(np.sum(scores >= (GOAL - mean) / std) / (rows.sum() + 1))


def test_pooled_probability_is_the_share_of_calibration_scores_at_or_above_the_goals() -> None:
    # Too few views for a category of their own: one pool.
    model = confidence(MIN_PER_CATEGORY)
    assert not model.mondrian
    cases = [(0.88, 0.02, 3), (0.91, 0.01, 9), (0.95, 0.04, 1), (0.80, 0.03, 20)]
    got = model.probability(*np.array(cases).T)
    everything = np.ones(len(model.residuals), bool)
    assert got == pytest.approx([by_hand(model, mean, std, everything)
                                 for mean, std, _ in cases], abs=1e-12)


def test_mondrian_probability_counts_only_the_calibration_views_of_the_same_view_category(
        ) -> None:
    views = np.repeat([2, 5, 9], MIN_PER_CATEGORY)
    model = confidence(len(views), views)
    assert model.mondrian
    for taken in (1, 3, 4, 6, 7, 15):
        rows = view_category(model.views) == view_category(taken)
        assert model.probability(0.9, 0.02, taken)[0] == pytest.approx(
            by_hand(model, 0.9, 0.02, rows), abs=1e-12)


def test_false_stops_are_those_of_the_first_view_reaching_each_threshold() -> None:
    rng = np.random.default_rng(3)
    probabilities = [rng.uniform(0, 1, rng.integers(1, 9)) for _ in range(30)]
    coverages = [rng.uniform(0.8, 1.0, len(p)) for p in probabilities]
    thresholds = np.array([0.99, 0.9, 0.7, 0.5, 0.2])
    expected = np.zeros((30, len(thresholds)), bool)
    for episode, (probability, coverage) in enumerate(zip(probabilities, coverages, strict=True)):
        for column, threshold in enumerate(thresholds):
            for view in range(len(probability)):
                if probability[view] >= threshold:
                    expected[episode, column] = coverage[view] < GOAL
                    break
    np.testing.assert_array_equal(false_stops(probabilities, coverages, GOAL, thresholds),
                                  expected)


def _episodes(count: int, rng: np.random.Generator) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Synthetic episodes of 8 views whose stated probability is true: a view reaches the goal
    exactly when its probability exceeds the episode's uniform draw (so with that probability,
    and for good once reached, as probabilities rise)."""
    rise = np.sort(rng.uniform(0.0, 1.0, (count, 8)), axis=1) ** rng.uniform(0.3, 3.0, (count, 1))
    luck = rng.uniform(0.0, 1.0, (count, 1))
    coverage = np.where(rise > luck, GOAL + 0.01, GOAL - 0.01)
    return list(rise), list(coverage)


def test_learn_then_test_bounds_false_stops_in_all_but_delta_of_the_calibration_draws() -> None:
    """The guarantee itself: the true risk of the certified threshold (measured on 100 000 fresh
    episodes) exceeds the risk asked for in at most delta of 200 calibration draws."""
    rng = np.random.default_rng(0)
    true_risk = false_stops(*_episodes(100_000, rng), GOAL).mean(axis=0)
    risk, delta = 0.05, 0.1
    exceeded = []
    for _ in range(200):
        threshold = stop_threshold(*_episodes(300, rng), GOAL, risk, delta)
        assert threshold is not None
        exceeded.append(true_risk[np.flatnonzero(THRESHOLDS == threshold)[0]] > risk)
    assert np.mean(exceeded) <= delta
    # Not vacuous: the certified thresholds stop episodes, at a risk not far below the asked.
    assert true_risk[THRESHOLDS == threshold][0] > 0.02


def test_learn_then_test_certifies_nothing_when_even_the_highest_threshold_stops_badly() -> None:
    probabilities = [np.ones(3)] * 50
    coverages = [np.full(3, GOAL - 0.1)] * 50
    assert stop_threshold(probabilities, coverages, GOAL, 0.05, 0.1) is None
    with pytest.raises(ValueError, match=re.escape("risk and delta must lie in (0, 1)")):
        stop_threshold(probabilities, coverages, GOAL, 0.0, 0.1)


def test_a_run_gives_up_at_its_first_quiet_view_before_it_claims_the_goal_falsely_if_below_it(
) -> None:
    rng = np.random.default_rng(4)
    shares = np.array([0.005, 0.02, 0.05])
    for _ in range(200):
        views = int(rng.integers(1, 9))
        probability, quiet = rng.uniform(0, 1, views), rng.uniform(0, 0.08, views)
        coverage = rng.uniform(0.8, 1.0, views)
        expected_at, expected_false = [], []
        for share in shares:
            at = views
            for view in range(views):
                if probability[view] >= 0.7:
                    break
                if quiet[view] < share:
                    at = view
                    break
            expected_at.append(at)
            expected_false.append(at < views and coverage[at] < GOAL
                                  and bool((coverage[at + 1:] >= GOAL).any()))
        np.testing.assert_array_equal(give_ups(probability, quiet, 0.7, shares), expected_at)
        np.testing.assert_array_equal(
            false_give_ups([probability], [quiet], [coverage], GOAL, 0.7, shares)[0],
            expected_false)


def test_the_quiet_share_is_the_larger_growth_of_the_latest_two_acquisitions() -> None:
    features = np.zeros((2, len(FEATURES)))
    features[0, FEATURES.index("added_last")] = 0.03
    features[0, FEATURES.index("added_before")] = 0.01
    features[1, FEATURES.index("added_before")] = 0.02
    np.testing.assert_array_equal(quiet_share(features), [0.03, 0.02])


def _stalling(count: int, rng: np.random.Generator
              ) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """Synthetic episodes of 10 views that never claim the goal (probability 0). Half reach the
    goal at their 7th view, each view growing the surface by a share drawn above the episode's
    floor (0-4 %); the other half never do, their growth halving from 10 % a view. Giving up on
    a reaching episode before its 7th view is false (it reaches the goal later), so the risk of a
    quiet share rises with it, from about nothing, and is known by simulation."""
    reaches = rng.uniform(0.0, 1.0, (count, 1)) < 0.5
    floor = rng.uniform(0.0, 0.04, (count, 1))
    growth = np.where(reaches, rng.uniform(floor, 0.1, (count, 10)), 0.1 * 0.5 ** np.arange(10))
    coverage = np.where(reaches & (np.arange(10) >= 6), GOAL + 0.01, GOAL - 0.01)
    return [np.zeros(10)] * count, list(growth), list(coverage)


def test_learn_then_test_bounds_false_give_ups_in_all_but_delta_of_the_calibration_draws(
) -> None:
    """The give-up's guarantee: the true risk of the certified share (measured on 30 000 fresh
    episodes) exceeds the risk asked for in at most delta of 100 calibration draws."""
    rng = np.random.default_rng(1)
    probabilities, quiet, coverage = _stalling(30_000, rng)
    true_risk = false_give_ups(probabilities, quiet, coverage, GOAL, 0.9).mean(axis=0)
    assert np.all(np.diff(true_risk) >= 0) and true_risk[0] < 0.01 and true_risk[-1] > 0.2
    risk, delta = 0.05, 0.1
    certified = []
    for _ in range(100):
        share = give_up_share(*_stalling(300, rng), GOAL, 0.9, risk, delta)
        assert share is not None
        certified.append(true_risk[np.flatnonzero(GIVE_UP_SHARES == share)[0]])
    assert np.mean(np.array(certified) > risk) <= delta
    # Not vacuous: the certified shares give up, at a risk not far below the asked.
    assert np.mean(certified) > 0.01


def test_a_calibration_reads_back_as_written(tmp_path: Path) -> None:
    model = confidence(50)
    loaded = GoalConfidence.load(model.save(tmp_path / "confidence.npz"))
    for field in dataclasses.fields(model):
        np.testing.assert_array_equal(getattr(loaded, field.name), getattr(model, field.name))
    (tmp_path / "cut.npz").write_bytes(b"PK")
    with pytest.raises(ValueError, match="cannot read goal confidence"):
        GoalConfidence.load(tmp_path / "cut.npz")


def test_the_table_sets_claimed_against_observed_in_each_bin_of_the_probability() -> None:
    rows = calibration_table(np.array([0.1, 0.3, 0.85, 0.97, 0.97, 1.0]),
                             np.array([False, True, True, True, False, True]))
    assert [(row["views"], row["observed"]) for row in rows if row["views"]] == [
        (2, 0.5), (1, 1.0), (2, 0.5), (1, 1.0)]
    assert rows[0]["claimed"] == pytest.approx(0.2)


@pytest.fixture
def calibrated_estimator(tmp_path: Path) -> Path:
    """A copy of the bundled paper estimator with a calibration for the default config."""
    path = tmp_path / "estimator.npz"
    shutil.copyfile(BUNDLED_ESTIMATOR, path)
    dataclasses.replace(confidence(50), calibrated=Calibrated.of(load_config(), path)).save(
        confidence_path(path))
    return path


def test_the_rule_is_refused_for_another_robot_or_goal_naming_what_differs(
        calibrated_estimator: Path) -> None:
    config = load_config()
    assert isinstance(make_stop_rule("confident", config, calibrated_estimator), ConfidentStop)
    other = replace(replace(config, "cell", robot="panda"), "env", coverage_goal=0.8)
    assert config.cell.robot != "panda"
    with pytest.raises(ValueError, match=re.escape(
            f"another run than this: robot 'panda' (calibrated: {config.cell.robot!r}); goal "
            f"0.8 (calibrated: 0.9)")):
        make_stop_rule("confident", other, calibrated_estimator)
    alone = calibrated_estimator.parent / "alone" / "estimator.npz"
    alone.parent.mkdir()
    shutil.copyfile(calibrated_estimator, alone)
    with pytest.raises(ValueError, match="make one with `vprobot stop calibrate`"):
        make_stop_rule("confident", config, alone)


def test_the_rule_stops_once_the_probability_reaches_its_threshold(
        calibrated_estimator: Path) -> None:
    rule = make_stop_rule("confident", load_config(), calibrated_estimator)
    assert isinstance(rule, ConfidentStop) and rule.threshold == 0.95
    everything = np.ones(50, bool)
    for mean in np.linspace(0.85, 1.0, 31):
        expected = by_hand(rule.calibration, mean, 0.01, everything) >= 0.95
        reason = rule.decide(Stated(mean, 0.01), GROWING, 4)
        assert (reason is not None) == expected
        if reason is not None:
            assert reason.startswith("P(coverage ≥ 90 %) = ") and "certified" in reason
    chosen = make_stop_rule("confident:0.5", load_config(), calibrated_estimator)
    assert isinstance(chosen, ConfidentStop) and chosen.threshold == 0.5


def test_the_rule_gives_up_where_the_surface_stops_growing_below_its_threshold(
        calibrated_estimator: Path) -> None:
    config = load_config()
    path = confidence_path(calibrated_estimator)
    dataclasses.replace(GoalConfidence.load(path), give_up=0.01).save(path)
    rule = make_stop_rule("confident", config, calibrated_estimator)
    assert isinstance(rule, ConfidentStop)
    quiet = np.zeros(len(FEATURES))
    quiet[[FEATURES.index("added_last"), FEATURES.index("added_before")]] = 0.009
    low = Stated(0.5, 0.01)
    reason = rule.decide(low, quiet, 6)
    assert reason is not None and reason.startswith(f"{GAVE_UP}: P(coverage ≥ 90 %) = ")
    assert "less than 1 % to the seen surface" in reason and "false give-ups" in reason
    # Growing by the share or more, or a threshold other than the certified one: no give-up.
    quiet[FEATURES.index("added_before")] = 0.01
    assert rule.decide(low, quiet, 6) is None
    quiet[FEATURES.index("added_before")] = 0.0
    assert make_stop_rule("confident:0.9", config, calibrated_estimator).decide(
        low, quiet, 6) is None
    # A calibration that certified no share never gives up.
    dataclasses.replace(GoalConfidence.load(path), give_up=None).save(path)
    assert make_stop_rule("confident", config, calibrated_estimator).decide(
        low, quiet, 6) is None


def test_calibrating_on_rollouts_fits_the_probability_on_half_of_each_planners_episodes(
        tmp_path: Path) -> None:
    """On committed rollouts of the paper cell (the estimate's validation list): the conformal
    scores are the usable views of each planner's first, third, ... episode, the threshold's
    episodes the others, and the calibration lands beside the estimator's copy, which the rule
    then accepts."""
    config = load_config()
    data = read_dataset(ROOT / "results" / "stop_estimate" / "validation.csv")
    estimator = tmp_path / "estimator.npz"
    shutil.copyfile(BUNDLED_ESTIMATOR, estimator)
    figures = _calibrate(config, tmp_path, estimator, data, 0.05, 0.1)
    mean, std, usable = stated_estimates(config, estimator, data)
    fit = np.zeros(len(usable), bool)
    for planner in set(data.planners):
        numbers = sorted(set(data.episodes[data.planners == planner]))
        fit |= np.isin(data.episodes, numbers[::2])
    assert len(set(data.planners[fit])) == len(set(data.planners[~fit])) > 1
    model = GoalConfidence.load(confidence_path(estimator))
    np.testing.assert_array_equal(model.residuals, data.coverage[usable & fit]
                                  - mean[usable & fit])
    np.testing.assert_array_equal(model.sigmas, std[usable & fit])
    assert figures["threshold_episodes"] == model.episodes == len(np.unique(data.episodes[~fit]))
    assert sum(row["views"] for row in figures["table"]) == np.sum(usable & ~fit)
    assert "# Calibrated stop" in (tmp_path / "calibration.md").read_text()
    if model.threshold is not None:
        assert isinstance(make_stop_rule("confident", config, estimator), ConfidentStop)


def test_calibration_episodes_take_the_calibration_objects_and_planners_in_turn() -> None:
    split = Split.load()
    objects = split.calibration_objects()
    jobs = calibration_jobs(load_config(), len(objects) + 2, 7, ("nbv", "uniform4"), split)
    assert [spec.part for spec, _ in jobs] == [*objects, *objects[:2]]
    assert [planner for _, planner in jobs] == ["nbv", "uniform4"] * (len(objects) // 2 + 1)
    assert jobs == calibration_jobs(load_config(), len(objects) + 2, 7, ("nbv", "uniform4"))
    assert [spec.seed for spec, _ in jobs] != [
        spec.seed for spec, _ in calibration_jobs(load_config(), len(objects) + 2, 8)]


def test_stop_calibrate_writes_the_calibration_and_resumes_its_rollouts(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's plumbing, with each rollout replaced by one of the committed rollouts (a
    real one would first build a new part's ground truth)."""
    committed = (ROOT / "results" / "stop_estimate" / "validation.csv").read_text().splitlines()
    columns = committed[0].split(",")
    episodes: dict[str, list[dict[str, object]]] = {}
    for line in committed[1:]:
        row = dict(zip(columns, line.split(","), strict=True))
        episodes.setdefault(row["episode"], []).append(
            {key: value for key, value in row.items() if key not in COLUMNS[:5]})
    played: list[str] = []

    def rollout(config: object, spec: object, planner: str) -> list[dict[str, object]]:
        played.append(planner)
        return list(episodes.values())[len(played)]

    monkeypatch.setattr(dataset, "rollout", rollout)
    out = tmp_path / "calibrated"
    command = ["stop", "calibrate", "--out", str(out), "--episodes", "6"]
    assert main(command) == 0 and len(played) == 6
    assert (out / "confidence.npz").is_file() and (out / "estimator.npz").is_file()
    assert "# Calibrated stop" in (out / "calibration.md").read_text()
    assert main(command) == 0 and len(played) == 6


def test_a_plan_stopped_by_the_rule_records_the_probability_after_each_view(
        calibrated_estimator: Path) -> None:
    config = load_config()
    _, _, document, summary = plan_part(config, planner="nbv", stop="confident:0.6",
                                        estimator=calibrated_estimator)
    rule = make_stop_rule("confident:0.6", config, calibrated_estimator)
    assert isinstance(rule, ConfidentStop)
    everything = np.ones(len(rule.calibration.residuals), bool)
    stated = [view["estimate"] for view in document["views"] if view["estimate"] is not None]
    assert stated
    for view in stated:
        assert view["p_goal"] == pytest.approx(
            by_hand(rule.calibration, view["mean"], view["std"], everything), abs=1e-12)
    assert document["stop_rule"] == "confident:0.6"
    if document["stop_reason"].startswith("P(coverage"):
        assert float(document["stop_reason"].split("= ")[1].split(" ")[0]) >= 0.6
    assert "P(goal)" in summary


def test_a_held_back_estimate_stops_confident_but_not_estimate(calibrated_estimator: Path) -> None:
    """`estimate`'s guard against unexplored space belongs to its normal claims; `confident`'s
    calibration measured the errors on such views too."""
    config = load_config()
    held = Stated(0.999, 0.001, held="held back from a stop: unknown above 0.1")
    assert make_stop_rule("estimate", config, calibrated_estimator).decide(
        held, GROWING, 6) is None
    assert dataclasses.replace(held, held=None).mean - 3 * held.std >= GOAL
    confident = make_stop_rule("confident", config, calibrated_estimator)
    assert isinstance(confident, ConfidentStop)
    assert confident.decide(held, GROWING, 6) is not None
