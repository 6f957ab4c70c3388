"""Stop rules (`--stop`): their values, their decisions, the runner's reasons, the plan's
per-view estimates, and the stop study."""

from __future__ import annotations

import csv
import dataclasses
import json
import re
import shutil
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vprobot.agents.trained import TrainedAgent
from vprobot.cli import main
from vprobot.config import Config, replace, with_sensor
from vprobot.coverage.occupancy import OCCUPIED, VOXEL_M, EpisodeGrid, GridSettings, OccupancyGrid
from vprobot.episode import (
    Episode,
    PartScene,
    ViewRequest,
    episode_list,
    seeded_episode,
    write_episode_list,
)
from vprobot.episode.views import band_candidates
from vprobot.evaluation import CURVE_COLUMNS, plan_path
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.planners.runner import PLAN_RAN_OUT, make_planner, run, run_episode
from vprobot.planners.self_stopping import LearnedStop, stop_subject
from vprobot.stop_studies.study import (
    _write_study,
    combinations,
    planner_subjects,
    request_budget,
    study_row,
)
from vprobot.stopping.estimator import BUNDLED_ESTIMATOR, EstimateTracker, load_estimator
from vprobot.stopping.features import FEATURES
from vprobot.stopping.rules import StopSubject, make_stop_rule, parse_stop, stop_names
from vprobot.stopping.rules.estimate import EstimateStop

RESOLUTION = (107, 75)
LIGHT_CONFIG = replace(with_sensor(Config(), "zivid2plus_mr60"), "sensor", resolution=(107, 90))
"""The realistic cell's sensor and sensing model at a small resolution."""
SHARE = 0.25
"""The `measurable` rule's S in its test: reached in about seven views of the default motor
under `LIGHT_CONFIG`."""
CONFIG = replace(Config(), "sensor", resolution=RESOLUTION)


@pytest.fixture(scope="module")
def motor() -> PartScene:
    return PartScene.load(CONFIG, DEFAULT_MOTOR)


@pytest.mark.parametrize(("value", "problem"), [
    ("foo", "unknown stop rule 'foo'"),
    ("views:0", "bad stop rule 'views:0': N must be an integer >= 1"),
    ("views", "bad stop rule 'views': N must be an integer >= 1"),
    ("estimate:1.5", "bad stop rule 'estimate:1.5': C must be a number in (0, 1)"),
    ("estimate:0", "bad stop rule 'estimate:0': C must be a number in (0, 1)"),
    ("measurable:1", "bad stop rule 'measurable:1': S must be a number in (0, 1)"),
])
@pytest.mark.parametrize("command", [["plan", "--out", "plan.json"], ["evaluate"]])
def test_a_bad_stop_value_is_one_line_naming_it_and_what_is_allowed(
        value: str, problem: str, command: list[str], tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    argv = [*command, "--stop", value]
    with pytest.raises(SystemExit) as exit_:  # argparse refuses it, before any work
        main([arg.replace("plan.json", str(tmp_path / "plan.json")) for arg in argv])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and problem in err
    assert f"allowed: {', '.join(stop_names())}\n" in err and "views:N (N >= 1)" in err
    assert not (tmp_path / "plan.json").exists()


def test_parse_stop_reads_each_form() -> None:
    assert [parse_stop(text)[1] for text in ("goal", "estimate", "estimate:0.9", "views:12",
                                             "grid", "agent", "measurable", "measurable:0.1")] == [
        {}, {}, {"confidence": 0.9}, {"count": 12}, {}, {}, {}, {"share": 0.1}]


def test_a_rule_sees_which_planners_stop_at_the_goal_and_which_decide_their_stop() -> None:
    """A planner that is no `SelfStopping` one stops at the goal (`random1`, a plain
    planner); fixed plans and `nbv@RULE` run to their own end, B_SCP only with a view count;
    only a `LearnedStop` decides its stop."""
    cases = [("random1", None, True), ("hrec", None, False), ("uniform5", None, False),
             ("bscp", None, True), ("bscp", 5, False), ("nbv", None, True),
             ("nbv@grid", None, False)]
    for name, views, at_goal in cases:
        subject = stop_subject(make_planner(name, CONFIG, views))
        assert (subject.stops_at_goal, subject.decides_stop) == (at_goal, False), (name, views)
    assert stop_subject(_LearnedStopper()) == StopSubject("agent", False, True)


def test_the_agent_rule_needs_a_planner_with_a_learned_stop(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rule = make_stop_rule("agent", CONFIG)
    rule.bind(StopSubject("agent", stops_at_goal=False, decides_stop=True))
    assert rule.keeps_learned_stop  # the agent rule leaves its stop action in charge
    assert main(["plan", "--no-summary", "--planner", "nbv", "--stop", "agent", "--carrier", "free",
                 "--out", str(tmp_path / "plan.json")]) == 2
    err = capsys.readouterr().err
    assert "stop rule 'agent' needs an agent planner whose action has a stop" in err
    assert "planner 'nbv' has none" in err and not (tmp_path / "plan.json").exists()


class _Stopped(Exception):
    """Ends a run at the planner's reset, once the rule has taken the planner on."""


class _LearnedStopper(LearnedStop):
    """A planner with a learned stop that notes, at its reset, whether the stop is in use."""

    name = "agent"

    def __init__(self) -> None:
        self.seen: list[bool] = []

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self.seen.append(self.decides_stop)
        raise _Stopped

    def next_view(self, episode: Episode) -> ViewRequest | None:
        raise AssertionError("the run ends at the reset")


def test_a_rule_other_than_goal_and_agent_takes_the_stop_from_a_learned_stop() -> None:
    """Through the runner, which turns the planner's learned stop off (a rule sees the planner
    only as a read-only `StopSubject`)."""
    for text, keeps in (("goal", True), ("agent", True), ("views:3", False), ("grid", False),
                        ("estimate", False)):
        planner = _LearnedStopper()
        with pytest.raises(_Stopped):
            run_episode(planner, None, None, CONFIG, None,  # type: ignore[arg-type]
                        make_stop_rule(text, CONFIG))
        assert planner.seen == [keeps], text


def test_views_counts_acquisitions_only() -> None:
    rule = make_stop_rule("views:2", CONFIG)
    acquired = [True, False, True]
    decisions = [rule.check(types.SimpleNamespace(  # type: ignore[arg-type]
        views=[types.SimpleNamespace(acquired=flag) for flag in acquired[:count]]))
        for count in range(4)]
    assert decisions == [None, None, None, "views:2"]


@pytest.mark.parametrize(("confidence", "mean", "std", "stops"), [
    # z(0.95) = 1.6449: 0.94 - 1.6449 * 0.02 = 0.9071 >= 0.9, 0.93 - 0.0329 = 0.8971 < 0.9.
    (0.95, 0.94, 0.02, True), (0.95, 0.93, 0.02, False),
    # z(0.5) = 0: the mean alone decides.
    (0.5, 0.9, 0.3, True), (0.5, 0.899, 0.001, False),
    # z(0.9) = 1.2816: 0.92 - 0.0256 = 0.8944 < 0.9.
    (0.9, 0.92, 0.02, False),
])
def test_the_estimate_rule_stops_when_mean_minus_z_std_reaches_the_goal(
        confidence: float, mean: float, std: float, stops: bool) -> None:
    estimator = types.SimpleNamespace(estimate=lambda features: (np.array(mean), np.array(std)),
                                      features=FEATURES, domain=None)
    rule = EstimateStop(CONFIG, estimator, confidence)  # type: ignore[arg-type]

    def features(views: list[types.SimpleNamespace]) -> np.ndarray:
        vector = np.zeros(len(FEATURES))
        vector[FEATURES.index("acquired")] = sum(view.acquired for view in views)
        return vector

    rule.features = types.SimpleNamespace(  # type: ignore[assignment]
        update=features, reset=lambda: None, read=lambda episode: None)
    view = types.SimpleNamespace(acquired=True)
    reason = rule.check(types.SimpleNamespace(views=[view]))  # type: ignore[arg-type]
    assert (reason is not None) == stops
    if stops:
        assert reason == (f"estimate {100 * mean:.1f} ± {100 * std:.1f} % ≥ 90 % at "
                          f"{100 * confidence:g} %")
    # Nothing acquired: nothing to estimate from, whatever the estimator would say.
    rule.reset()
    assert rule.check(types.SimpleNamespace(  # type: ignore[arg-type]
        views=[types.SimpleNamespace(acquired=False)])) is None


def test_the_runner_says_why_it_stopped(motor: PartScene) -> None:
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    ran_out = run(CONFIG, motor, "uniform3", spec, "free")
    assert (len(ran_out.record.views), ran_out.stop_reason, ran_out.planner_stopped) == (
        3, PLAN_RAN_OUT, True)
    counted = run(CONFIG, motor, "uniform6", spec, "free", stop="views:2")
    assert (len(counted.record.views), counted.stop_reason, counted.planner_stopped) == (
        2, "views:2", False)
    budget = replace(CONFIG, "env", max_acquisitions=3)
    capped = run(budget, motor, "uniform12", spec, "free", stop="views:20")
    assert (len(capped.record.views), capped.stop_reason, capped.stop_rule) == (
        3, "max views", "views:20")


def test_nbv_at_grid_makes_the_requests_of_nbv_under_the_grid_rule(motor: PartScene) -> None:
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    self_stopped = run(CONFIG, motor, "nbv@grid", spec, "free")
    governed = run(CONFIG, motor, "nbv", spec, "free", stop="grid")
    requests = [[view.requested.position.tolist() for view in result.record.views]
                for result in (self_stopped, governed)]
    assert requests[0] == requests[1]
    # The grid stopped both, well within the budget: the planner itself, or the runner.
    assert len(requests[0]) <= CONFIG.env.max_acquisitions
    assert self_stopped.stop_reason == governed.stop_reason
    assert self_stopped.stop_reason.startswith("grid: the latest 2 views")
    assert (self_stopped.planner_stopped, governed.planner_stopped) == (True, False)


def test_the_measurable_rule_stops_at_the_first_view_where_at_most_s_is_left() -> None:
    # The share worked out again after each view from a grid of the run's frames: the bound
    # of every band candidate (free-flying, all reachable) against the occupied voxels.
    spec = seeded_episode(LIGHT_CONFIG.env, DEFAULT_MOTOR, 0)
    motor = PartScene.load(LIGHT_CONFIG, DEFAULT_MOTOR)
    result = run(LIGHT_CONFIG, motor, "nbv", spec, "free", stop=f"measurable:{SHARE}")
    assert result.stop_reason.startswith("measurable: the reachable candidates would measure")
    views = result.record.views
    grid = EpisodeGrid(GridSettings.of(LIGHT_CONFIG))
    grid.update(views)
    gains = band_candidates(LIGHT_CONFIG, VOXEL_M).gains
    left = []
    for count in range(1, len(views) + 1):
        after = grid.after(count)
        measurable = gains.revisits(after).measurable
        left.append(measurable / (measurable + int((after.state == OCCUPIED).sum())))
    assert 2 < len(views) < LIGHT_CONFIG.env.max_acquisitions
    assert min(left[:-1]) > SHARE >= left[-1]
    # Asked before a fixed plan's first view, with nothing seen, it lets the plan start.
    fixed = run(LIGHT_CONFIG, motor, "uniform3", spec, "free", stop=f"measurable:{SHARE}")
    assert (len(fixed.record.views), fixed.stop_reason) == (3, PLAN_RAN_OUT)


def test_nbv_at_any_rule_stops_itself_by_that_rule(motor: PartScene) -> None:
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    result = run(CONFIG, motor, "nbv:frontier@views:2", spec, "free")
    assert (len(result.record.views), result.stop_reason, result.planner_stopped) == (
        2, "views:2", True)


@pytest.mark.parametrize(("planner", "problem"), [
    ("nbv@foo", f"nbv@foo: unknown stop rule 'foo'; allowed: {', '.join(stop_names())}\n"),
    ("nbv@views:0", "nbv@views:0: bad stop rule 'views:0': N must be an integer >= 1"),
    ("nbv@agent", "nbv@agent: stop rule 'agent' needs an agent planner"),
])
def test_a_bad_rule_in_a_self_stopped_nbv_is_one_line_listing_the_rules(
        planner: str, problem: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["plan", "--planner", planner, "--out", str(tmp_path / "plan.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and problem in err
    assert not (tmp_path / "plan.json").exists()


def test_plan_with_the_estimate_rule_says_why_and_the_estimate_at_each_view(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    plan = tmp_path / "plan.json"
    estimator = tmp_path / "copy.npz"
    shutil.copy(BUNDLED_ESTIMATOR, estimator)
    assert main(["plan", "--no-summary", "--planner", "nbv", "--carrier", "free", "--stop",
                 "estimate:0.9",
                 "--estimator", str(estimator), "--out", str(plan)]) == 0
    out = capsys.readouterr().out
    document = json.loads(plan.read_text())
    assert document["stop_rule"] == "estimate:0.9"
    estimates = [(view["estimate"]["mean"], view["estimate"]["std"])
                 for view in document["views"]]
    # Independently of the rule's code: it stopped at the first view whose lower bound at
    # z(0.9) = 1.2816 reached the goal, or at the budget.
    bounds = [mean - 1.2815516 * std for mean, std in estimates]
    if document["stop_reason"] == "max views":
        assert max(bounds) < 0.9 and len(estimates) == 1 + CONFIG.env.max_acquisitions
    else:
        assert bounds[-1] >= 0.9 and max(bounds[:-1], default=0.0) < 0.9
        shown = re.fullmatch(r"estimate (\S+) ± (\S+) % ≥ 90 % at 90 %",
                             document["stop_reason"])
        assert shown is not None
        assert float(shown[1]) == round(100 * estimates[-1][0], 1)
        assert float(shown[2]) == round(100 * estimates[-1][1], 1)
        assert f"stopped: {document['stop_reason']} (--stop estimate:0.9)" in out
    assert all(0.0 <= mean <= 1.0 and std > 0.0 for mean, std in estimates)
    assert f"{100 * estimates[0][0]:5.1f} ± {100 * estimates[0][1]:4.1f} %" in out


def test_study_row_counts_the_goal_share_wasted_views_and_false_stops_by_hand() -> None:
    # Budget 11: the second episode stopped before it, below the goal (a false stop); the
    # third ran to it.
    curve = {key: 50.0 for key in CURVE_COLUMNS}
    rows = [{"episode": 0, "success": True, "coverage_pct": 92.0, "requested": 6,
             "acquisitions": 6, "views_to_goal": 4, **curve},
            {"episode": 1, "success": False, "coverage_pct": 80.0, "requested": 9,
             "acquisitions": 9, "views_to_goal": None, **curve},
            {"episode": 2, "success": False, "coverage_pct": 85.0, "requested": 11,
             "acquisitions": 10, "views_to_goal": None, **curve}]
    assert study_row(rows, "test-v1", "nbv", "grid", 11) == {
        "episodes": "test-v1", "planner": "nbv", "stop": "grid", "count": 3,
        "at_goal_pct": pytest.approx(100 / 3), "coverage_pct": pytest.approx(257 / 3),
        "requested": pytest.approx(26 / 3), "acquisitions": pytest.approx(25 / 3),
        "wasted": pytest.approx(2 / 3), "extra_vs_goal": None, "stopped": 2,
        "false_stops": 1, "median_extra_vs_goal": None, "out_of_reach_stops": None,
        "plateau_gap_median": None, "plateau_gap_min": None, "plateau_gap_max": None,
        "by_episode": {0: 6, 1: 9, 2: 11}, "to_goal": {0: 4, 1: 9, 2: 11},
        "below_goal": {1}, "missed": {1, 2}, "fixed_plan": False,
        # The curve's columns hold 10 requests; the 11th is the coverage at the end.
        "curves": {0: [0.5] * 6, 1: [0.5] * 9, 2: [0.5] * 10 + [0.85]}}


def test_extra_views_and_out_of_reach_stops_are_per_episode_against_the_planner_at_goal(
        tmp_path: Path) -> None:
    # At the goal, episode 2 misses it within the budget, its coverage within 1 pp of its
    # highest from its 4th request; under the rule episodes 1 and 2 stop below the goal: 1 is a
    # false stop, 2 out of reach, 8 requests in: 4 after that plateau.
    goal = {"episodes": "a", "planner": "nbv", "stop": "goal", "requested": 5.0,
            "by_episode": {0: 4, 1: 5, 2: 6}, "to_goal": {0: 4, 1: 5, 2: 6},
            "below_goal": set(), "missed": {2},
            "curves": {0: None, 1: None, 2: [0.5, 0.7, 0.8, 0.85, 0.85, 0.855]}}
    rule = {"episodes": "a", "planner": "nbv", "stop": "grid", "requested": 7.0,
            "by_episode": {0: 4, 1: 9, 2: 8}, "below_goal": {1, 2}, "missed": {1, 2},
            "curves": {}}
    other = {**rule, "planner": "agent"}
    table = [{**row, "count": 3, "at_goal_pct": 0.0, "coverage_pct": 0.0, "acquisitions": 0.0,
              "wasted": 0.0, "extra_vs_goal": None, "stopped": 2, "false_stops": 2,
              "median_extra_vs_goal": None, "out_of_reach_stops": None,
              "plateau_gap_median": None, "plateau_gap_min": None, "plateau_gap_max": None,
              "fixed_plan": False}
             for row in (goal, rule, other)]
    _write_study(tmp_path, table, CONFIG)
    assert (table[1]["extra_vs_goal"], table[1]["median_extra_vs_goal"]) == (2.0, 2)
    assert (table[1]["false_stops"], table[1]["out_of_reach_stops"]) == (1, 1)
    assert table[1]["plateau_gap_median"] == table[1]["plateau_gap_max"] == 4
    assert (table[2]["extra_vs_goal"], table[2]["median_extra_vs_goal"]) == (None, None)
    assert (table[2]["false_stops"], table[2]["out_of_reach_stops"]) == (2, None)
    study = (tmp_path / "study.md").read_text()
    assert ("| nbv | grid | 3 | 0 | 0.00 | 7.00 | 0.00 | 0.00 | 2.00 | 2.0 | 2 | 1 | 1 | "
            "+4 (+4 to +4) |") in study
    assert "| agent | grid | 3 | 0 | 0.00 | 7.00 | 0.00 | 0.00 | - | - | 2 | 2 | - | - |" in study


def test_a_fixed_plan_is_counted_to_the_request_after_which_it_reached_the_goal(
        tmp_path: Path) -> None:
    # uniform10 under `goal` runs its whole plan (10 requests; the view budget allows 11) and
    # reaches the goal after its 5th and 7th requests in episodes 0 and 1, never in episode 2
    # (its coverage within 1 pp of its highest from its 3rd request). Under the rule it stops
    # after 6, 5 and 4 requests, each before the plan's end: one view late, a false stop two
    # views early, and out of reach one view after the plateau.
    subjects = planner_subjects(CONFIG, ["uniform10", "nbv"])
    assert [request_budget(CONFIG, subject) for subject in subjects.values()] == [None, 11]
    curve = {key: 50.0 for key in CURVE_COLUMNS}
    views = [5, 7, None]
    rows = [{"episode": episode, "success": to_goal is not None, "coverage_pct": 91.0,
             "requested": 10, "acquisitions": 10, "views_to_goal": to_goal, **curve}
            for episode, to_goal in enumerate(views)]
    rising = [50.0, 70.0, 85.0, 85.5, 85.6]
    for number, key in enumerate(CURVE_COLUMNS):
        rows[2][key] = rising[number] if number < len(rising) else 85.8
    rows[2]["coverage_pct"] = 85.8
    goal = study_row(rows, "a", "uniform10", "goal", None)
    # The plan ran to its end: not stopped early, and no false stop.
    assert (goal["stopped"], goal["false_stops"]) == (0, 0)
    stopped = [{**row, "requested": requested, "success": success, "views_to_goal": None}
               for row, requested, success in zip(rows, [6, 5, 4], [True, False, False],
                                                  strict=True)]
    stopped[0]["views_to_goal"] = 5
    rule = study_row(stopped, "a", "uniform10", "confident", None)
    # Its stops are known only against the plan's run at the goal.
    assert (rule["stopped"], rule["false_stops"]) == (None, None)
    table = [goal, rule]
    _write_study(tmp_path, table, CONFIG)
    assert rule["extra_vs_goal"] == pytest.approx(5.0 - (5 + 7 + 10) / 3)
    assert rule["median_extra_vs_goal"] == -2
    assert (rule["stopped"], rule["false_stops"], rule["out_of_reach_stops"]) == (3, 1, 1)
    assert rule["plateau_gap_median"] == 4 - 1 - 2


def test_a_curve_longer_than_the_episodes_table_is_read_from_the_episodes_plan(
        tmp_path: Path) -> None:
    # 13 requests: the table's columns hold 10, the coverage at the end an 11th; the plan JSON
    # of the row, where the evaluation keeps it, holds every view.
    coverage = [0.1 * number for number in range(1, 11)] + [0.95, 0.96, 0.97]
    row = {"episode": 3, "carrier": "robot", "planner": "nbv", "success": True,
           "coverage_pct": 97.0, "requested": 13, "acquisitions": 13, "views_to_goal": 11,
           **{key: 100.0 * value for key, value in zip(CURVE_COLUMNS, coverage, strict=False)}}
    assert study_row([row], "a", "nbv", "goal", 26)["curves"] == {3: None}
    plan = plan_path(tmp_path, 3, "robot", "nbv")
    plan.parent.mkdir(parents=True)
    plan.write_text(json.dumps({"views": [{"coverage": value} for value in coverage]}))
    assert study_row([row], "a", "nbv", "goal", 26, tmp_path)["curves"] == {3: coverage}


def test_the_study_runs_a_rule_only_with_the_planners_it_applies_to() -> None:
    # `goal` runs every planner that does not decide its own stop: a fixed plan (uniform4) to
    # its end.
    assert combinations(CONFIG, ["uniform4", "random2"], ["goal", "agent", "views:2"]) == [
        ("goal", ["uniform4", "random2"]), ("views:2", ["uniform4", "random2"])]


def _low_resolution_and_one_episode(folder: Path) -> tuple[Path, Path]:
    """A config file at the tests' low resolution, with straight-line moves only (the robot's
    view band is then screened in seconds, not the minute of motion planning the default
    cell's takes), and a list of one episode on the default motor."""
    config = folder / "low.yaml"
    config.write_text(f"sensor:\n  resolution: [{RESOLUTION[0]}, {RESOLUTION[1]}]\n"
                      f"kinematics:\n  path_planner: line\n")
    episodes = folder / "one.json"
    write_episode_list(episodes, episode_list(CONFIG, [DEFAULT_MOTOR], [0]))
    return config, episodes


def test_the_stop_study_runs_from_one_command(tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    config, episodes = _low_resolution_and_one_episode(tmp_path)
    out = tmp_path / "study"
    assert main(["stop", "study", "--config", str(config), "--out", str(out), "--episodes",
                 str(episodes), "--planners", "uniform2", "--stop", "views:1", "grid"]) == 0
    with (out / "study.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert [(row["planner"], row["stop"], row["count"]) for row in rows] == [
        ("uniform2", "views:1", "1"), ("uniform2", "grid", "1")]
    # views:1 stops after the first acquisition; the grid rule needs three frames, so the
    # two views of uniform2 run out first.
    assert (rows[0]["requested"], rows[1]["requested"]) == ("1.0", "2.0")
    for rule in ("views-1", "grid"):
        with (out / "one" / rule / "evaluation_episodes.csv").open() as stream:
            (episode,) = csv.DictReader(stream)
        assert episode["planner"] == f"uniform2 --stop {rule.replace('-', ':')}"
    assert (out / "study.png").stat().st_size > 0
    assert "| uniform2 | views:1 | 1 |" in capsys.readouterr().out


def test_stop_error_is_the_mean_absolute_error_of_the_estimate_against_the_rollouts_truth(
        tmp_path: Path) -> None:
    config, episodes = _low_resolution_and_one_episode(tmp_path)
    out = tmp_path / "error"
    assert main(["stop", "error", "--config", str(config), "--out", str(out), "--episodes",
                 str(episodes), "--planners", "uniform2"]) == 0
    with (out / "one.csv").open() as stream:
        views = list(csv.DictReader(stream))
    assert [int(row["view"]) for row in views] == [1, 2]
    mean, _ = load_estimator().estimate(
        np.array([[float(row[name]) for name in FEATURES] for row in views]))
    truth = np.array([float(row["coverage"]) for row in views])
    with (out / "error.csv").open() as stream:
        rows = {row["view"]: float(row["mae_pp"]) for row in csv.DictReader(stream)}
    expected = 100 * np.abs(truth - mean)
    assert rows["1"] == pytest.approx(expected[0])
    assert rows["2"] == pytest.approx(expected[1])
    assert rows["all"] == pytest.approx(expected.mean())


def test_estimate_takes_the_bundled_estimator_fitted_on_the_runs_sensor_and_sensing() -> None:
    from vprobot.config import load_config, with_sensor
    from vprobot.files.paths import CONFIGS_DIR
    from vprobot.stopping.estimator import BUNDLED_ESTIMATORS, bundled_estimator

    real = load_config(CONFIGS_DIR / "cell_real.yaml")
    assert bundled_estimator(Config().sensor) == BUNDLED_ESTIMATOR
    assert bundled_estimator(real.sensor) == BUNDLED_ESTIMATORS[1]
    rule = make_stop_rule("estimate", real)
    assert isinstance(rule, EstimateStop)
    domain = rule.estimator.domain
    assert domain is not None and domain.sensor_mismatch(real.sensor) is None
    # The full-frame preset: the features count per pixel, so the 612 x 512 fit serves it.
    assert bundled_estimator(with_sensor(Config(), "zivid2plus_mr60").sensor) == (
        BUNDLED_ESTIMATORS[1])
    # Fitted on none: the paper sensor's, whose estimates the tracker then refuses.
    ideal_zivid = replace(real, "sensor", sensing="ideal").sensor
    assert bundled_estimator(ideal_zivid) == BUNDLED_ESTIMATOR
    assert load_estimator(None, ideal_zivid).domain.sensor_mismatch(ideal_zivid) is not None


class FirstOffered:
    """An `s_grid` policy: the first candidate its mask offers."""

    def predict(self, observation: dict[str, np.ndarray], deterministic: bool = True) -> tuple:
        return np.array(int(np.argmax(observation["mask"]))), None


@pytest.mark.parametrize(("planner", "stop"), [("agent:stub", "estimate"), ("nbv", "grid")])
def test_every_frame_is_integrated_once_however_many_read_the_episodes_grid(
        motor: PartScene, planner: str, stop: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The `s_grid` agent's state or nbv, the rule and the estimate after each view each read
    an occupancy grid of the same settings: the episode's, into which each acquired frame is
    integrated once (each of them integrated every frame into its own before)."""
    config = replace(CONFIG, "env", action="A_view", state="s_grid", max_acquisitions=4)
    monkeypatch.setattr("vprobot.agents.trained.load_agent", lambda source: TrainedAgent(
        model=FirstOffered(), config=config, path=Path("stub.zip")))  # type: ignore[arg-type]
    integrated: list[int] = []
    integrate = OccupancyGrid.integrate

    def counting(grid: OccupancyGrid, sensor: Any, pose: Any, points_world: np.ndarray,
                 *args: Any) -> None:
        integrated.append(id(points_world))
        integrate(grid, sensor, pose, points_world, *args)

    monkeypatch.setattr(OccupancyGrid, "integrate", counting)
    spec = seeded_episode(config.env, DEFAULT_MOTOR, 0)
    result = run(config, motor, planner, spec, "free", stop=stop, estimates=True)
    acquired = [id(view.points_world) for view in result.record.views if view.acquired]
    assert len(acquired) >= 3 and result.estimates is not None
    assert sorted(integrated) == sorted(acquired)


def test_a_stop_held_back_by_an_estimator_that_never_claimed_the_goal_says_so() -> None:
    # `claim_limits` writes -inf where the estimate claimed the goal on no training view (the
    # bundled structured-light estimator); with finite limits the percentile is named.
    estimator = load_estimator()
    assert estimator.domain is not None and estimator.domain.claimed is not None
    features = (estimator.domain.low + estimator.domain.high) / 2.0
    features[FEATURES.index("acquired")] = 2.0
    column = FEATURES.index("unknown")
    features[column] = estimator.domain.claimed[column] + 0.01
    finite = EstimateTracker(estimator, Config()).update(features).held
    assert finite == (f"held back from a stop: unknown above "
                      f"{estimator.domain.claimed[column]:.4g}, the 98th percentile over the "
                      f"training views on which it claimed the goal (space it was not shown to "
                      f"judge)")
    never = dataclasses.replace(estimator, domain=dataclasses.replace(
        estimator.domain, claimed=np.where(np.isfinite(estimator.domain.claimed), -np.inf,
                                           np.inf)))
    tracker = EstimateTracker(never, Config())
    held = tracker.update(features).held
    assert held == ("held back from every stop: on none of its training views did it claim "
                    "the goal, so nothing shows that a claim of it holds")
    assert held in tracker.notes and "inf" not in held
