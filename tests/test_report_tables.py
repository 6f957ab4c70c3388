"""`vprobot report tables`: the README's tables from evaluation folders, agents over seeds
compared with the optimum of the same episodes, and one line (exit 2) for a bad input."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest

from vprobot.cli import main
from vprobot.episode import EpisodeSpec, write_episode_list
from vprobot.evaluation import CURVE_COLUMNS, EPISODE_COLUMNS, EPISODES_NAME

FOLDERS = {"test-v1": "motors", "families-test-v1": "families-test", "shapes-v1": "shapes"}


def _row(episode: int, planner: str, acquisitions: int, success: bool,
         cycle: float) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(EPISODE_COLUMNS, "")
    row.update({"episode": episode, "planner": planner, "carrier": "robot", "part": "m.stl",
                "seed": 0, "coverage_pct": 90.0, "acquisitions": acquisitions,
                "requested": acquisitions + 1, "failed_requests": 1, "success": success,
                "views_to_goal": acquisitions if success else "",
                "cycle_time_s": cycle, "paper_m": 1.0, "plan_s": 0.1,
                "plan_ms_per_view": 1.0, "episode_s": 1.0,
                **dict.fromkeys(CURVE_COLUMNS, 90.0)})
    return row


def _folder(folder: Path, rows: list[dict[str, Any]], episodes: list[int]) -> None:
    """An evaluation folder of `rows` whose episode list holds one spec per number in
    `episodes` (the number its seed)."""
    folder.mkdir(parents=True)
    with (folder / EPISODES_NAME).open("w", newline="") as stream:
        writer = csv.DictWriter(stream, EPISODE_COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    write_episode_list(folder / "episodes.json", [
        EpisodeSpec(part="m.stl", object_quaternion=(1.0, 0.0, 0.0, 0.0),
                    initial_views=((1.42, 0.71),), seed=seed) for seed in episodes])


def _tables(*args: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """`vprobot report tables ARGS` in the current folder: the exit code and stderr."""
    code = main(["report", "tables", *args])
    return code, capsys.readouterr().err


def test_agents_are_averaged_over_seeds_against_the_optimum_of_the_same_episodes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    # Two episodes per list: the optimum takes 3 and 4 views (cycles 10 and 12 s).
    for name, sub in FOLDERS.items():
        _folder(tmp_path / "cell" / sub,
                [_row(0, "bscp", 4, True, 11.0), _row(0, "optimum", 3, True, 10.0),
                 _row(1, "bscp", 5, True, 13.0), _row(1, "optimum", 4, True, 12.0)], [0, 1])
        # Seed 0: 4 and 6 views (+1, +2 above); seed 1: 3 and 5 (+0, +1), one short of the goal.
        _folder(tmp_path / "agent" / "seed-0" / "test" / name,
                [_row(0, "policy", 4, True, 20.0), _row(1, "policy", 6, True, 22.0)], [0, 1])
        _folder(tmp_path / "agent" / "seed-1" / "test" / name,
                [_row(0, "policy", 3, True, 20.0), _row(1, "policy", 5, False, 22.0)], [0, 1])
    monkeypatch.chdir(tmp_path)
    code, err = _tables("--folders", "cell", "--agents", "learned=agent", "--out", "t.md",
                        capsys=capsys)
    assert code == 0, err
    text = (tmp_path / "t.md").read_text()
    # bscp: 4.5 views, all to the goal, +1 above, cycle 12 s; the optimum +0.
    assert "| bscp | 100 | 4.50 | 4.50 | 1.00 | 12.00 | +1.00 |" in text
    assert "| optimum | 100 | 3.50 | 3.50 | 1.00 | 11.00 | +0.00 |" in text
    # The agent: goal 100 and 50 %, views 5 and 4, to the goal 5 and 3 (its one episode
    # there), above the optimum 1.5 and 0.5 per seed.
    assert ("| learned (2 seeds) | 75 (50-100) | 4.50 (4.00-5.00) | 4.00 (3.00-5.00) "
            "| 1.00 (1.00-1.00) | 21.00 (21.00-21.00) | +1.00 (0.50-1.50) |") in text
    # Chosen rows in the order given, the agent after the one named.
    code, err = _tables("--folders", "cell", "--agents", "learned=agent", "--planners",
                        "optimum", "bscp", "--agents-after", "optimum", "--out", "c.md",
                        capsys=capsys)
    assert code == 0, err
    names = [line.split(" | ")[0][2:] for line in (tmp_path / "c.md").read_text().splitlines()[2:]]
    assert names == ["optimum", "learned (2 seeds)", "bscp"]
    assert _tables("--folders", "cell", "--planners", "nbv", "--out", "u.md", capsys=capsys) == (
        2, "vprobot report tables: error: no rows of planner(s) nbv in cell\n")


def test_an_agent_scored_on_other_episodes_is_refused_in_one_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    for name, sub in FOLDERS.items():
        _folder(tmp_path / "cell" / sub, [_row(0, "optimum", 3, True, 10.0)], [0])
        _folder(tmp_path / "agent" / "seed-0" / "test" / name,
                [_row(0, "policy", 4, True, 20.0)], [7])
    monkeypatch.chdir(tmp_path)
    code, err = _tables("--folders", "cell", "--agents", "learned=agent", "--out", "t.md",
                        capsys=capsys)
    assert code == 2 and "scored on other episodes" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "t.md").exists()
    code, err = _tables("--folders", "nowhere", "--out", "t.md", capsys=capsys)
    assert code == 2 and "does not exist" in err
    with pytest.raises(SystemExit) as exit_:
        _tables("--folders", "cell", "--agents", "agent", "--out", "t.md", capsys=capsys)
    assert exit_.value.code == 2
    assert capsys.readouterr().err == ("vprobot report tables: error: argument --agents: must be "
                                       "LABEL=DIR, got 'agent'\n")
