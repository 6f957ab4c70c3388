"""`vprobot benchmark motion` on one robot, planner and motor: the figures it writes hold together
and agree with the plan it made (no timing is asserted)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from vprobot.benchmarks import motion
from vprobot.cli import main
from vprobot.config import Config
from vprobot.evaluation import held_out_motors
from vprobot.export.formats import FORMATS

SAMPLES = 4


def test_benchmark_motion_writes_the_path_export_and_replay_figures(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    full = motion.run_motion_benchmark
    motor = held_out_motors()[0]

    def quick(config: Config, samples: int) -> dict[str, Any]:
        return full(config, robots=["ur10"], planners=["agent"], motors=[motor], samples=samples,
                    progress=False)

    monkeypatch.setattr(motion, "run_motion_benchmark", quick)
    out = tmp_path / "motion.json"
    assert main(["benchmark", "motion", "--samples", str(SAMPLES), "--json", str(out)]) == 0
    results = json.loads(out.read_text())
    random_moves = results["path_planning"]["random_views"]
    assert random_moves["moves"] == SAMPLES
    for figures in results["path_planning"].values():
        assert sum(figures[method]["count"] for method in motion.METHODS) == figures["moves"]
    assert results["export_10_views"]["views"] == motion.EXPORT_VIEWS
    # Every registered format, the bundled ones among them.
    assert list(results["export_10_views"]["format_s"]) == list(FORMATS)
    assert "urscript" in FORMATS
    (row,) = results["replay"]
    assert (row["robot"], row["planner"], row["motor"]) == ("ur10", "agent", motor.stem)
    assert row["planned"] and row["holds"] and row["failures"] == []
    # The plan's moves, planned again: the approach and the moves to its views, and the return.
    assert results["path_planning"]["plan_moves"]["moves"] == row["views"] + 1
    assert results["replay_summary"] == {"plans": 1, "planned": 1, "held": 1, "check_failed": 0,
                                         "not_planned": 0}
    printed = capsys.readouterr().out
    assert "replay check: 1 of 1 plans hold" in printed and "ur10   agent" in printed


def test_benchmark_motion_records_a_planner_that_cannot_plan_with_its_message(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    message = "none of the 1 initial views is reachable (did_not_converge)"

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise ValueError(message)

    monkeypatch.setattr(motion, "plan_part", refuse)
    row, scene, record = motion.replay_one(Config(), held_out_motors()[0], "nbv", tmp_path)
    assert row["failures"] == [message] and not row["planned"] and not row["holds"]
    assert scene is None and record is None
