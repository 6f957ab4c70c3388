"""When the coverage estimate may be trusted (issue 30): a view that adds no new surface never
raises it, another sensor or a feature far outside the training range refuses it, and a bad
estimator file is refused on load in one line naming it."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from vprobot.cli import main
from vprobot.config import Config, replace, with_sensor
from vprobot.episode import PartScene, seeded_episode
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.planners.runner import run, summary
from vprobot.stopping.estimator import (
    BUNDLED_ESTIMATOR,
    NEW_SURFACE,
    REFUSE_RANGES,
    WIDEN_PER_RANGE,
    CoverageEstimator,
    EstimateTracker,
    load_estimator,
)
from vprobot.stopping.features import FEATURES, episode_features
from vprobot.stopping.rules.estimate import view_estimates

CONFIG = Config()
Z = 1.6448536  # one-sided 95 %


@pytest.fixture(scope="module")
def motor() -> PartScene:
    return PartScene.load(CONFIG, DEFAULT_MOTOR)


def test_a_repeated_view_never_raises_the_estimate_nor_its_lower_bound(
        motor: PartScene) -> None:
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    views = list(run(CONFIG, motor, "nbv", spec, "free", stop="views:3").record.views)
    repeated = views + [views[-1]] * 8
    estimator = load_estimator()
    # The repeats add nothing to the seen surface (the reference the guard must follow).
    occupied = episode_features(CONFIG, repeated)[:, FEATURES.index("occupied")]
    assert np.all(occupied[3:] <= occupied[2] / (1.0 - NEW_SURFACE))
    stated, _ = view_estimates(CONFIG, repeated, estimator, "nbv")
    mean, std = stated[2:, 0], stated[2:, 1]
    assert np.all(np.isfinite(mean))
    assert np.all(np.diff(mean) <= 0.0) and np.all(np.diff(mean - Z * std) <= 0.0)


def test_another_sensor_refuses_the_estimate_and_the_summary_says_why(
        motor: PartScene) -> None:
    # phoxi_m's geometry at a small resolution, to keep the test fast: the features count per
    # pixel, so the check compares the opening angles, the range and the working distance.
    config = replace(replace(with_sensor(CONFIG, "phoxi_m"), "sensor", resolution=(107, 80)),
                     "env", max_acquisitions=2)
    scene = PartScene.load(config, DEFAULT_MOTOR)
    spec = seeded_episode(config.env, DEFAULT_MOTOR, 0)
    result = run(config, scene, "nbv", spec, "free", stop="estimate:0.5", estimates=True)
    assert result.stop_reason == "max views"
    assert result.estimates is not None and np.isnan(result.estimates).all()
    text = summary(result, config)
    assert "  estimate not used: fitted on sensor 'paper' (27 x 25 deg" in text
    assert "this run uses 'phoxi_m' (48.92 x 37.58 deg" in text
    assert text.count("refused") == len(result.record.views)


def test_another_sensing_model_refuses_the_estimate_with_the_reason(tmp_path: Path) -> None:
    # The bundled estimator was fit on the ideal sensor (its file predates the record, which
    # reads as ideal); one recorded as fit on structured light is refused on the ideal sensor.
    estimator = load_estimator()
    assert estimator.domain is not None and estimator.domain.sensing == "ideal"
    other = CoverageEstimator.load(dataclasses.replace(estimator, domain=dataclasses.replace(
        estimator.domain, sensing="structured_light")).save(tmp_path / "other.npz"))
    assert other.domain.sensing == "structured_light"
    features = (estimator.domain.low + estimator.domain.high) / 2
    assert not EstimateTracker(estimator, CONFIG).update(features).refused
    stated = EstimateTracker(other, CONFIG).update(features)
    assert stated.refused and np.isnan(stated.mean)
    assert stated.note == ("not used: fitted on the structured_light sensing model, this run "
                           "uses ideal")


def test_a_feature_outside_its_training_range_widens_the_estimate_and_far_outside_refuses_it(
) -> None:
    estimator = load_estimator()
    domain = estimator.domain
    assert domain is not None
    extent = FEATURES.index("extent")
    inside = (domain.low + domain.high) / 2.0
    width = domain.high[extent] - domain.low[extent]
    std = float(estimator.estimate(inside)[1])
    assert EstimateTracker(estimator, CONFIG).update(inside).std == std
    near = inside.copy()
    near[extent] = domain.high[extent] + 0.1 * width
    widened = EstimateTracker(estimator, CONFIG).update(near)
    raw = float(estimator.estimate(near)[1])
    assert widened.std == pytest.approx(raw * (1.0 + WIDEN_PER_RANGE * 0.1))
    assert widened.note is not None and widened.note.startswith("widened: extent outside")
    far = inside.copy()
    far[extent] = 1000.0 * domain.high[extent]  # millimetres read as metres
    refused = EstimateTracker(estimator, CONFIG).update(far)
    assert refused.refused and refused.note == (
        f"not used: extent outside its training range {domain.low[extent]:.4g} to "
        f"{domain.high[extent]:.4g} by more than {REFUSE_RANGES:g} of that range")


def test_a_planner_the_estimate_was_not_fit_on_is_named() -> None:
    estimator = load_estimator()
    assert EstimateTracker(estimator, CONFIG, "uniform").notes == []
    assert EstimateTracker(estimator, CONFIG, "agent").notes == [
        "may be less accurate: planner 'agent' is not among those it was fit on (random2, "
        "uniform4, uniform6, uniform8, nbv)"]


def test_the_training_domain_survives_a_save_and_a_format_2_file_still_loads(
        tmp_path: Path) -> None:
    estimator = load_estimator()
    loaded = CoverageEstimator.load(estimator.save(tmp_path / "estimator.npz"))
    assert loaded.domain is not None and estimator.domain is not None
    assert np.array_equal(loaded.domain.low, estimator.domain.low)
    assert (loaded.domain.sensor, loaded.domain.planners) == (
        (27.0, 25.0, 0.3, 0.5, 0.47), ("random2", "uniform4", "uniform6", "uniform8", "nbv"))
    with np.load(tmp_path / "estimator.npz") as data:
        arrays = {key: data[key] for key in data.files if not key.startswith("domain_")}
    np.savez(tmp_path / "old.npz", **(arrays | {"format": np.array(2)}))
    old = CoverageEstimator.load(tmp_path / "old.npz")
    assert old.domain is None and old.unseen_scale == estimator.unseen_scale
    assert EstimateTracker(old, CONFIG).notes == [
        "not checked for inputs unlike its training data: its file records no training domain "
        "(format before 3)"]


def _bundled_arrays() -> dict[str, np.ndarray]:
    with np.load(BUNDLED_ESTIMATOR) as data:
        return {key: data[key] for key in data.files}


def _nan_weight(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    weight = arrays["w_0_1"].copy()
    weight[0, 0] = np.nan
    return arrays | {"w_0_1": weight}


@pytest.mark.parametrize(("change", "problem"), [
    (_nan_weight, "member 0 layer 1: a weight is not finite"),
    (lambda arrays: arrays | {"scale": np.zeros_like(arrays["scale"])},
     "shift must be finite and scale finite and > 0"),
    (lambda arrays: arrays | {"shift": arrays["shift"][:5]},
     "shift and scale need one value per feature (18), got shapes (5,) and (18,)"),
    (lambda arrays: arrays | {"w_1_0": arrays["w_1_0"].T},
     "member 1 layer 0: weight (32, 18) and bias (32,) do not take 18 inputs"),
    (lambda arrays: arrays | {"b_0_2": arrays["b_0_2"][:1]},
     "member 0 layer 2: weight (32, 2) and bias (1,) do not take 32 inputs to 2 outputs"),
])
def test_an_estimator_with_bad_arrays_is_refused_on_load_naming_the_file(
        change, problem: str, tmp_path: Path) -> None:
    path = tmp_path / "bad.npz"
    np.savez(path, **change(_bundled_arrays()))
    with pytest.raises(ValueError) as error:
        CoverageEstimator.load(path)
    assert str(error.value) == f"cannot read coverage estimator {path}: {problem}"


@pytest.mark.parametrize("size", [0, 30000])
def test_an_empty_or_cut_estimator_file_is_one_line_naming_it_and_exit_2(
        size: int, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "cut.npz"
    path.write_bytes(BUNDLED_ESTIMATOR.read_bytes()[:size])
    assert main(["plan", "--no-summary", "--planner", "nbv", "--carrier", "free", "--stop",
                 "estimate",
                 "--estimator", str(path), "--out", str(tmp_path / "plan.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cannot read coverage estimator {path}: " in err
    assert not (tmp_path / "plan.json").exists()


def test_a_refused_estimate_is_null_in_the_plan(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    # An estimator fit on another sensor: every estimate is refused, the JSON still written.
    estimator = load_estimator()
    assert estimator.domain is not None
    other = dataclasses.replace(estimator, domain=dataclasses.replace(
        estimator.domain, sensor=(40.0, 30.0, 0.3, 0.5, 0.47)))
    path = other.save(tmp_path / "other.npz")
    plan = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--planner", "nbv", "--carrier", "free", "--stop",
                 "estimate",
                 "--estimator", str(path), "--out", str(plan)]) == 0
    document = json.loads(plan.read_text())
    assert not document["stop_reason"].startswith("estimate")
    assert all(view["estimate"] is None for view in document["views"])
    assert "estimate not used: fitted on sensor 'custom' (40 x 30 deg" in capsys.readouterr().out
