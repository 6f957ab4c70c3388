"""`vprobot train --seeds`: the spread over seeds against hand-computed numbers, and a two-seed
run through the CLI (folder layout, resume without retraining, refused option mixes)."""

from __future__ import annotations

import csv
import json
import re
import shutil
import types
import typing
from pathlib import Path

import pytest

from vprobot.cli import main
from vprobot.config import Config, ConfigError, Selection, replace
from vprobot.evaluation import COLUMNS
from vprobot.files.atomic import csv_text
from vprobot.files.paths import ASSETS_DIR, CONFIGS_DIR, MOTORS_DIR
from vprobot.training.callbacks import (
    EVALUATION_COLUMNS,
    SharedEpisodeEvaluation,
    upgrade_evaluations,
)
from vprobot.training.runs import best_evaluation, best_validation
from vprobot.training.seeds import seeds_table, write_summary
from vprobot.training.train import profile_config

PROFILE = str(CONFIGS_DIR / "agents" / "cpu.yaml")
# A few env steps on one bundled motor at a small resolution, scored on one validation episode.
TINY = ["sensor.resolution=[64,45]", "env.resolution=[64,45]", "env.state_points=64",
        "env.parts=mesh", f"env.mesh={MOTORS_DIR / 'train' / 'motor_000.stl'}",
        "agent.learning_starts=50", "agent.batch_size=32", "agent.buffer_size=400",
        "agent.eval_freq=100", "agent.checkpoint_freq=100", "agent.eval_episodes=1",
        "agent.net_arch=[16,16]", "agent.test_lists=null"]


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(path.read_text().splitlines()))


def _validation(run: Path, rows: list[tuple[int, float, float, float]]) -> None:
    """An `evaluations.csv` of (step, coverage, acquisitions, success) rows, as fractions."""
    run.mkdir(parents=True)
    (run / "result.json").write_text("{}\n")
    (run / "evaluations.csv").write_text(csv_text(EVALUATION_COLUMNS, [
        {"step": step, "coverage_pct": 100 * coverage, "acquisitions": acquisitions,
         "success_pct": 100 * success}
        for step, coverage, acquisitions, success in rows]))


def _test_list(run: Path, name: str, episodes: int, **row: float | None) -> None:
    folder = run / "test" / name
    folder.mkdir(parents=True)
    (folder / "evaluation.csv").write_text(csv_text(COLUMNS, [
        {"planner": f"agent:{run}", "carrier": "robot", "episodes": episodes, **row}]))


def test_seed_summary_is_mean_min_max_of_best_validation_and_complete_test_lists(
        tmp_path: Path) -> None:
    config = replace(Config(), "agent", test_lists=("shapes-v1",))
    # Best model: highest coverage, fewer acquisitions breaking the tie (seed 0: the middle row).
    _validation(tmp_path / "seed-0", [(100, 0.80, 9, 0.2), (200, 0.85, 8, 0.4),
                                      (300, 0.85, 10, 0.6)])
    _validation(tmp_path / "seed-1", [(100, 0.70, 12, 0.2), (200, 0.90, 11, 0.6)])
    _validation(tmp_path / "seed-2", [(100, 0.60, 10, 0.0)])
    # shapes-v1 has 15 episodes: seed 1's table covers 7 (interrupted), so it is left out;
    # no episode of seed 2 reached the goal, so it has no views to goal.
    _test_list(tmp_path / "seed-0", "shapes-v1", 15, coverage_pct=92.5, acquisitions=9.2,
               success_pct=80.0, area_pct=70.5, views_to_goal=7.0)
    _test_list(tmp_path / "seed-1", "shapes-v1", 7, coverage_pct=99.0, acquisitions=5.0,
               success_pct=100.0, area_pct=90.0, views_to_goal=3.0)
    _test_list(tmp_path / "seed-2", "shapes-v1", 15, coverage_pct=88.5, acquisitions=12.0,
               success_pct=0.0, area_pct=60.5, views_to_goal=None)

    table = seeds_table(config, tmp_path, [0, 1, 2])
    write_summary(config, tmp_path, [0, 1, 2], table, ["vprobot", "train", "cpu.yaml"])

    rows = {row["evaluation"]: row for row in _rows(tmp_path / "seeds.csv")}
    assert list(rows) == ["validation", "shapes-v1"]
    validation, test = rows["validation"], rows["shapes-v1"]
    assert (validation["seeds"], validation["runs"]) == ("0 1 2", "3")
    expected = {"coverage_pct": ((85 + 90 + 60) / 3, 60, 90),
                "acquisitions": ((8 + 11 + 10) / 3, 8, 11),
                "success_pct": ((40 + 60 + 0) / 3, 0, 60)}
    for key, (mean, low, high) in expected.items():
        assert float(validation[key]) == pytest.approx(mean)
        assert (float(validation[f"{key}_min"]), float(validation[f"{key}_max"])) == (
            pytest.approx(low), pytest.approx(high))
    assert validation["area_pct"] == validation["views_to_goal"] == ""
    assert (test["seeds"], test["runs"]) == ("0 2", "2")
    expected = {"coverage_pct": (90.5, 88.5, 92.5), "acquisitions": (10.6, 9.2, 12.0),
                "success_pct": (40.0, 0.0, 80.0), "area_pct": (65.5, 60.5, 70.5),
                "views_to_goal": (7.0, 7.0, 7.0)}
    for key, (mean, low, high) in expected.items():
        assert float(test[key]) == pytest.approx(mean)
        assert (float(test[f"{key}_min"]), float(test[f"{key}_max"])) == (
            pytest.approx(low), pytest.approx(high))
    markdown = (tmp_path / "seeds.md").read_text()
    assert markdown.startswith("**Partial: 2 of 3 seeds;")
    assert "Seeds: 0, 1, 2: one run per seed" in markdown
    assert ("| shapes-v1 | 0 2 | 90.5 (88.5-92.5) | 10.60 (9.20-12.00) | 40 (0-80) "
            "| 65.5 (60.5-70.5) | 7.00 (7.00-7.00) |") in markdown
    assert "| validation | 0 1 2 | 78.3 (60.0-90.0) | 9.67 (8.00-11.00) | 33 (0-60) | - | - |" \
        in markdown


# (step, coverage, acquisitions, success): the imitation, then RL that reaches the goal in every
# episode with more views; steps 12 500 and 15 000 tie on goal rate and views.
SELECTION_ROWS = [(0, 0.920, 4.92, 0.92), (2500, 0.924, 6.24, 0.96), (7500, 0.919, 6.10, 1.0),
                  (10000, 0.927, 6.40, 1.0), (12500, 0.925, 6.10, 1.0),
                  (15000, 0.925, 6.10, 1.0)]


@pytest.mark.parametrize(("select", "step"), [("coverage", 10000), ("goal_then_views", 12500)])
def test_the_best_validation_row_is_the_runs_selection_rule(
        tmp_path: Path, select: str, step: int) -> None:
    """coverage: the highest coverage; goal_then_views: of the rows at the highest goal rate
    the fewest acquisitions, then the higher coverage, then the earliest."""
    _validation(tmp_path / "run", SELECTION_ROWS)
    assert best_validation(tmp_path / "run", select)["step"] == step  # type: ignore[arg-type]


def test_selection_in_the_cells_terms_ranks_by_goal_then_requests_then_cycle(
        tmp_path: Path) -> None:
    """goal_then_cycle: of the rows at the highest goal rate the fewest requests (failed ones
    included, though it acquired fewer), then the shorter cycle; a row without a cycle last."""
    rows = [  # step, success, acquisitions, requested, cycle s
        (0, 0.9, 4.0, 4.0, 8.0), (2500, 1.0, 4.5, 5.5, 9.0), (5000, 1.0, 5.0, 5.0, 11.0),
        (7500, 1.0, 5.0, 5.0, 10.0), (10000, 1.0, 5.0, 5.0, None)]
    run = tmp_path / "run"
    run.mkdir()
    (run / "result.json").write_text("{}\n")
    (run / "evaluations.csv").write_text(csv_text(EVALUATION_COLUMNS, [
        {"step": step, "coverage_pct": 92.0, "acquisitions": acquisitions,
         "requested": requested, "success_pct": 100 * success, "cycle_time_s": cycle}
        for step, success, acquisitions, requested, cycle in rows]))
    # goal_then_views would take step 2500 (4.5 acquisitions), which failed a request.
    assert best_validation(run, "goal_then_views")["step"] == 2500
    assert best_validation(run, "goal_then_cycle")["step"] == 7500


@pytest.mark.parametrize(("select", "kept"), [
    ("coverage", [0, 2500, 2500, 10000, 10000, 10000]),
    ("goal_then_views", [0, 2500, 7500, 7500, 12500, 12500]),
])
def test_the_evaluation_callback_keeps_the_best_model_under_agent_select(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, select: str, kept: list[int]) -> None:
    summaries = iter([{"coverage_pct": 100 * coverage, "acquisitions": acquisitions,
                       "success_pct": 100 * success}
                      for _, coverage, acquisitions, success in SELECTION_ROWS])
    monkeypatch.setattr("vprobot.training.callbacks.evaluate_policy", lambda *args: None)
    monkeypatch.setattr("vprobot.training.callbacks.policy_summary",
                        lambda rows: next(summaries))
    model = types.SimpleNamespace(num_timesteps=0, logger=types.SimpleNamespace(
        record=lambda *args: None), save=lambda path: Path(path).write_text(
            str(model.num_timesteps)))
    run = tmp_path / "run"
    run.mkdir()
    callback = SharedEpisodeEvaluation(None, [], run, 2500, 0.0, select)  # type: ignore[arg-type]
    for index, ((step, *_), best) in enumerate(zip(SELECTION_ROWS, kept, strict=True)):
        if index == 3:
            # A resume reads the best so far from evaluations.csv under the same rule.
            callback = SharedEpisodeEvaluation(None, [], run, 2500, 0.0,  # type: ignore[arg-type]
                                               select)
        model.num_timesteps = step
        callback.evaluate_model(model)  # type: ignore[arg-type]
        assert int((run / "best_model.zip").read_text()) == best, step


def test_agent_select_is_coverage_by_default_and_goal_then_views_for_the_candidate_profile(
) -> None:
    assert Config().agent.select == "coverage"
    assert profile_config(CONFIGS_DIR / "agents" / "cpu.yaml").agent.select == "coverage"
    candidates = profile_config(CONFIGS_DIR / "agents" / "cpu-candidates.yaml")
    assert candidates.agent.select == "goal_then_views"
    # The message lists every rule the config accepts, whatever they are.
    allowed = list(typing.get_args(Selection))
    assert {"coverage", "goal_then_views", "goal_then_cycle"} <= set(allowed)
    with pytest.raises(ConfigError, match=re.escape(
            f"agent.select must be one of {allowed}, got 'views'")):
        replace(Config(), "agent", select="views")


def test_train_seeds_makes_one_run_per_seed_and_goes_on_without_retraining(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "seeds"
    command = ["train", PROFILE, "--seeds", "0", "1", "--set", *TINY, "--out", str(out),
               "--steps", "5"]
    assert main(command) == 0
    for seed in (0, 1):
        run = out / f"seed-{seed}"
        for name in ("config.yaml", "evaluations.csv", "best_model.zip", "final_model.zip",
                     "result.json"):
            assert (run / name).is_file(), (seed, name)
        assert json.loads((run / "run.json").read_text())["seed"] == seed
        assert f"--steps 5 --seed {seed} --out {run}\n" in (run / "command.txt").read_text()
    coverages = [float(_rows(out / f"seed-{seed}" / "evaluations.csv")[0]["coverage_pct"])
                 for seed in (0, 1)]
    summary = _rows(out / "seeds.csv")[0]
    assert (summary["evaluation"], summary["seeds"]) == ("validation", "0 1")
    assert float(summary["coverage_pct"]) == pytest.approx(sum(coverages) / 2)
    assert (float(summary["coverage_pct_min"]), float(summary["coverage_pct_max"])) == (
        pytest.approx(min(coverages)), pytest.approx(max(coverages)))
    assert "Partial" not in (out / "seeds.md").read_text()

    # Seed 1 interrupted after training (no result.json): the rerun goes on with it from its
    # checkpoint and leaves the finished seed 0 alone.
    (out / "seed-1" / "result.json").unlink()
    models = {seed: (out / f"seed-{seed}" / "final_model.zip").stat().st_mtime_ns
              for seed in (0, 1)}
    started = (out / "seed-1" / "run.json").read_text()
    capsys.readouterr()
    assert main(command) == 0
    assert "2 seeds, 1 finished, 1 to run" in capsys.readouterr().out
    assert (out / "seed-0" / "final_model.zip").stat().st_mtime_ns == models[0]
    assert (out / "seed-1" / "run.json").read_text() == started
    assert (out / "seed-1" / "result.json").is_file()
    models[1] = (out / "seed-1" / "final_model.zip").stat().st_mtime_ns

    assert main(command) == 0
    assert "2 seeds, 2 finished, 0 to run" in capsys.readouterr().out
    assert {seed: (out / f"seed-{seed}" / "final_model.zip").stat().st_mtime_ns
            for seed in (0, 1)} == models

    # Other settings into the same folder are refused, naming the setting.
    assert main([*command[:-1], "6"]) == 2
    assert capsys.readouterr().err == (
        f"vprobot train: error: {out / 'seed-0'} holds a run with another agent.total_steps; "
        f"rerun the command that started it to go on, or choose another --out\n")


@pytest.mark.parametrize(("options", "message"), [
    (["--seeds", "0", "1", "--seed", "0"],
     "give --seed (one run) or --seeds (one run per seed), not both"),
    (["--seeds", "0", "0"], "--seeds 0 0: give each seed once"),
    (["--workers", "2"], "--workers and --address run the seeds of --seeds on Ray; add --seeds"),
], ids=["seed-and-seeds", "repeated-seed", "workers-without-seeds"])
def test_train_refuses_seed_option_mixes_before_writing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], options: list[str],
        message: str) -> None:
    out = tmp_path / "seeds"
    assert main(["train", PROFILE, *options, "--out", str(out)]) == 2
    assert capsys.readouterr().err == f"vprobot train: error: {message}\n"
    assert not out.exists()


def test_committed_runs_in_the_old_columns_are_read_in_todays() -> None:
    # The bundled agent's evaluations.csv predates the one summary: fractions, and k_cum as
    # `travel_<cost>` (today one step's travel in the env's info).
    path = ASSETS_DIR / "agents" / "cpu" / "evaluations.csv"
    raw = _rows(path)
    assert {"coverage", "travel_joint_time"} <= set(raw[0])
    best = best_evaluation(path, "coverage")
    assert best is not None and not {"coverage", "travel_joint_time"} & set(best)
    (row,) = [row for row in raw if row["step"] == best["step"]]
    assert best["coverage_pct"] == 100 * max(float(row["coverage"]) for row in raw)
    assert best["success_pct"] == 100 * float(row["success"])
    assert best["reachable_pct"] == 100 * float(row["reachable_share"])
    assert best["plan_ms_per_view"] == float(row["ms_per_view"])
    for cost, column in (("joint_time", "joint_time_s"), ("joint_path", "joint_path_rad"),
                         ("cartesian", "cartesian_m"), ("paper", "paper_m")):
        assert best[column] == float(row[f"travel_{cost}"])


def test_a_run_resumed_by_this_version_rewrites_old_evaluations_in_todays_columns(
        tmp_path: Path) -> None:
    old = ASSETS_DIR / "agents" / "cpu" / "evaluations.csv"
    path = tmp_path / "evaluations.csv"
    shutil.copy(old, path)
    upgrade_evaluations(path)
    rows = _rows(path)
    assert path.read_text().splitlines()[0].split(",") == list(EVALUATION_COLUMNS)
    assert [float(row["coverage_pct"]) for row in rows] == [
        100 * float(row["coverage"]) for row in _rows(old)]
    before = path.read_text()
    upgrade_evaluations(path)  # today's file: left as it is
    assert path.read_text() == before
