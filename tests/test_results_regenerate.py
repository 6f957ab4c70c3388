"""The committed evaluation tables regenerate: a small subset of `results/motors` is run again
from its own episode list, with the test run's cache (built by this code, as `vprobot report
check`'s empty one is), and must give the committed rows cell by cell (`vprobot report check`;
the full check is recorded in results/regenerated/README.md)."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from vprobot.cli import main
from vprobot.report import check

ROOT = Path(__file__).resolve().parents[1]
MOTORS = ROOT / "results" / "motors"
EPISODES = [0]
"""motor_000.stl, seed 0."""
PLANNERS = ["random2", "nbv", "agent"]
"""Cheap planners: `random2` (a borderline ground-truth point), `nbv` (it reads the occupancy grid)
and the bundled agent, which the README's rows name. Not `uniform4` (which had a borderline point
too): with the robot it first screens the default cell's view band, about 70 s of motion
planning here (the band's cache: `tests/test_planners.py`)."""


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory, session_cache: Path) -> Path:
    out = tmp_path_factory.mktemp("check") / "regenerated"
    check.regenerate(MOTORS, out, EPISODES, PLANNERS, ["free", "robot"], cache=session_cache)
    return out


def test_committed_motor_rows_equal_their_regeneration(regenerated: Path) -> None:
    rows = list(csv.DictReader((regenerated / "tables" / "evaluation_episodes.csv").open()))
    assert sorted(row["planner"] for row in rows) == sorted(2 * PLANNERS)
    # The robot rows too: the folder's settings record gives the config it was made with,
    # planned moves included (`check.recorded_config`).
    assert check.differences(MOTORS, regenerated, EPISODES) == []
    assert check.recorded_config(MOTORS)["kinematics"]["path_planner"] == "rrt_connect"


def test_check_names_a_committed_cell_that_differs(regenerated: Path, tmp_path: Path) -> None:
    committed = tmp_path / "motors"
    shutil.copytree(MOTORS, committed)
    path = committed / "evaluation_episodes.csv"
    rows = list(csv.DictReader(path.open()))
    changed = next(row for row in rows if row["episode"] == "0" and row["planner"] == "agent"
                   and row["carrier"] == "free")
    changed["coverage_pct"] = str(float(changed["coverage_pct"]) + 1.0)
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    moved = check.differences(committed, regenerated, EPISODES)
    assert len(moved) == 1 and "('0', 'agent', 'free') coverage_pct" in moved[0]


@pytest.mark.parametrize(("arguments", "message"), [
    (["{tmp}"], "{tmp} is not an evaluation folder: it needs episodes.json, evaluation.csv, "
     "evaluation_episodes.csv"),
    ([str(MOTORS), "--episodes", "0", "15"],
     f"--episodes 0 15: {MOTORS} has episodes 0 to 14"),
])
def test_check_refuses_a_bad_folder_or_episode_in_one_line(
        arguments: list[str], message: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", "check", *(value.format(tmp=tmp_path) for value in arguments)]) == 2
    assert capsys.readouterr().err == (
        f"vprobot report check: error: {message.format(tmp=tmp_path)}\n")
