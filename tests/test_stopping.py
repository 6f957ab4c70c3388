"""The model-free coverage estimate: its features, its fit, its calibration helpers."""

from __future__ import annotations

import dataclasses
import functools
import itertools
import subprocess
import sys
import time
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vprobot.cli import main
from vprobot.config import Config
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import FREE, OCCUPIED, UNKNOWN
from vprobot.episode import (
    EpisodeSpec,
    ViewRecord,
    episode_list,
    seeded_episode,
    write_episode_list,
)
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import Pose
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.parts.generated import family_of
from vprobot.parts.splits import Split
from vprobot.stop_studies import dataset as dataset_module
from vprobot.stop_studies import folds as folds_module
from vprobot.stop_studies import report as report_module
from vprobot.stop_studies import study as study_module
from vprobot.stop_studies.calibration import interval_coverage, mae_per_view, unseen_scale
from vprobot.stop_studies.dataset import Dataset, training_jobs
from vprobot.stop_studies.folds import family_folds
from vprobot.stop_studies.report import fit_estimate
from vprobot.stopping.estimator import UNEXPLORED, CoverageEstimator, fit
from vprobot.stopping.features import BAND_NEAR_DEG, FEATURES, CoverageFeatures

CONFIG = Config()
CENTER = np.asarray(CONFIG.cell.object_center_m, dtype=float)
SENSOR = SensorModel.from_config(CONFIG.sensor)
PIXELS = SENSOR.rays_per_frame
FAMILIES_DRAWN = 22
"""The least count of training episodes whose draw from seed 0 holds every training family."""


def view(side: float | None, plane_x: float = 0.0, half: int = 0,
         blocked: int = 0) -> ViewRecord:
    """A view from 0.47 m along world x (side +1 or -1) looking at the cell's centre that
    measured the plane x = centre + `plane_x` on the (2 half + 1)^2 pixels about the image
    centre, the last `blocked` pixels blocked; side None: an unreached request."""
    position = CENTER + np.array([0.47 * (side or 1.0), 0.0, 0.0])
    pose = Pose.look_at(position, CENTER)
    if side is None:
        return ViewRecord(requested=pose, reachable=False, reason="collision", joints=None,
                          path=None, sensor_pose=None, points_world=np.zeros((0, 3)),
                          coverage=0.0)
    width, height = SENSOR.resolution
    rows, columns = np.meshgrid(np.arange(-half, half + 1) + height // 2,
                                np.arange(-half, half + 1) + width // 2, indexing="ij")
    pixels = (rows * width + columns).ravel()
    rays = SENSOR.ray_directions[pixels] @ pose.rotation.T
    distance = (CENTER[0] + plane_x - position[0]) / rays[:, 0]
    return ViewRecord(requested=pose, reachable=True, reason=None, joints=None, path=None,
                      sensor_pose=pose, points_world=position + rays * distance[:, None],
                      coverage=0.0, pixels=pixels,
                      blocked_pixels=PIXELS - 1 - np.arange(blocked))


def test_features_of_a_hand_built_episode_match_hand_computed_values() -> None:
    features = CoverageFeatures(CONFIG)
    origin, voxel = features.grid.origin, features.grid.voxel_m

    def voxels(record: ViewRecord) -> set[tuple[int, ...]]:
        return {tuple(cell) for cell in np.floor((record.points_world - origin) / voxel)
                .astype(int)}

    # A plate in the middle of a voxel layer: a square patch of it seen twice from +x, an
    # unreached request, then a larger patch of it seen from -x, two pixels blocked.
    front, back = view(1.0, 0.005, 60), view(-1.0, 0.005, 80, blocked=2)
    views = [front, view(1.0, 0.005, 60), view(None), back]
    rows = [dict(zip(FEATURES, features.update(views[:n]), strict=True)) for n in range(1, 5)]
    total, first, second = features.grid.state.size, voxels(front), voxels(back)
    occupied = len(first | second)
    assert rows[0]["occupied"] == pytest.approx(len(first) / total)
    assert (rows[0]["added_last"], rows[0]["novel_last"]) == (1.0, 1.0)
    assert (rows[1]["added_last"], rows[1]["novel_last"], rows[1]["added_before"]) == (
        0.0, 0.0, 1.0)
    assert rows[2] == pytest.approx({**rows[1], "requested": 3})
    last = rows[3]
    band = sphere_directions(128, np.deg2rad(120.0))
    angle_to_x = np.degrees(np.arccos(np.abs(band[:, 0])))
    assert last == pytest.approx({
        **last,
        "requested": 4, "acquired": 3, "occupied": occupied / total,
        "added_last": len(second - first) / occupied, "added_before": 0.0,
        "novel_last": len(second - first) / len(second),
        "points": (2 * 121**2 + 161**2) / PIXELS, "points_last": 161**2 / PIXELS,
        "blocked": 2 / PIXELS / 3, "blocked_last": 2 / PIXELS,
        # Directions +x, +x, -x: their mean is (1/3, 0, 0).
        "spread": 2 / 3, "band_seen": float((angle_to_x <= BAND_NEAR_DEG).mean()),
    })
    # Rear side and open surface by brute force over the occupied voxels' neighbours.
    state = features.grid.state
    steps = [np.array(step) for step in itertools.product((-1, 0, 1), repeat=3)
             if sum(map(abs, step)) == 1]

    def neighbours(cell: np.ndarray) -> list[tuple[int, ...]]:
        return [tuple(cell + step) for step in steps
                if all(0 <= c < n for c, n in zip(cell + step, state.shape, strict=True))]

    rear = {cell for seen in first | second for cell in neighbours(np.array(seen))
            if state[cell] == UNKNOWN}
    open_surface = [cell for cell in rear if any(state[near] == FREE
                                                 for near in neighbours(np.array(cell)))]
    assert last["rear_side"] == pytest.approx(len(rear) / occupied)
    assert last["open_surface"] == pytest.approx(len(open_surface) / occupied)
    assert len(open_surface) <= len(rear)
    # The bounding box of the occupied voxels, and the unknown voxels inside it, cell by cell.
    cells = np.array(sorted(first | second))
    low, high = cells.min(axis=0), cells.max(axis=0)
    assert last["extent"] == pytest.approx(voxel * np.linalg.norm(high - low + 1))
    inside = sum(state[cell] == UNKNOWN for cell in itertools.product(
        *(range(a, b + 1) for a, b in zip(low, high, strict=True))))
    assert last["hull_unknown"] == pytest.approx(inside / occupied)
    assert 0 < len(second - first) < len(second)


def test_rear_side_counts_unknown_voxels_by_occupied_ones_open_surface_by_free_ones_too() -> None:
    features = CoverageFeatures(CONFIG)
    features.grid.state[10, 10, 10] = OCCUPIED
    features.grid.state[11, 11, 10] = FREE
    values = dict(zip(FEATURES, features.update([]), strict=True))
    # All six face neighbours of the occupied voxel are unknown; two of them, (11, 10, 10) and
    # (10, 11, 10), are face neighbours of the free voxel too.
    assert (values["rear_side"], values["open_surface"]) == (6.0, 2.0)


def test_features_refuse_fewer_views_than_already_integrated() -> None:
    features = CoverageFeatures(CONFIG)
    features.update([view(None)] * 2)
    with pytest.raises(ValueError, match="call reset"):
        features.update([])


def test_fit_recovers_a_linear_relation_and_its_noise_and_survives_a_save(
        tmp_path: Path) -> None:
    rng = np.random.default_rng(0)

    def sample(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x = rng.uniform(0.0, 1.0, size=(count, 2))
        truth = 0.2 + 0.5 * x[:, 0] + 0.2 * x[:, 1]
        return x, truth, truth + rng.normal(0.0, 0.02, size=count)

    x, _, y = sample(400)
    vx, _, vy = sample(200)
    estimator = fit(x, y, vx, vy, ("a", "b"), seed=0, members=2, hidden=16, steps=800)
    tx, truth, _ = sample(200)
    mean, std = estimator.estimate(tx)
    assert np.abs(mean - truth).mean() < 0.01
    assert 0.012 < float(np.median(std)) < 0.035
    loaded = CoverageEstimator.load(estimator.save(tmp_path / "estimator.npz"))
    assert np.array_equal(loaded.estimate(tx)[0], mean)
    one_mean, one_std = loaded.estimate(tx[0])
    assert one_mean.shape == one_std.shape == () and one_mean == pytest.approx(mean[0])
    with pytest.raises(ValueError, match="expected 2 features"):
        estimator.estimate(np.zeros(3))


def test_interval_coverage_is_the_level_on_gaussian_draws_and_counts_a_hand_case() -> None:
    rng = np.random.default_rng(1)
    mean = rng.uniform(0.5, 1.0, size=200_000)
    std = rng.uniform(0.01, 0.05, size=mean.size)
    truth = mean + std * rng.standard_normal(mean.size)
    levels = (0.5, 0.9, 0.95)
    assert interval_coverage(mean, std, truth, levels) == pytest.approx(levels, abs=0.005)
    # Errors of 0.5, 1.5 and 2.5 std: within 1 std (68.27 %) one, within 2.576 (99 %) all.
    hand = interval_coverage(np.zeros(3), np.ones(3), np.array([0.5, -1.5, 2.5]),
                             (0.6827, 0.99))
    assert hand == pytest.approx([1 / 3, 1.0])
    with pytest.raises(ValueError, match=r"levels must lie in \(0, 1\)"):
        interval_coverage(np.zeros(1), np.ones(1), np.zeros(1), (1.0,))


def test_unseen_scale_is_the_least_factor_that_makes_the_interval_hold_the_level() -> None:
    # Hand case: std 0, disagreement 1, errors 0.1 .. 0.4; the 50 % interval (z = 0.6745)
    # holds two of four once c reaches 0.2^2 / z^2.
    hand = unseen_scale(np.zeros(4), np.zeros(4), np.ones(4), np.array([0.1, -0.2, 0.3, 0.4]),
                        level=0.5)
    assert hand == pytest.approx(0.2 ** 2 / 0.6744897501960817 ** 2)
    # Family-biased residuals far beyond the stated std, larger where the members disagree;
    # brute force: the least of the candidate factors (each case's own) that holds 95 %.
    rng = np.random.default_rng(2)
    std = rng.uniform(0.005, 0.02, size=600)
    disagreement = rng.uniform(0.1, 1.0, size=600) * 1e-4
    truth = rng.uniform(0.5, 1.0, size=600)
    mean = truth + rng.choice([-8.0, 0.0, 5.0], size=600) * np.sqrt(disagreement) \
        + std * rng.normal(size=600)
    scale = unseen_scale(mean, std, disagreement, truth)

    def holds(factor: float) -> float:
        return interval_coverage(mean, np.sqrt(std ** 2 + factor * disagreement), truth,
                                 (0.95,))[0]

    candidates = np.sort(np.maximum(((truth - mean) ** 2 / 1.959963984540054 ** 2 - std ** 2)
                                    / disagreement, 0.0))
    brute = next(value for value in candidates if holds(value * (1 + 1e-9)) >= 0.95)
    assert holds(0.0) < 0.8 and holds(scale) >= 0.95 and scale == pytest.approx(brute, rel=1e-6)
    assert holds(scale * 0.999) < 0.95
    with pytest.raises(ValueError, match="no factor on the disagreement holds 95 %"):
        unseen_scale(np.zeros(2), np.full(2, 0.01), np.zeros(2), np.ones(2))


def test_a_family_fold_never_sees_its_family_and_is_reused_from_its_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Feature 0 is the family's number, so what each fit was given shows which families it saw.
    names = np.array(["motor", "flange", "lever"])

    def dataset(families: list[int]) -> Dataset:
        rng = np.random.default_rng(len(families))
        return Dataset(np.column_stack([families, rng.uniform(size=len(families))]),
                       rng.uniform(0.5, 1.0, len(families)), np.ones(len(families), dtype=int),
                       np.array(["nbv"] * len(families)), names[families],
                       np.arange(len(families)))

    training, validation = dataset([0, 1, 2] * 6), dataset([0, 1, 2, 2])
    seen: list[tuple[set[float], set[float]]] = []

    def spy(features: np.ndarray, coverage: np.ndarray, check: np.ndarray, *args: object,
            **kwargs: object) -> CoverageEstimator:
        seen.append((set(features[:, 0]), set(check[:, 0])))
        return fit(features, coverage, check, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(folds_module, "fit", spy)
    options = {"members": 1, "hidden": 2, "steps": 25}
    pooled = family_folds(training, validation, ["flange", "lever"], ("family", "x"),
                          out_dir=tmp_path, progress=False, **options)
    assert seen == [({0.0, 2.0}, {0.0, 2.0}), ({0.0, 1.0}, {0.0, 1.0})]
    # Scored on the left-out family's rows of both lists: 6 + 1 flange, 6 + 2 lever.
    assert list(pooled.families) == ["flange"] * 7 + ["lever"] * 8
    again = family_folds(training, validation, ["flange", "lever"], ("family", "x"),
                         out_dir=tmp_path, progress=False, **options)
    assert len(seen) == 2 and np.array_equal(again.mean, pooled.mean)
    with pytest.raises(ValueError, match="cannot leave out family 'pulley'"):
        family_folds(training, validation, ["pulley"], ("family", "x"), progress=False)


def test_the_widening_scales_the_disagreement_and_survives_a_save(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    x = rng.uniform(size=(40, 2))
    stated = fit(x, rng.uniform(0.5, 1.0, 40), x, rng.uniform(0.5, 1.0, 40), ("a", "b"),
                 members=3, hidden=4, steps=25)
    widened = dataclasses.replace(stated, unseen_scale=7.0)
    mean, std = stated.estimate(x)
    wide_mean, wide_std = widened.estimate(x)
    # Brute force from the members: the mixture's variance plus 7 times that of their means.
    members = [dataclasses.replace(stated, layers=(member,)).estimate(x) for member in
               stated.layers]
    means = np.array([one[0] for one in members])
    variances = np.array([one[1] for one in members]) ** 2
    expected = variances.mean(axis=0) + 8.0 * means.var(axis=0)
    assert np.array_equal(wide_mean, mean) and wide_std ** 2 == pytest.approx(expected)
    assert std ** 2 == pytest.approx(variances.mean(axis=0) + means.var(axis=0))
    loaded = CoverageEstimator.load(widened.save(tmp_path / "estimator.npz"))
    assert loaded.unseen_scale == 7.0 and np.array_equal(loaded.estimate(x)[1], wide_std)
    # A format 1 file (before the widening) loads with none; an unknown format is refused.
    with np.load(tmp_path / "estimator.npz") as data:
        arrays = {key: data[key] for key in data.files if key != "unseen_scale"}
    np.savez(tmp_path / "old.npz", **(arrays | {"format": np.array(1)}))
    assert np.array_equal(CoverageEstimator.load(tmp_path / "old.npz").estimate(x)[1], std)
    np.savez(tmp_path / "new.npz", **(arrays | {"format": np.array(9)}))
    with pytest.raises(ValueError, match="estimator format 9, expected 1 to 4"):
        CoverageEstimator.load(tmp_path / "new.npz")
    with pytest.raises(ValueError, match="unseen_scale must be finite and >= 0, got -1"):
        dataclasses.replace(stated, unseen_scale=-1.0)


def test_mae_per_view_averages_each_view_count_apart() -> None:
    rows = mae_per_view(np.array([0.5, 0.6, 0.9]), np.array([0.4, 0.7, 0.95]),
                        np.array([1, 1, 2]))
    assert [(v, round(m, 9), n) for v, m, n in rows] == [(1, 0.1, 2), (2, 0.05, 1)]


def test_stop_fit_refuses_a_folder_of_rollouts_drawn_otherwise(tmp_path: Path) -> None:
    (tmp_path / "dataset.json").write_text('{"split": 1, "episodes": 7}')
    with pytest.raises(ValueError, match="holds rollouts drawn otherwise"):
        fit_estimate(CONFIG, tmp_path, episodes=FAMILIES_DRAWN, progress=False)
    # The lock is removed as the command ends.
    assert sorted(path.name for path in tmp_path.iterdir()) == ["dataset.json"]


@pytest.mark.parametrize("option, message", [
    (["--episodes", "0"], "--episodes: must be an integer >= 1"),
    (["--planners", "bogus"], "unknown planner 'bogus'"),
])
def test_stop_fit_refuses_bad_options_with_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture, option: list[str], message: str) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["stop", "fit", "--out", str(tmp_path / "out"), *option])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err
    assert message in error and len(error.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


class FakeRollouts:
    """Stands in for the robot in the loop: an episode of seed s has 1 + s % 3 views whose
    coverage and features follow from s; counts the episodes run, and raises KeyboardInterrupt
    (Ctrl-C) in place of episode `interrupt_at` (counted from 0) when set."""

    def __init__(self) -> None:
        self.runs = 0
        self.interrupt_at: int | None = None

    def play(self, config: Config, scene: object, planner: str, spec: EpisodeSpec
             ) -> tuple[list[types.SimpleNamespace], None]:
        if self.runs == self.interrupt_at:
            raise KeyboardInterrupt
        self.runs += 1
        return [types.SimpleNamespace(coverage=0.3 + 0.2 * view + spec.seed % 10 / 100)
                for view in range(1 + spec.seed % 3)], None

    @staticmethod
    def features(config: Config, views: list[types.SimpleNamespace], grid: None
                 ) -> list[np.ndarray]:
        return [np.full(len(FEATURES), view.coverage + 0.01 * number)
                for number, view in enumerate(views)]


@pytest.fixture
def fake_rollouts(monkeypatch: pytest.MonkeyPatch) -> FakeRollouts:
    """Rollouts in no time (`FakeRollouts`), and tiny estimator fits."""
    fake = FakeRollouts()
    monkeypatch.setattr(dataset_module, "PartScene",
                        types.SimpleNamespace(load=lambda *args: None))
    monkeypatch.setattr(dataset_module, "play", fake.play)
    monkeypatch.setattr(dataset_module, "episode_features", fake.features)
    tiny = functools.partial(fit, members=2, hidden=4, steps=25)
    monkeypatch.setattr(report_module, "fit", tiny)
    monkeypatch.setattr(folds_module, "fit", tiny)
    return fake


def _episode_lists(folder: Path, *names: str) -> list[Path]:
    """Episode lists at `names` in `folder`, each of two episodes on the default motor."""
    paths = [folder / name for name in names]
    for path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_episode_list(path, episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1]))
    return paths


def test_stop_fit_refuses_a_count_that_draws_no_episode_of_a_family_before_any_rollout(
        tmp_path: Path, capsys: pytest.CaptureFixture, fake_rollouts: FakeRollouts) -> None:
    out = tmp_path / "out"
    assert main(["stop", "fit", "--out", str(out), "--episodes", "6"]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1
    assert "--episodes 6 with --seed 0 draws no training episode of family" in error
    assert f"--episodes {FAMILIES_DRAWN} is the least count that draws every family" in error
    assert fake_rollouts.runs == 0 and not out.exists()
    # The count named draws every training family (by the objects' names), none below it does.
    families = {family_of(spec.part) for spec, _ in training_jobs(CONFIG, FAMILIES_DRAWN, 0)}
    assert set(Split.load().training_families) <= families
    for count in range(6, FAMILIES_DRAWN):
        with pytest.raises(ValueError, match=f"--episodes {FAMILIES_DRAWN} is the least"):
            training_jobs(CONFIG, count, 0)


def test_stop_fit_records_the_limits_of_unexplored_space_for_a_stop(
        tmp_path: Path, fake_rollouts: FakeRollouts) -> None:
    fit_estimate(CONFIG, tmp_path, episodes=FAMILIES_DRAWN, planners=["random2"],
                 progress=False)
    estimator = CoverageEstimator.load(tmp_path / "estimator.npz")
    assert estimator.domain is not None and estimator.domain.claimed is not None
    unexplored = [FEATURES.index(name) for name in UNEXPLORED]
    others = np.setdiff1d(np.arange(len(FEATURES)), unexplored)
    assert np.all(estimator.domain.claimed[others] == np.inf)
    assert np.all(estimator.domain.claimed[unexplored] < np.inf)


def test_an_interrupted_stop_fit_keeps_its_finished_episodes_and_a_rerun_runs_only_the_rest(
        tmp_path: Path, fake_rollouts: FakeRollouts) -> None:
    options: dict[str, Any] = {"episodes": FAMILIES_DRAWN, "planners": ["random2"],
                               "progress": False}
    whole = tmp_path / "whole"
    fit_estimate(CONFIG, whole, **options)
    total = fake_rollouts.runs
    lines = (whole / "training.csv").read_text().splitlines(keepends=True)
    header, rows = lines[0], lines[1:]

    def episodes(numbers: range) -> list[str]:
        return [row for row in rows if int(row.split(",")[0]) in numbers]

    cut = tmp_path / "cut"
    fake_rollouts.runs, fake_rollouts.interrupt_at = 0, 7
    with pytest.raises(KeyboardInterrupt):
        fit_estimate(CONFIG, cut, **options)
    # Ctrl-C at the eighth training episode keeps the seven before it whole.
    assert (cut / "training.csv").read_text() == "".join([header, *episodes(range(7))])
    # A kill while the ninth was written: the eighth whole, the ninth's first row cut short.
    with (cut / "training.csv").open("a") as stream:
        stream.write("".join(episodes(range(7, 8))) + episodes(range(8, 9))[0][:20])
    fake_rollouts.runs, fake_rollouts.interrupt_at = 0, None
    fit_estimate(CONFIG, cut, **options)
    # The cut write's episode (the last seen) is run again, with every one after it.
    assert fake_rollouts.runs == total - 7
    for name in ("training.csv", "validation.csv"):
        assert (cut / name).read_bytes() == (whole / name).read_bytes()


@pytest.mark.parametrize("change", [["--planners", "random2"], ["--robot", "ur5"]])
def test_stop_error_reuses_its_rollouts_only_when_drawn_alike(
        tmp_path: Path, capsys: pytest.CaptureFixture, fake_rollouts: FakeRollouts,
        change: list[str]) -> None:
    (episodes,) = _episode_lists(tmp_path, "one.json")
    out = tmp_path / "error"
    command = ["stop", "error", "--out", str(out), "--episodes", str(episodes), "--planners",
               "uniform4"]
    assert main(command) == 0
    assert fake_rollouts.runs == 2
    rollouts = (out / "one.csv").read_text()
    assert main(command) == 0
    assert fake_rollouts.runs == 2
    capsys.readouterr()
    assert main([*command, *change]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1
    assert f"{out} holds rollouts drawn otherwise ({out / 'one.json'})" in error
    assert fake_rollouts.runs == 2 and (out / "one.csv").read_text() == rollouts


@pytest.mark.parametrize("command", [
    ["stop", "error", "--planners", "uniform4"],
    ["stop", "study", "--planners", "uniform2", "--stop", "views:1"],
])
def test_two_episode_lists_of_one_name_are_refused_before_anything_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch,
        fake_rollouts: FakeRollouts, command: list[str]) -> None:
    def evaluate(*args: object, **kwargs: object) -> None:
        raise AssertionError("an evaluation ran")

    monkeypatch.setattr(study_module, "evaluate", evaluate)
    first, second = _episode_lists(tmp_path, "a/one.json", "b/one.json")
    out = tmp_path / "out"
    assert main([*command, "--out", str(out), "--episodes", str(first), str(second)]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1
    assert f"--episodes {first} and {second} are both named 'one'" in error
    assert fake_rollouts.runs == 0 and not out.exists()


HOLDER = """
import sys, time, types
from pathlib import Path

from vprobot.cli import main
from vprobot.stop_studies import dataset, study


def hold(*args, **kwargs):
    Path(sys.argv[1]).touch()
    time.sleep(600)


dataset.PartScene = types.SimpleNamespace(load=lambda *args: None)
dataset.play = study.evaluate = hold
sys.exit(main(sys.argv[2:]))
"""
"""Runs a `vprobot` command whose first rollout or evaluation holds still, a file (argv[1])
saying that it got there."""


class Reached(Exception):
    """A command got past its folder's lock to its first rollout or evaluation."""


@pytest.mark.parametrize("command", [
    ["stop", "study", "--planners", "uniform2", "--stop", "views:1"],
    ["stop", "fit", "--planners", "random2", "--episodes", str(FAMILIES_DRAWN)],
    ["stop", "error", "--planners", "uniform4"],
])
def test_a_stop_folder_in_use_by_a_running_command_is_refused_naming_its_pid(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch,
        command: list[str]) -> None:
    def reached(*args: object, **kwargs: object) -> None:
        raise Reached

    monkeypatch.setattr(dataset_module, "PartScene",
                        types.SimpleNamespace(load=lambda *args: None))
    monkeypatch.setattr(dataset_module, "play", reached)
    monkeypatch.setattr(study_module, "evaluate", reached)
    (episodes,) = _episode_lists(tmp_path, "one.json")
    out, holding = tmp_path / "out", tmp_path / "holding"
    argv = [*command, "--out", str(out)]
    if command[1] != "fit":
        argv += ["--episodes", str(episodes)]
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(holding), *argv],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while holder.poll() is None and time.monotonic() < deadline and not holding.exists():
            time.sleep(0.05)
        assert holding.exists(), holder.stderr.read().decode() if holder.stderr else ""
        assert main(argv) == 2
        error = capsys.readouterr().err
        assert len(error.strip().splitlines()) == 1
        assert f"{out} is in use by pid {holder.pid}" in error
        assert holder.poll() is None
    finally:
        holder.kill()
        holder.wait(timeout=60)
    # Its holder gone, the folder is free (the kernel dropped the lock).
    with pytest.raises(Reached):
        main(argv)


def test_a_rollout_of_nbv_integrates_each_frame_once_and_reads_its_features_as_integrated_anew(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """`stop fit`'s rollout reads the features from the grid nbv filled (each acquired frame
    integrated once), and they equal those of a grid integrated anew from the views."""
    from vprobot.coverage.occupancy import OccupancyGrid
    from vprobot.stopping.features import episode_features

    integrated: list[int] = []
    integrate = OccupancyGrid.integrate

    def counting(grid: OccupancyGrid, sensor: Any, pose: Any, points_world: np.ndarray,
                 *args: Any) -> None:
        integrated.append(id(points_world))
        integrate(grid, sensor, pose, points_world, *args)

    views: list[ViewRecord] = []
    play = dataset_module.play

    def keeping(*args: Any) -> Any:
        played = play(*args)
        views.extend(played[0])
        return played

    monkeypatch.setattr(OccupancyGrid, "integrate", counting)
    monkeypatch.setattr(dataset_module, "play", keeping)
    config = Config()
    rows = dataset_module.rollout(config, seeded_episode(config.env, str(DEFAULT_MOTOR), 0), "nbv")
    acquired = [id(view.points_world) for view in views if view.acquired]
    assert len(acquired) >= 3 and sorted(integrated) == sorted(acquired)
    monkeypatch.setattr(OccupancyGrid, "integrate", integrate)
    anew = episode_features(config, views)
    np.testing.assert_array_equal([[row[name] for name in FEATURES] for row in rows], anew)
