"""Planner evaluation tables and the planner benchmark."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from helpers import SERIAL_EVALUATION
from PIL import Image
from scipy.spatial.transform import Rotation

from vprobot import evaluation as evaluation_module
from vprobot.benchmarks.planners import print_table, run_planners_benchmark
from vprobot.config import Config, load_config
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode import (
    BUNDLED_TEST_EPISODES,
    Episode,
    EpisodeRecord,
    EpisodeSpec,
    ViewRecord,
    episode_list,
    read_episode_list,
    write_episode_list,
)
from vprobot.episode.specs import BUNDLED_SHAPE_EPISODES
from vprobot.evaluation import (
    COLUMNS,
    CURVE_COLUMNS,
    EPISODE_COLUMNS,
    OPTIMUM_COLUMNS,
    PLOT_NAME,
    episode_row,
    evaluate,
    evaluation_episodes,
    finished_rows,
    held_out_motors,
    markdown,
    plot_coverage_curves,
    summarize,
    versus_optimum,
)
from vprobot.files.paths import DEFAULT_MOTOR, OBJECTS_DIR
from vprobot.geometry.poses import Pose
from vprobot.kinematics.trajectory import CycleTime, TimedPlan
from vprobot.planners import candidates as candidates_module
from vprobot.planners.base import PLANNERS, Planner
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.candidates import CandidateViews
from vprobot.planners.optimum import OptimumPlanner
from vprobot.planners.proof import Proof
from vprobot.planners.runner import EpisodeResult, make_planner, run
from vprobot.report.compare import moved_cells
from vprobot.stopping.rules import StopRule, make_stop_rule
from vprobot.training.evaluation import SUMMARY_KEYS, evaluate_policy, policy_summary

CONFIG = Config()


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open() as stream:
        return list(csv.DictReader(stream))


def assert_png(path: Path) -> None:
    with Image.open(path) as image:
        assert image.format == "PNG" and image.width > 100 and image.height > 100
        image.verify()


def test_evaluate_writes_markdown_and_csv(serial_evaluation: Path) -> None:
    # The session's SERIAL_EVALUATION: hrec and random2 on the default motor, seeds 0-2, both
    # carriers (12 episodes); test_killed_evaluation_resumes_... shows its rows rerun the same.
    summary = read_csv(serial_evaluation / "evaluation.csv")
    assert list(summary[0]) == list(COLUMNS)
    assert [(row["planner"], row["carrier"]) for row in summary] == [
        ("hrec", "robot"), ("random2", "robot"), ("hrec", "free"), ("random2", "free")]
    episodes = read_csv(serial_evaluation / "evaluation_episodes.csv")
    assert list(episodes[0]) == list(EPISODE_COLUMNS) and len(episodes) == 12
    for row in episodes:
        assert 0.0 <= float(row["coverage_pct"]) <= 100.0
        assert int(row["acquisitions"]) <= int(row["requested"])
        curve = [float(row[key]) for key in CURVE_COLUMNS]
        assert curve == sorted(curve)
        assert curve[-1] == float(row["coverage_pct"]) or int(row["requested"]) > len(curve)
        assert (row["views_to_goal"] != "") == (row["success"] == "True")
        if row["carrier"] == "free":
            assert row["joint_time_s"] == "" and row["reachable_pct"] == ""
            assert row["cycle_time_s"] == ""
        else:
            assert float(row["joint_time_s"]) > 0.0
            assert 0.0 <= float(row["reachable_pct"]) <= 100.0
            # The cycle holds the moves between views (their joint time, the velocity limits
            # alone, is a lower bound of their duration), a stop to acquire at each view, and
            # the approach and the return besides.
            stops = int(row["acquisitions"]) * CONFIG.sensor.acquisition_time_s
            assert float(row["cycle_time_s"]) > float(row["joint_time_s"]) + stops
    hrec_free = next(row for row in summary
                     if row["planner"] == "hrec" and row["carrier"] == "free")
    assert float(hrec_free["acquisitions"]) == 6 and hrec_free["joint_time_s"] == ""
    assert hrec_free["cycle_time_s"] == ""
    hrec_robot = next(row for row in summary
                      if row["planner"] == "hrec" and row["carrier"] == "robot")
    assert float(hrec_robot["cycle_time_s"]) == pytest.approx(np.mean(
        [float(row["cycle_time_s"]) for row in episodes
         if row["planner"] == "hrec" and row["carrier"] == "robot"]))
    markdown = (serial_evaluation / "evaluation.md").read_text()
    assert "| hrec | free | 3 |" in markdown and "B_SCP,5 | 98.17" in markdown
    assert "| area % | views to goal | cycle s |" in markdown
    assert_png(serial_evaluation / PLOT_NAME)
    # The episode list is part of the output, and `--episodes` on it runs the same episodes.
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1, 2])
    assert read_episode_list(serial_evaluation / "episodes.json") == specs
    assert evaluation_episodes(CONFIG, episodes=serial_evaluation / "episodes.json") == specs


def test_every_planner_sees_the_same_object_pose(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The pose each planner's episode used, and the frames it acquired, are the spec's: its
    quaternion about the cell's object centre (scipy's rotation and trimesh's distances as the
    references)."""
    (spec,) = episode_list(CONFIG, [DEFAULT_MOTOR], [3])
    results: list[EpisodeResult] = []

    def recording_run(*args: Any, **kwargs: Any) -> EpisodeResult:
        results.append(run(*args, **kwargs))
        return results[-1]

    monkeypatch.setattr(evaluation_module, "run", recording_run)
    evaluate(CONFIG, ["random1", "hrec"], [spec], tmp_path, progress=False, carriers=["free"])
    assert sorted(result.planner for result in results) == ["hrec", "random1"]
    rotation = Rotation.from_quat(spec.object_quaternion, scalar_first=True).as_matrix()
    center = np.asarray(CONFIG.cell.object_center_m)
    # The mesh file centred on its bounds (the loader's convention), placed by the spec.
    mesh = trimesh.load_mesh(spec.part_path)
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    for result in results:
        pose = result.record.object_pose
        np.testing.assert_allclose(pose.rotation, rotation, atol=1e-9)
        np.testing.assert_allclose(pose.position, center, atol=1e-9)
        points = np.concatenate([view.points_world for view in result.record.views])
        assert len(points) > 1000, result.planner
        sample = points[np.random.default_rng(0).choice(len(points), 500, replace=False)]
        # Back into the mesh's frame by the spec's pose: every point lies on the surface.
        _, distances, _ = trimesh.proximity.closest_point(mesh, (sample - center) @ rotation)
        assert distances.max() < 1e-3, (result.planner, distances.max())


def test_bundled_episode_list_is_what_the_sampler_draws() -> None:
    """The committed list is versioned: a change to the sampler must come with a new version."""
    bundled = read_episode_list(BUNDLED_TEST_EPISODES)
    assert bundled == episode_list(CONFIG, held_out_motors(), [0, 1, 2])
    assert evaluation_episodes(CONFIG) == bundled
    assert len({spec.object_quaternion for spec in bundled}) == len(bundled) == 15


def test_shapes_episode_list_is_what_the_sampler_draws_and_loads_from_anywhere(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bundled = read_episode_list(BUNDLED_SHAPE_EPISODES)
    objects = sorted(OBJECTS_DIR.glob("*.stl"))
    assert [path.stem for path in objects] == ["bracket", "pipe_tee", "torus"]
    assert bundled == episode_list(CONFIG, objects, range(5))
    assert evaluation_episodes(CONFIG, episodes="shapes-v1") == bundled
    assert evaluation_episodes(CONFIG, episodes="test-v1") == read_episode_list(
        BUNDLED_TEST_EPISODES)
    # Bundled objects are named inside the assets, not by a path that only works in the repo.
    monkeypatch.chdir(tmp_path)
    assert bundled[0].part == "objects/bracket.stl"
    assert {spec.part_path for spec in bundled} == set(objects)


def test_an_unknown_episode_list_names_the_bundled_ones(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"unknown episode list 'shapes-v2': neither a bundled "
                       r"episode list \(test-v1, shapes-v1.*\) nor a file"):
        evaluation_episodes(CONFIG, episodes="shapes-v2")


def _result(coverages: list[float], reachable: list[bool] | None = None,
            cycle: CycleTime | None = None) -> EpisodeResult:
    """A free-flying episode whose views reached `coverages` (unreachable ones acquire
    nothing), with the cycle time `cycle`."""
    pose = Pose(np.zeros(3), np.eye(3))
    views = [ViewRecord(requested=pose, reachable=ok, reason=None if ok else "collision",
                        joints=None, path=None, sensor_pose=pose if ok else None,
                        points_world=np.zeros((0, 3)), coverage=coverage)
             for coverage, ok in zip(coverages, reachable or [True] * len(coverages),
                                     strict=True)]
    record = EpisodeRecord(carrier="free", object_pose=pose, start_joints=np.zeros(6),
                           views=views, gt_points_world=np.zeros((0, 3)),
                           first_covered_by=np.zeros(0, dtype=int), epsilon_m=0.001,
                           timed=None if cycle is None else TimedPlan((), (), cycle, ()))
    spec = EpisodeSpec(part="test/motor_000.stl", object_quaternion=(1.0, 0.0, 0.0, 0.0),
                       initial_views=((1.42, 0.71),), seed=0)
    return EpisodeResult(planner="nbv", carrier="free", spec=spec, record=record, goal=0.9,
                         plan_seconds=0.1, episode_seconds=0.2)


def test_a_robot_episode_without_a_request_has_no_reachable_share() -> None:
    """A model-based planner with no usable candidate view requests nothing: its row has no
    reachable share instead of failing the evaluation (the UR5 and the Panda on some parts)."""
    result = dataclasses.replace(_result([]), carrier="robot")
    row = episode_row(0, result)
    assert row["reachable_pct"] is None and row["requested"] == 0
    (summary,) = summarize([row, episode_row(1, dataclasses.replace(_result([0.5]),
                                                                       carrier="robot"))])
    assert summary["reachable_pct"] == pytest.approx(100.0)


def test_an_episode_row_counts_the_requests_the_robot_did_not_reach() -> None:
    # Requests 2 and 4 of 5 unreached: 2 failed, 3 acquired; a free sensor's row fails none.
    robot = dataclasses.replace(_result([0.3, 0.3, 0.6, 0.6, 0.9],
                                        [True, False, True, False, True]), carrier="robot")
    row = episode_row(0, robot)
    assert (row["requested"], row["acquisitions"], row["failed_requests"]) == (5, 3, 2)
    assert row["reachable_pct"] == pytest.approx(60.0)
    assert episode_row(1, _result([0.3, 0.6, 0.9]))["failed_requests"] == 0
    (summary,) = summarize([row, episode_row(1, dataclasses.replace(_result([0.5]),
                                                                       carrier="robot"))])
    assert summary["failed_requests"] == pytest.approx(1.0)  # (2 + 0) / 2


def _scored(episode: int, planner: str, carrier: str, acquisitions: int,
            cycle: float | None) -> dict[str, Any]:
    """An episode row as `finished_rows` reads it, with `acquisitions` and the cycle time."""
    return {**episode_row(episode, dataclasses.replace(_result([0.9]), carrier=carrier)),
            "planner": planner, "acquisitions": acquisitions, "cycle_time_s": cycle}


def test_planners_are_compared_with_the_optimum_of_the_same_episode_and_carrier() -> None:
    rows = [
        # Robot: the optimum needs 3, 4 and 3 views, cycles 10, 12 and 9 s.
        _scored(0, "bscp", "robot", 3, 11.0), _scored(0, "optimum", "robot", 3, 10.0),
        _scored(1, "bscp", "robot", 6, 18.0), _scored(1, "optimum", "robot", 4, 12.0),
        _scored(2, "optimum", "robot", 3, 9.0), _scored(2, "bscp", "robot", 4, None),
        # The random planner stopped short of the goal with fewer views than the optimum.
        _scored(0, "random2", "robot", 2, 8.0),
        # Free: no optimum row of episode 1, so bscp's episode 1 is not compared.
        _scored(0, "optimum", "free", 3, None), _scored(0, "bscp", "free", 4, None),
        _scored(1, "bscp", "free", 9, None),
    ]
    versus = {(row["episode"], row["planner"], row["carrier"]):
              (row["views_above_optimum"], row["cycle_ratio"]) for row in versus_optimum(rows)}
    expected = {
        (0, "bscp", "robot"): (0, 1.1), (0, "optimum", "robot"): (0, 1.0),
        (1, "bscp", "robot"): (2, 1.5), (1, "optimum", "robot"): (0, 1.0),
        (2, "optimum", "robot"): (0, 1.0), (2, "bscp", "robot"): (1, None),
        (0, "random2", "robot"): (-1, 0.8),
        (0, "optimum", "free"): (0, None), (0, "bscp", "free"): (1, None)}
    # Views exactly, cycle ratios to rounding (pytest 9's approx takes no nested containers).
    assert versus == {key: (views, None if ratio is None else pytest.approx(ratio))
                      for key, (views, ratio) in expected.items()}
    table = {(row["planner"], row["carrier"]): row for row in summarize(rows)}
    bscp = table["bscp", "robot"]
    assert bscp["views_above_optimum"] == pytest.approx(1.0)  # (0 + 2 + 1) / 3
    assert bscp["within_one_view_pct"] == pytest.approx(200 / 3)  # 0 and 1 within, 2 not
    assert bscp["cycle_ratio"] == pytest.approx(1.3)  # (1.1 + 1.5) / 2: episode 2 untimed
    optimum = table["optimum", "robot"]
    assert (optimum["views_above_optimum"], optimum["within_one_view_pct"],
            optimum["cycle_ratio"]) == pytest.approx((0.0, 100.0, 1.0))
    assert table["random2", "robot"]["views_above_optimum"] == pytest.approx(-1.0)
    free = table["bscp", "free"]
    # Over the compared episode only; no cycle without the robot.
    assert (free["views_above_optimum"], free["within_one_view_pct"],
            free["cycle_ratio"]) == (pytest.approx(1.0), pytest.approx(100.0), None)
    assert free["episodes"] == 2 and free["acquisitions"] == pytest.approx(6.5)


def test_the_optimums_proof_is_a_column_that_survives_the_csv(tmp_path: Path) -> None:
    # Three optimum episodes: proven, a one-view gap, a two-view gap; bscp has no proof.
    proofs = [Proof(True, 3, 0), Proof(False, 3, 1), Proof(False, 2, 2)]
    rows = [episode_row(index, dataclasses.replace(_result([0.9]), carrier="robot",
                                                   planner="optimum", proof=proof))
            for index, proof in enumerate(proofs)]
    rows.append(episode_row(0, dataclasses.replace(_result([0.9]), carrier="robot")))
    assert [(row["proven"], row["gap_views"]) for row in rows] == [
        (True, 0), (False, 1), (False, 2), (None, None)]
    path = tmp_path / "evaluation_episodes.csv"
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, EPISODE_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    assert finished_rows(path) == rows
    table = {row["planner"]: row for row in summarize(rows)}
    assert table["optimum"]["proven_pct"] == pytest.approx(100 / 3)
    assert table["optimum"]["gap_views_max"] == 2
    assert table["nbv"]["proven_pct"] is table["nbv"]["gap_views_max"] is None
    text = markdown(summarize(rows), episode_list(CONFIG, [DEFAULT_MOTOR], [0]), CONFIG)
    assert "| proven % | gap views, max |" in text
    # The optimum's row ends with its comparison with itself (no cycle time) and the proof.
    assert "| 0.00 | 100 | - | 33 | 2 |" in text


def test_the_markdown_shows_the_comparison_or_says_how_to_get_it() -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    without = markdown(summarize([_scored(0, "bscp", "robot", 4, 12.0)]), specs, CONFIG)
    assert ("| cov@5 % | cov@10 % | views above optimum | within +1 view % | cycle / optimum |"
            in without)
    assert "`--planners ... optimum`" in without
    (row,) = summarize([_scored(0, "bscp", "robot", 4, 12.0)])
    assert all(row[key] is None for key in OPTIMUM_COLUMNS)
    assert row["cov_5_pct"] == row["cov_10_pct"] == pytest.approx(90.0)
    # The row's last five cells: coverage after 5 and 10 requests, then the empty comparison.
    assert "| 90.00 | 90.00 | - | - | - |" in without
    compared = markdown(summarize([_scored(0, "bscp", "robot", 5, 12.0),
                                   _scored(0, "optimum", "robot", 3, 10.0)]), specs, CONFIG)
    assert "--planners ... optimum" not in compared
    assert "| bscp | robot | 1 |" in compared and "| 90.00 | 90.00 | 2.00 | 0 | 1.200 |" in compared


def test_the_plot_draws_the_optimum_apart(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    import vprobot.evaluation as evaluation

    figures = []
    saved = evaluation.save_figure

    def keep(figure: Any, path: Path, title: str) -> Path:
        figures.append(figure)
        return saved(figure, path, title)

    monkeypatch.setattr(evaluation, "save_figure", keep)
    rows = [_scored(0, "bscp", "robot", 4, 12.0), _scored(0, "optimum", "robot", 3, 10.0)]
    plot_coverage_curves(summarize(rows), CONFIG, tmp_path / PLOT_NAME, "title")
    assert_png(tmp_path / PLOT_NAME)
    (axis,) = figures[0].axes
    lines = {line.get_label(): line for line in axis.get_lines()}
    assert set(lines) == {"bscp", "optimum (fewest views)", "goal 90%"}
    floor = lines["optimum (fewest views)"]
    assert floor.get_color() == "black" and floor.get_linestyle() == ":"
    assert lines["bscp"].get_color() == "C0"  # the colour bscp has without the optimum


def test_summarize_gives_the_coverage_curve_its_area_and_views_to_goal() -> None:
    # Reaches the goal exactly at request 3 and stops: 90 % is carried over requests 4..10.
    stopped = episode_row(0, _result([0.5, 0.8, 0.9]))
    # Request 2 unreached (it still costs a request); ends at 85 % after 4 requests.
    failed = episode_row(1, _result([0.4, 0.4, 0.7, 0.85], [True, False, True, True]))
    # Reaches the goal at request 11, past the curve.
    late = episode_row(2, _result([0.3, 0.5, 0.6, 0.7, 0.75, 0.8, 0.82, 0.84, 0.86, 0.88,
                                   0.91]))
    assert [stopped[key] for key in CURVE_COLUMNS] == pytest.approx([50, 80] + [90] * 8)
    assert [failed[key] for key in CURVE_COLUMNS] == pytest.approx([40, 40, 70] + [85] * 7)
    assert (stopped["views_to_goal"], failed["views_to_goal"], late["views_to_goal"]) == (
        3, None, 11)
    (row,) = summarize([stopped, failed, late])
    # Areas per episode: (50 + 80 + 8 * 90) / 10 = 85, (40 + 40 + 70 + 7 * 85) / 10 = 74.5,
    # (30 + 50 + 60 + 70 + 75 + 80 + 82 + 84 + 86 + 88) / 10 = 70.5.
    assert row["area_pct"] == pytest.approx((85.0 + 74.5 + 70.5) / 3)
    assert row["cov_1_pct"] == pytest.approx(40.0)
    assert row["cov_10_pct"] == pytest.approx((90 + 85 + 88) / 3)
    assert row["views_to_goal"] == pytest.approx(7.0)  # (3 + 11) / 2: the failed one is out
    assert row["success_pct"] == pytest.approx(200 / 3)
    (none_reached,) = summarize([failed])
    assert none_reached["views_to_goal"] is None


def test_an_episode_row_has_the_cycle_time_and_the_summary_its_mean_over_the_timed() -> None:
    """`cycle_time_s` is the cycle's total (approach + moves + acquisitions + return); an episode
    without a cycle (no robot, or no path home) has none and is left out of the mean."""
    timed = [episode_row(0, _result([0.5], cycle=CycleTime(1.0, 2.5, 1.5, 0.75))),
             episode_row(1, _result([0.5], cycle=CycleTime(2.0, 3.5, 2.0, 1.25)))]
    untimed = episode_row(2, _result([0.5]))
    assert [row["cycle_time_s"] for row in [*timed, untimed]] == [5.75, 8.75, None]
    (row,) = summarize([*timed, untimed])
    assert row["cycle_time_s"] == pytest.approx(7.25)
    (none,) = summarize([untimed])
    assert none["cycle_time_s"] is None


def test_a_policys_episode_rows_have_the_cycle_time_of_their_episode() -> None:
    """`evaluate_policy` (a training's evaluations) rows a policy's episode as `evaluate` does,
    the cycle time included."""
    env = InspectEnv(parts="mesh", mesh=str(DEFAULT_MOTOR), resolution=(107, 75),
                     action="A_2S0R")
    rng = np.random.default_rng(0)

    class RandomPolicy:
        def predict(self, observation: object, deterministic: bool = True
                    ) -> tuple[np.ndarray, None]:
            return rng.uniform(-1.0, 1.0, 2).astype(np.float32), None

    (row,) = evaluate_policy(RandomPolicy(), env, episode_list(CONFIG, [DEFAULT_MOTOR], [0]))
    timed = env.episode_record().timed
    assert row["cycle_time_s"] == pytest.approx(timed.cycle.total_s)
    assert row["cycle_time_s"] > row["joint_time_s"]


def test_the_optimum_added_to_a_finished_evaluation_fills_the_comparison(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`bscp` alone, then resumed with `optimum`: bscp's row is kept, and the tables compare it
    with the optimum's row from the episodes table. Both planners on 200 candidates at a coarse
    grid (as tests/test_optimum.py), to run in seconds."""
    from vprobot.cli import main

    for planner in (SetCoverPlanner, OptimumPlanner):
        def small(self: SetCoverPlanner, *args: Any, original: Any = planner.__init__,
                  **kwargs: Any) -> None:
            # `OptimumPlanner` passes its (small) candidate count and resolution on to
            # `SetCoverPlanner` positionally.
            grid = {} if len(args) > 3 else {"candidate_count": 200, "resolution": (107, 75)}
            original(self, *args, **{**grid, **kwargs})

        monkeypatch.setattr(planner, "__init__", small)
    command = ["evaluate", "--parts", str(DEFAULT_MOTOR), "--seeds", "0", "--carriers",
               "robot", "--out", str(tmp_path), "--planners", "bscp"]
    assert main(command) == 0
    assert read_csv(tmp_path / "evaluation_vs_optimum.csv") == []
    assert "`--planners ... optimum`" in (tmp_path / "evaluation.md").read_text()
    first = read_csv(tmp_path / "evaluation_episodes.csv")
    assert main([*command, "optimum"]) == 0
    episodes = read_csv(tmp_path / "evaluation_episodes.csv")
    assert episodes[0] == first[0] and [row["planner"] for row in episodes] == ["bscp", "optimum"]
    bscp, optimum = episodes
    versus = {row["planner"]: row for row in read_csv(tmp_path / "evaluation_vs_optimum.csv")}
    assert int(versus["bscp"]["views_above_optimum"]) == (int(bscp["acquisitions"])
                                                          - int(optimum["acquisitions"])) >= 0
    ratio = float(bscp["cycle_time_s"]) / float(optimum["cycle_time_s"])
    assert float(versus["bscp"]["cycle_ratio"]) == pytest.approx(ratio)
    summary = {row["planner"]: row for row in read_csv(tmp_path / "evaluation.csv")}
    assert float(summary["bscp"]["cycle_ratio"]) == pytest.approx(ratio)
    assert float(summary["optimum"]["within_one_view_pct"]) == 100.0
    assert "`--planners ... optimum`" not in (tmp_path / "evaluation.md").read_text()


def test_an_old_episodes_table_is_a_clear_error(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    from vprobot.cli import main

    rows = tmp_path / "evaluation_episodes.csv"
    # A table of the version before the cycle time: refused, naming what it lacks.
    rows.write_text(",".join(column for column in EPISODE_COLUMNS
                             if column != "cycle_time_s") + "\n")
    with pytest.raises(ValueError, match=r"not an episodes table of this vprobot version \(it "
                                         r"lacks cycle_time_s\); use another --out"):
        finished_rows(rows)
    # A table of the version before the failed requests (a folder of the scoreboard before
    # the optimum): refused the same way.
    rows.write_text(",".join(column for column in EPISODE_COLUMNS
                             if column != "failed_requests") + "\n")
    with pytest.raises(ValueError, match=r"\(it lacks failed_requests\); use another --out"):
        finished_rows(rows)
    old = [column for column in EPISODE_COLUMNS
           if column not in CURVE_COLUMNS and column not in ("views_to_goal", "cycle_time_s")]
    rows.write_text(",".join(old) + "\n")
    with pytest.raises(ValueError, match="not an episodes table of this vprobot version"):
        finished_rows(rows)
    assert main(["evaluate", "--planners", "hrec", "--parts", str(DEFAULT_MOTOR), "--seeds",
                 "0", "--out", str(tmp_path)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "use another --out" in line
    assert rows.read_text() == ",".join(old) + "\n"
    assert not (tmp_path / "episodes.json").exists()


def test_summarize_averages_per_planner_and_carrier() -> None:
    base = {"acquisitions": 4, "requested": 5, "failed_requests": 0, "views_to_goal": None,
            "cycle_time_s": None,
            "joint_time_s": None,
            "joint_path_rad": None, "cartesian_m": None, "paper_m": 1.0, "reachable_pct": None,
            "plan_s": 0.5, "plan_ms_per_view": 100.0, "episode_s": 1.0,
            **dict.fromkeys(CURVE_COLUMNS, 50.0), "proven": None, "gap_views": None}
    rows = [{**base, "episode": 0, "planner": "bscp", "carrier": "free", "coverage_pct": 90.0,
             "success": True},
            {**base, "episode": 1, "planner": "bscp", "carrier": "free", "coverage_pct": 80.0,
             "success": False}]
    (row,) = summarize(rows)
    assert row["coverage_pct"] == 85.0 and row["coverage_std_pct"] == 5.0
    assert row["success_pct"] == 50.0 and row["joint_time_s"] is None and row["episodes"] == 2


def test_a_policys_summary_is_the_one_summary_by_hand() -> None:
    # Two robot episodes of a policy, as `evaluate_policy` rows them; the values by hand.
    reached = {"episode": 0, "planner": "policy", "carrier": "robot", "part": "m.stl",
               "seed": 0, "coverage_pct": 95.0, "acquisitions": 5, "requested": 6,
               "failed_requests": 1, "success": True, "views_to_goal": 5, "cycle_time_s": 12.0,
               "joint_time_s": 2.0, "joint_path_rad": 3.0, "cartesian_m": 1.0, "paper_m": 0.8,
               "reachable_pct": 500 / 6, "plan_s": 0.3, "plan_ms_per_view": 50.0,
               "episode_s": 2.0,
               **dict(zip(CURVE_COLUMNS, [40, 60, 80, 90] + [95] * 6, strict=True)),
               "proven": None, "gap_views": None}
    missed = {**reached, "episode": 1, "coverage_pct": 75.0, "acquisitions": 3, "requested": 4,
              "success": False, "views_to_goal": None, "cycle_time_s": 8.0, "joint_time_s": 1.0,
              "joint_path_rad": 1.0, "cartesian_m": 0.5, "paper_m": 0.4, "reachable_pct": 75.0,
              "plan_s": 0.1, "plan_ms_per_view": 25.0, "episode_s": 1.0,
              **dict(zip(CURVE_COLUMNS, [30, 50, 70] + [75] * 7, strict=True))}
    summary = policy_summary([reached, missed])
    assert tuple(summary) == SUMMARY_KEYS
    expected = {"episodes": 2, "coverage_pct": 85.0, "coverage_std_pct": 10.0,
                "acquisitions": 4.0, "requested": 5.0, "failed_requests": 1.0,
                "success_pct": 50.0,
                "views_to_goal": 5.0, "cycle_time_s": 10.0, "joint_time_s": 1.5,
                "joint_path_rad": 2.0, "cartesian_m": 0.75, "paper_m": 0.6,
                "reachable_pct": (500 / 6 + 75) / 2,
                "plan_s": 0.2, "plan_ms_per_view": 37.5, "episode_s": 1.5,
                "cov_1_pct": 35.0, "cov_4_pct": 82.5, "cov_10_pct": 85.0,
                # The mean of the ten mean curve points: (35 + 55 + 75 + 82.5 + 6 * 85) / 10.
                "area_pct": 75.75}
    assert {key: summary[key] for key in expected} == pytest.approx(expected)
    with pytest.raises(ValueError, match="at least one episode"):
        policy_summary([])


@pytest.mark.parametrize(
    ("planners", "carriers", "message"),
    [(["dijkstra"], ["robot"], "unknown planner 'dijkstra'"),
     (["hrec"], ["flying"], "unknown carrier 'flying'"),
     ([], ["robot"], "at least one planner")],
)
def test_bad_arguments_are_clear_errors(planners: list[str], carriers: list[str], message: str,
                                        tmp_path: Path) -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    with pytest.raises(ValueError, match=message):
        evaluate(CONFIG, planners, specs, tmp_path, progress=False, carriers=carriers)
    with pytest.raises(ValueError, match="not both"):
        evaluation_episodes(CONFIG, seeds=[0], episodes=BUNDLED_TEST_EPISODES)


@pytest.mark.benchmark
def test_planner_benchmark_reports_the_targets(capsys: pytest.CaptureFixture) -> None:
    results = run_planners_benchmark(CONFIG, motors=[DEFAULT_MOTOR], seeds=[0], progress=False)
    for key in ("bscp_plan_s_median", "bscp5_free_coverage_pct", "bscp_robot_coverage_pct",
                "hrec_free_coverage_pct", "hrec_robot_coverage_pct", "uniform4_robot_coverage_pct",
                "nbv_robot_coverage_pct", "nbv_free_ms_per_view"):
        assert key in results
    assert results["nbv_robot_views"] >= 2 and results["nbv_free_ms_per_view"] > 0.0
    assert results["bscp_robot_coverage_pct"] >= 90.0
    assert results["bscp5_free_coverage_pct"] >= 95.0
    assert 0.0 < results["bscp_plan_s_median"] <= results["bscp_plan_s_max"]
    # The agent's screening, once per episode, is part of its planning, not of its decisions.
    assert 0.0 < results["agent_screening_s_median"] < results["agent_plan_s_median"]
    assert results["agent_decision_ms_per_view_median"] < results["agent_ms_per_view"]
    print_table(results)
    printed = capsys.readouterr().out
    assert "B_SCP,5" in printed and "nbv (90 %)" in printed and "screening left out" in printed


EVAL_ARGS = list(SERIAL_EVALUATION[1:])


def _rows_by_key(path: Path) -> dict[tuple[str, str, str], str]:
    rows = read_csv(path)
    keys = [(row["episode"], row["carrier"], row["planner"]) for row in rows]
    assert len(keys) == len(set(keys)), "duplicated rows"
    return {key: row["coverage_pct"] for key, row in zip(keys, rows, strict=True)}


def test_killed_evaluation_resumes_without_lost_or_duplicated_rows(
        tmp_path: Path, serial_evaluation: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    from vprobot.cli import main

    killed = tmp_path / "killed"
    expected = _rows_by_key(serial_evaluation / "evaluation_episodes.csv")
    assert len(expected) == 12
    process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", "evaluate", *EVAL_ARGS,
                                "--out", str(killed)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    rows = killed / "evaluation_episodes.csv"
    deadline = time.monotonic() + 120
    while process.poll() is None and time.monotonic() < deadline:
        if rows.exists() and rows.read_text().count("\n") >= 4:  # header + 3 episodes
            process.send_signal(signal.SIGKILL)
            break
        time.sleep(0.05)
    process.wait()
    assert process.returncode == -signal.SIGKILL, "the evaluation ended before it was killed"
    done = len(_rows_by_key(rows))
    assert 3 <= done < 12
    # A kill in the middle of a write leaves a cut line; it is dropped, not read as a row.
    with rows.open("a") as stream:
        stream.write("5,hrec,fr")
    assert main(["evaluate", *EVAL_ARGS, "--out", str(killed)]) == 0
    assert _rows_by_key(rows) == expected


def test_interrupted_evaluation_saves_its_tables_and_finishes_later(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import vprobot.evaluation as evaluation

    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1])
    real_run, calls = evaluation.run, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real_run(*args, **kwargs)

    monkeypatch.setattr(evaluation, "run", interrupted)
    with pytest.raises(KeyboardInterrupt):
        evaluate(CONFIG, ["random2", "hrec"], specs, tmp_path, progress=False,
                 carriers=["free"])
    assert len(read_csv(tmp_path / "evaluation_episodes.csv")) == 2
    assert "Partial: 2 of 4 episodes" in (tmp_path / "evaluation.md").read_text()
    assert_png(tmp_path / PLOT_NAME)
    monkeypatch.setattr(evaluation, "run", real_run)
    table = evaluate(CONFIG, ["random2", "hrec"], specs, tmp_path, progress=False,
                     carriers=["free"])
    assert sum(row["episodes"] for row in table) == 4
    assert "Partial" not in (tmp_path / "evaluation.md").read_text()
    # Another episode list into the same folder is refused rather than mixed in.
    with pytest.raises(ValueError, match="other episodes"):
        evaluate(CONFIG, ["hrec"], episode_list(CONFIG, [DEFAULT_MOTOR], [7]), tmp_path,
                 progress=False, carriers=["free"])


def test_a_bad_motor_fails_before_the_first_episode(tmp_path: Path) -> None:
    bad = tmp_path / "bad.stl"
    bad.write_text("solid nothing\nendsolid nothing\n")
    specs = episode_list(CONFIG, [DEFAULT_MOTOR, bad], [0])
    with pytest.raises(ValueError, match=r"bad\.stl"):
        evaluate(CONFIG, ["hrec"], specs, tmp_path / "out", progress=False)
    assert not (tmp_path / "out" / "evaluation_episodes.csv").exists()


TINY_FREE = ("evaluate", "--planners", "hrec", "--parts", str(DEFAULT_MOTOR), "--carriers",
             "free")
"""A cheap `vprobot evaluate` (one fixed planner, the free sensor); add --seeds and --out."""


def test_an_evaluation_folder_in_use_is_refused(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    """While one evaluate process runs into a folder (held still after its first episode), a
    second evaluate of the same folder is refused at once, naming the first's pid; let go, the
    first finishes with each episode once."""
    import signal
    import subprocess
    import sys
    import time

    from vprobot.cli import main

    out = tmp_path / "out"
    command = [*TINY_FREE, "--seeds", "0", "1", "2", "3", "--out", str(out)]
    process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", *command],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rows = out / "evaluation_episodes.csv"
    try:
        deadline = time.monotonic() + 120
        while process.poll() is None and time.monotonic() < deadline:
            if rows.is_file() and rows.read_text().count("\n") >= 2:  # header + 1 episode
                process.send_signal(signal.SIGSTOP)
                break
            time.sleep(0.01)
        assert process.poll() is None, "the first evaluation ended before it was held"
        assert main(command) == 2
        (line,) = capsys.readouterr().err.splitlines()
        assert f"{out} is in use by pid {process.pid}" in line
        process.send_signal(signal.SIGCONT)
        assert process.wait(timeout=120) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert sorted(_rows_by_key(rows)) == [
        (str(index), "free", "hrec") for index in range(4)]


def test_a_short_row_write_is_an_error_that_leaves_whole_rows_and_resumes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A full disk that takes only part of a row: the evaluation stops with an OSError, the
    table keeps whole rows only, and a rerun (space freed) finishes it."""
    import os

    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1])
    real_write = os.write

    def disk_full(descriptor: int, data: bytes) -> int:
        # The second episode's row (episode index 1) gets only part of its bytes on disk.
        return real_write(descriptor, data[:50] if data.startswith(b"1,") else data)

    monkeypatch.setattr(os, "write", disk_full)
    with pytest.raises(OSError, match="disk full"):
        evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    monkeypatch.undo()
    rows = tmp_path / "evaluation_episodes.csv"
    assert rows.read_text().endswith("\n")
    assert sorted(_rows_by_key(rows)) == [("0", "free", "hrec")]
    table = evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    assert table[0]["episodes"] == 2
    assert sorted(_rows_by_key(rows)) == [("0", "free", "hrec"), ("1", "free", "hrec")]


def test_damaged_rows_are_dropped_with_one_warning_and_their_episodes_rerun(
        tmp_path: Path) -> None:
    """A row glued onto a cut one (a torn write), a row with too few cells, one with a value
    that does not parse and one with bytes that are not UTF-8 are dropped and their episodes
    run again; the good row is kept as it was (not rerun), and the rerun's rows equal a clean
    evaluation's."""
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1, 2, 3, 4])
    evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    rows = tmp_path / "evaluation_episodes.csv"
    expected = _rows_by_key(rows)
    header, first, second, third, fourth, fifth = rows.read_text().splitlines()
    unparsed = fourth.split(",")
    unparsed[EPISODE_COLUMNS.index("coverage_pct")] = "cut"
    # Too many cells (episodes 1 and 2), a cell that does not parse, too few cells (3).
    damaged = [header, first, second[:40] + third, ",".join(unparsed),
               fourth.rsplit(",", 3)[0]]
    motor = fifth.split(",")[EPISODE_COLUMNS.index("part")]
    rows.write_bytes(("\n".join(damaged) + "\n").encode()
                     + fifth.encode().replace(motor.encode(), b"\xff" + motor.encode()[1:])
                     + b"\n")
    with pytest.warns(UserWarning) as caught:
        table = evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    (warning,) = caught
    assert "dropped 4 damaged row(s) at line(s) 3, 4, 5, 6;" in str(warning.message)
    assert table[0]["episodes"] == 5
    assert _rows_by_key(rows) == expected
    assert rows.read_text().splitlines()[:2] == [header, first]


def test_resuming_with_other_settings_is_refused(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture) -> None:
    """The first run records its settings; a rerun with another robot, coverage goal or
    estimator is refused (exit 2, one line naming the setting) and leaves the rows as they
    were. A folder of an older vprobot (no settings recorded) takes this run's, with a
    warning."""
    from vprobot.cli import main
    from vprobot.config import replace

    command = [*TINY_FREE, "--seeds", "0", "--out", str(tmp_path)]
    assert main(command) == 0
    rows = tmp_path / "evaluation_episodes.csv"
    written = rows.read_text()
    capsys.readouterr()
    assert main([*command, "--robot", "ur5"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "holds an evaluation of other settings (cell.robot 'ur10' there, 'ur5' now" in line
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    for config, estimator, setting in [
            (replace(CONFIG, "env", coverage_goal=0.5), None, "env.coverage_goal"),
            (CONFIG, tmp_path / "estimator.npz", "estimator")]:
        with pytest.raises(ValueError, match=f"other settings \\({setting} "):
            evaluate(config, ["hrec"], specs, tmp_path, progress=False, carriers=["free"],
                     estimator=estimator)
    assert rows.read_text() == written
    (tmp_path / "evaluation_settings.json").unlink()
    with pytest.warns(UserWarning, match="did not record its settings"):
        evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    with pytest.raises(ValueError, match="other settings"):
        evaluate(replace(CONFIG, "cell", robot="ur5"), ["hrec"], specs, tmp_path,
                 progress=False, carriers=["free"])


def test_a_setting_added_since_the_folder_was_made_resumes_at_its_default(
        tmp_path: Path) -> None:
    """`env.split` came after some committed folders were made: a folder without it resumes
    with the default split, and is refused with another."""
    from vprobot.config import replace

    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    path = tmp_path / "evaluation_settings.json"
    settings = json.loads(path.read_text())
    del settings["config"]["env"]["split"]
    path.write_text(json.dumps(settings))
    table = evaluate(CONFIG, ["hrec", "uniform2"], specs, tmp_path, progress=False,
                     carriers=["free"])
    assert [row["planner"] for row in table] == ["hrec", "uniform2"]
    with pytest.raises(ValueError, match=r"other settings \(env.split 1 there, 2 now"):
        evaluate(replace(CONFIG, "env", split=2), ["hrec"], specs, tmp_path, progress=False,
                 carriers=["free"])


def test_a_folder_made_in_another_checkout_resumes_and_a_changed_mesh_is_still_refused(
        tmp_path: Path) -> None:
    """Mesh files are recorded under the episode list's names; a folder that recorded them by
    the absolute paths of the checkout that made it (as before) resumes in another one, and a
    mesh whose content differs is refused whatever its name."""
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    path = tmp_path / "evaluation_settings.json"
    settings = json.loads(path.read_text())
    ((name, digest),) = settings["sha256"].items()
    assert name == specs[0].part
    elsewhere = f"/another/checkout/vprobot/assets/motors/{name}"
    settings["sha256"] = {elsewhere: digest}
    path.write_text(json.dumps(settings))
    table = evaluate(CONFIG, ["hrec", "uniform2"], specs, tmp_path, progress=False,
                     carriers=["free"])
    assert [row["planner"] for row in table] == ["hrec", "uniform2"]
    settings["sha256"] = {elsewhere: "0" * 64}
    path.write_text(json.dumps(settings))
    with pytest.raises(ValueError, match=f"{name} changed since the evaluation"):
        evaluate(CONFIG, ["hrec", "uniform3"], specs, tmp_path, progress=False,
                 carriers=["free"])


def test_a_folder_recorded_under_keys_renamed_since_resumes_under_their_new_names(
        tmp_path: Path) -> None:
    """A folder made before `env.motors` became `env.parts`, the episodes table's `motor`
    column `part`, and the encoders' settings moved under `agent.encoder_settings` resumes;
    another value under the old name is still refused."""
    from vprobot.config import replace

    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    evaluate(CONFIG, ["hrec"], specs, tmp_path, progress=False, carriers=["free"])
    path = tmp_path / "evaluation_settings.json"
    settings = json.loads(path.read_text())
    settings["config"]["env"]["motors"] = settings["config"]["env"].pop("parts")
    agent = settings["config"]["agent"]
    del agent["encoder_settings"]
    agent |= {"encoder_scale": 1.0, "sphere_bins": [8, 16], "sphere_features": 128}
    path.write_text(json.dumps(settings))
    rows = tmp_path / "evaluation_episodes.csv"
    header, *written = rows.read_text().splitlines()
    assert header.split(",")[3] == "part"
    rows.write_text("\n".join([header.replace(",part,", ",motor,"), *written]) + "\n")
    table = evaluate(CONFIG, ["hrec", "uniform2"], specs, tmp_path, progress=False,
                     carriers=["free"])
    assert [row["planner"] for row in table] == ["hrec", "uniform2"]
    # The hrec row was kept, not run again; uniform2's was appended to the same table.
    assert rows.read_text().splitlines()[1:2] == written
    assert [row["part"] for row in finished_rows(rows)] == [DEFAULT_MOTOR.name] * 2
    with pytest.raises(ValueError, match=r"other settings \(env.parts 'train' there, 'test' "):
        evaluate(replace(CONFIG, "env", parts="test"), ["hrec"], specs, tmp_path,
                 progress=False, carriers=["free"])


def test_a_planner_or_carrier_given_twice_runs_once(tmp_path: Path) -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0])
    table = evaluate(CONFIG, ["hrec", "hrec"], specs, tmp_path, progress=False,
                     carriers=["free", "free"], stops=["goal", "goal"])
    assert [(row["planner"], row["carrier"], row["episodes"]) for row in table] == [
        ("hrec", "free", 1)]
    assert len(read_csv(tmp_path / "evaluation_episodes.csv")) == 1


def test_an_episode_without_a_reachable_initial_view_is_scored_and_plan_says_why(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from vprobot.cli import main

    """The Panda reaches no view at the PhoXi M's working distance (0.788 m) around the motor:
    `evaluate` scores the episode as covering nothing, with the reason, and goes on to the next
    planner; `plan` of that one episode is a one-line error."""
    config = tmp_path / "panda_phoxi.yaml"
    config.write_text("cell:\n  robot: panda\nsensor:\n  preset: phoxi_m\n"
                      "  resolution: [64, 48]\n")
    episodes = tmp_path / "one.json"
    write_episode_list(episodes, episode_list(load_config(config), [DEFAULT_MOTOR], [0]))
    out = tmp_path / "out"
    assert main(["evaluate", "--config", str(config), "--episodes", str(episodes),
                 "--planners", "nbv", "random2", "--carriers", "robot", "--out", str(out)]) == 0
    with (out / "evaluation_episodes.csv").open() as stream:
        rows = {row["planner"]: row for row in csv.DictReader(stream)}
    assert set(rows) == {"nbv", "random2"}
    for row in rows.values():
        assert float(row["coverage_pct"]) == 0.0 and row["requested"] == "0"
        assert row["reachable_pct"] == ""
    assert ("note: 2 episode(s) requested no view, covering nothing (the robot reached no "
            "initial view, or no candidate view was usable): nbv (robot) on episode 0; random2 "
            "(robot) on episode 0") in capsys.readouterr().out
    assert main(["plan", "--no-summary", "--config", str(config), "--planner", "nbv",
                 "--out", str(tmp_path / "plan.json")]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "none of the 25 initial views is reachable" in line


def test_each_planner_is_built_once_per_run_and_gives_the_rows_of_fresh_ones(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`evaluate` builds each planner once (by its check) and runs it episode after episode,
    reset each time: its rows (timing aside) are those of planners built afresh per episode,
    as before (random2 draws from the episode's rng, nbv keeps its failed candidates, bscp its
    candidates and picks, the agent its observer)."""
    names = ["random2", "hrec", "nbv", "bscp", "agent"]
    built: dict[str, int] = dict.fromkeys(names, 0)
    for name in names:
        original = PLANNERS[name].from_name

        def counted(config: Config, views: int | None = None, *, _name: str = name,
                    _original: Any = original, **params: str) -> Planner:
            built[_name] += 1
            return _original(config, views, **params)

        monkeypatch.setattr(PLANNERS[name], "from_name", counted)
    # bscp's candidates (seconds of visibility rendering an episode) built once per episode for
    # both runs: they are the episode's, not the planner's (`candidate_views` builds them per
    # episode whether the planner is new or not), and the same episode gives the same ones.
    built_candidates: dict[tuple[object, ...], CandidateViews] = {}
    build_candidates = candidates_module._build_candidates

    def candidates_once(episode: Episode, count: int, resolution: tuple[int, int],
                        screened: Any) -> CandidateViews:
        assert screened is None
        pose = episode.object_pose
        key = (str(episode.scene.mesh.path), pose.position.tobytes(), pose.rotation.tobytes(),
               episode.q.tobytes(), episode.uses_robot, count, tuple(resolution))
        if key not in built_candidates:
            built_candidates[key] = build_candidates(episode, count, resolution, screened)
        # As built: no acquisition simulated yet.
        return dataclasses.replace(built_candidates[key], previews={})

    monkeypatch.setattr(candidates_module, "_build_candidates", candidates_once)
    specs = evaluation_episodes(CONFIG, parts=[DEFAULT_MOTOR], seeds=[0, 1])
    evaluate(CONFIG, names, specs, tmp_path / "once", progress=False, carriers=["free"])
    assert built == dict.fromkeys(names, 1)

    def fresh(run_id: str, config: Config, name: str, views: int | None, stop: str,
              estimator: str | Path | None) -> tuple[Planner, StopRule]:
        return make_planner(name, config, views), make_stop_rule(stop, config, estimator)

    monkeypatch.setattr(evaluation_module, "_built", fresh)
    evaluate(CONFIG, names, specs, tmp_path / "fresh", progress=False, carriers=["free"])
    # The check's, then one per episode.
    assert built == dict.fromkeys(names, 1 + 1 + len(specs))
    once, again = (finished_rows(tmp_path / folder / evaluation_module.EPISODES_NAME)
                   for folder in ("once", "fresh"))
    assert len(once) == len(names) * len(specs)
    assert moved_cells(again, once, ("episode", "planner", "carrier"))[0] == []
    assert len(built_candidates) == len(specs)
