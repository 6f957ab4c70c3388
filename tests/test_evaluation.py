"""Planner evaluation tables and the planner benchmark."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from vprobot.benchmarks.planners import print_table, run_planners_benchmark
from vprobot.config import Config
from vprobot.evaluation import COLUMNS, EPISODE_COLUMNS, evaluate, summarize
from vprobot.paths import DEFAULT_MOTOR

CONFIG = Config()


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open() as stream:
        return list(csv.DictReader(stream))


def test_evaluate_writes_markdown_and_csv(tmp_path: Path) -> None:
    table = evaluate(CONFIG, ["hrec", "random2"], [DEFAULT_MOTOR], [0, 1], tmp_path,
                     progress=False)
    assert [(row["planner"], row["mode"]) for row in table] == [
        ("hrec", "robot"), ("random2", "robot"), ("hrec", "free"), ("random2", "free")]
    summary = read_csv(tmp_path / "evaluation.csv")
    assert list(summary[0]) == list(COLUMNS) and len(summary) == 4
    episodes = read_csv(tmp_path / "evaluation_episodes.csv")
    assert list(episodes[0]) == list(EPISODE_COLUMNS) and len(episodes) == 8
    for row in episodes:
        assert 0.0 <= float(row["coverage_pct"]) <= 100.0
        assert int(row["acquisitions"]) <= int(row["requested"])
        if row["mode"] == "free":
            assert row["joint_time_s"] == "" and row["reachable_pct"] == ""
        else:
            assert float(row["joint_time_s"]) > 0.0
            assert 0.0 <= float(row["reachable_pct"]) <= 100.0
    hrec_free = next(row for row in table if row["planner"] == "hrec" and row["mode"] == "free")
    assert hrec_free["acquisitions"] == 6 and hrec_free["joint_time_s"] is None
    markdown = (tmp_path / "evaluation.md").read_text()
    assert "| hrec | free | 2 |" in markdown and "B_SCP,5 | 98.17" in markdown


def test_episodes_are_deterministic_per_seed(tmp_path: Path) -> None:
    first = evaluate(CONFIG, ["random1"], [DEFAULT_MOTOR], [3], tmp_path / "a", progress=False,
                     modes=["free"])
    second = evaluate(CONFIG, ["random1"], [DEFAULT_MOTOR], [3], tmp_path / "b", progress=False,
                      modes=["free"])
    assert first[0]["coverage_pct"] == second[0]["coverage_pct"]


def test_summarize_averages_per_planner_and_mode() -> None:
    base = {"acquisitions": 4, "requested": 5, "joint_time_s": None, "joint_path_rad": None,
            "cartesian_m": None, "paper_m": 1.0, "reachable_pct": None, "plan_s": 0.5,
            "episode_s": 1.0}
    rows = [{**base, "planner": "bscp", "mode": "free", "coverage_pct": 90.0, "success": True},
            {**base, "planner": "bscp", "mode": "free", "coverage_pct": 80.0, "success": False}]
    (row,) = summarize(rows)
    assert row["coverage_pct"] == 85.0 and row["coverage_std_pct"] == 5.0
    assert row["success_pct"] == 50.0 and row["joint_time_s"] is None and row["episodes"] == 2


@pytest.mark.parametrize(
    ("planners", "modes", "message"),
    [(["dijkstra"], ["robot"], "unknown planner 'dijkstra'"),
     (["hrec"], ["flying"], "unknown mode 'flying'"),
     ([], ["robot"], "at least one planner")],
)
def test_bad_arguments_are_clear_errors(planners: list[str], modes: list[str], message: str,
                                        tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=message):
        evaluate(CONFIG, planners, [DEFAULT_MOTOR], [0], tmp_path, progress=False, modes=modes)


def test_planner_benchmark_reports_the_targets(capsys: pytest.CaptureFixture) -> None:
    results = run_planners_benchmark(CONFIG, motors=[DEFAULT_MOTOR], seeds=[0], progress=False)
    for key in ("bscp_plan_s_median", "bscp5_free_coverage_pct", "bscp_robot_coverage_pct",
                "hrec_free_coverage_pct", "hrec_robot_coverage_pct"):
        assert key in results
    assert results["bscp_robot_coverage_pct"] >= 90.0
    assert results["bscp5_free_coverage_pct"] >= 95.0
    assert 0.0 < results["bscp_plan_s_median"] <= results["bscp_plan_s_max"]
    print_table(results)
    assert "B_SCP,5" in capsys.readouterr().out
