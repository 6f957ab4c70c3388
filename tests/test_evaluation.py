"""Planner evaluation tables and the planner benchmark."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from vprobot.benchmarks.planners import print_table, run_planners_benchmark
from vprobot.config import Config
from vprobot.episode import (
    BUNDLED_TEST_EPISODES,
    episode_list,
    read_episode_list,
)
from vprobot.evaluation import (
    COLUMNS,
    EPISODE_COLUMNS,
    evaluate,
    evaluation_episodes,
    held_out_motors,
    summarize,
)
from vprobot.paths import DEFAULT_MOTOR

CONFIG = Config()


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open() as stream:
        return list(csv.DictReader(stream))


def test_evaluate_writes_markdown_and_csv(tmp_path: Path) -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [0, 1])
    table = evaluate(CONFIG, ["hrec", "random2"], specs, tmp_path, progress=False)
    assert [(row["planner"], row["carrier"]) for row in table] == [
        ("hrec", "robot"), ("random2", "robot"), ("hrec", "free"), ("random2", "free")]
    summary = read_csv(tmp_path / "evaluation.csv")
    assert list(summary[0]) == list(COLUMNS) and len(summary) == 4
    episodes = read_csv(tmp_path / "evaluation_episodes.csv")
    assert list(episodes[0]) == list(EPISODE_COLUMNS) and len(episodes) == 8
    for row in episodes:
        assert 0.0 <= float(row["coverage_pct"]) <= 100.0
        assert int(row["acquisitions"]) <= int(row["requested"])
        if row["carrier"] == "free":
            assert row["joint_time_s"] == "" and row["reachable_pct"] == ""
        else:
            assert float(row["joint_time_s"]) > 0.0
            assert 0.0 <= float(row["reachable_pct"]) <= 100.0
    hrec_free = next(row for row in table
                     if row["planner"] == "hrec" and row["carrier"] == "free")
    assert hrec_free["acquisitions"] == 6 and hrec_free["joint_time_s"] is None
    markdown = (tmp_path / "evaluation.md").read_text()
    assert "| hrec | free | 2 |" in markdown and "B_SCP,5 | 98.17" in markdown
    # The episode list is part of the output, and running it again gives the same rows.
    assert read_episode_list(tmp_path / "episodes.json") == specs
    again = evaluate(CONFIG, ["hrec", "random2"], evaluation_episodes(
        CONFIG, episodes=tmp_path / "episodes.json"), tmp_path / "again", progress=False)
    assert [row["coverage_pct"] for row in again] == [row["coverage_pct"] for row in table]


def test_every_planner_sees_the_same_object_pose(tmp_path: Path) -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [3])
    evaluate(CONFIG, ["random1", "hrec"], specs, tmp_path, progress=False, carriers=["free"])
    rows = read_csv(tmp_path / "evaluation_episodes.csv")
    assert {(row["motor"], row["seed"]) for row in rows} == {("motor_000.stl", "3")}


def test_bundled_episode_list_is_what_the_sampler_draws() -> None:
    """The committed list is versioned: a change to the sampler must come with a new version."""
    bundled = read_episode_list(BUNDLED_TEST_EPISODES)
    assert bundled == episode_list(CONFIG, held_out_motors(), [0, 1, 2])
    assert evaluation_episodes(CONFIG) == bundled
    assert len({spec.object_quaternion for spec in bundled}) == len(bundled) == 15


def test_summarize_averages_per_planner_and_carrier() -> None:
    base = {"acquisitions": 4, "requested": 5, "joint_time_s": None, "joint_path_rad": None,
            "cartesian_m": None, "paper_m": 1.0, "reachable_pct": None, "plan_s": 0.5,
            "plan_ms_per_view": 100.0, "episode_s": 1.0}
    rows = [{**base, "planner": "bscp", "carrier": "free", "coverage_pct": 90.0,
             "success": True},
            {**base, "planner": "bscp", "carrier": "free", "coverage_pct": 80.0,
             "success": False}]
    (row,) = summarize(rows)
    assert row["coverage_pct"] == 85.0 and row["coverage_std_pct"] == 5.0
    assert row["success_pct"] == 50.0 and row["joint_time_s"] is None and row["episodes"] == 2


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


EVAL_ARGS = ["--planners", "random2", "hrec", "--motors", str(DEFAULT_MOTOR), "--seeds", "0",
             "1", "2"]


def _rows_by_key(path: Path) -> dict[tuple[str, str, str], str]:
    rows = read_csv(path)
    keys = [(row["episode"], row["carrier"], row["planner"]) for row in rows]
    assert len(keys) == len(set(keys)), "duplicated rows"
    return {key: row["coverage_pct"] for key, row in zip(keys, rows, strict=True)}


def test_killed_evaluation_resumes_without_lost_or_duplicated_rows(tmp_path: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    from vprobot.cli import main

    reference, killed = tmp_path / "reference", tmp_path / "killed"
    assert main(["evaluate", *EVAL_ARGS, "--out", str(reference)]) == 0
    expected = _rows_by_key(reference / "evaluation_episodes.csv")
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
