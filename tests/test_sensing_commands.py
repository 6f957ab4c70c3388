"""`--sensing` and the presets' default models reach every command that acquires: plan, render,
evaluate, train and stop (issue 31)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import TINY_TRAINING

from vprobot import render
from vprobot.cli import main
from vprobot.config import load_config
from vprobot.episode import EpisodeRecord, PartScene, episode_list, write_episode_list
from vprobot.evaluation import SETTINGS_NAME
from vprobot.files.paths import CONFIGS_DIR, DEFAULT_MOTOR
from vprobot.render import episode_from_plan

RESOLUTION = (107, 75)


def _zivid_config(folder: Path) -> Path:
    config = folder / "zivid.yaml"
    config.write_text(f"sensor:\n  preset: zivid2plus_mr60\n  resolution: [{RESOLUTION[0]}, "
                      f"{RESOLUTION[1]}]\n")
    return config


@pytest.fixture
def zivid(tmp_path: Path) -> Path:
    """A config with the Zivid preset (structured light by default) at a low resolution."""
    return _zivid_config(tmp_path)


def _plan(config: Path, out: Path, *sensing: str) -> dict:
    assert main(["plan", "--no-summary", "--config", str(config), "--planner", "random2", "--seed",
                 "3",
                 "--out", str(out), *sensing]) == 0
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def zivid_plan(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """`_plan` with the `zivid` config (its preset's structured light), made once for the
    module's tests that read it: the plan file and its document. Read only."""
    folder = tmp_path_factory.mktemp("zivid")
    plan = folder / "structured.json"
    return plan, _plan(_zivid_config(folder), plan)


def test_plan_takes_the_presets_model_and_sensing_replaces_it(
        zivid: Path, zivid_plan: tuple[Path, dict], tmp_path: Path) -> None:
    structured = zivid_plan[1]
    ideal = _plan(zivid, tmp_path / "ideal.json", "--sensing", "ideal")
    assert structured["sensor"]["sensing"] == "structured_light"
    assert structured["sensor"]["structured_light"]["baseline_m"] == 0.15
    assert ideal["sensor"]["sensing"] == "ideal"
    # The same requests (random2, one seed), measured by two models: the structured-light
    # frames lose the shadowed and grazing points, so they cover less.
    assert ([view["joints"] for view in structured["views"]]
            == [view["joints"] for view in ideal["views"]])
    assert structured["coverage"] < ideal["coverage"]


def test_render_replays_a_plan_with_the_model_it_was_made_with(
        zivid_plan: tuple[Path, dict], tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    plan, document = zivid_plan
    replayed: list[EpisodeRecord] = []

    def recording_replay(*args: Any, **kwargs: Any) -> tuple[PartScene, EpisodeRecord]:
        scene, record = episode_from_plan(*args, **kwargs)
        replayed.append(record)
        return scene, record

    monkeypatch.setattr(render, "episode_from_plan", recording_replay)
    summary = tmp_path / "summary.png"
    assert main(["render", "--plan", str(plan), "--out", str(tmp_path / "replay.mp4"),
                 "--summary", str(summary), "--width", "64", "--height", "48"]) == 0
    assert summary.stat().st_size > 0
    # Measured as the plan was (structured light): the plan's coverage, view by view.
    (record,) = replayed
    assert [view.coverage for view in record.views] == [
        view["coverage"] for view in document["views"]]
    capsys.readouterr()
    # The plan fixes its sensing model as it fixes the sensor.
    assert main(["render", "--plan", str(plan), "--sensing", "ideal",
                 "--out", str(tmp_path / "other.gif")]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "--sensing" in line and "cannot be combined" in line


def test_evaluate_records_the_sensing_model_and_refuses_another_on_resume(
        zivid: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    episodes = tmp_path / "one.json"
    write_episode_list(episodes, episode_list(load_config(zivid), [DEFAULT_MOTOR], [0]))
    out = tmp_path / "evaluation"
    argv = ["evaluate", "--config", str(zivid), "--episodes", str(episodes), "--planners",
            "random2", "--out", str(out)]
    assert main(argv) == 0
    settings = json.loads((out / SETTINGS_NAME).read_text())
    assert settings["config"]["sensor"]["sensing"] == "structured_light"
    capsys.readouterr()
    assert main([*argv, "--sensing", "ideal"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "sensor.sensing" in line


def test_train_records_the_sensing_model_in_its_run(tmp_path: Path) -> None:
    run = tmp_path / "run"
    assert main(["train", str(CONFIGS_DIR / "agents" / "cpu.yaml"), "--steps", "5",
                 "--set", *TINY_TRAINING, "--sensor", "zivid2plus_mr60",
                 "--sensing", "structured_light", "--out", str(run)]) == 0
    saved = yaml.safe_load((run / "config.yaml").read_text())
    assert saved["sensor"]["sensing"] == "structured_light"
    assert saved["sensor"]["structured_light"]["baseline_m"] == 0.15


def test_stop_study_runs_under_the_presets_model_and_the_estimate_refuses_it(
        zivid: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    episodes = tmp_path / "one.json"
    write_episode_list(episodes, episode_list(load_config(zivid), [DEFAULT_MOTOR], [0]))
    out = tmp_path / "study"
    assert main(["stop", "study", "--config", str(zivid), "--out", str(out), "--episodes",
                 str(episodes), "--planners", "random2", "--stop", "views:1"]) == 0
    settings = json.loads((out / "one" / "views-1" / SETTINGS_NAME).read_text())
    assert settings["config"]["sensor"]["sensing"] == "structured_light"
    capsys.readouterr()
    # The bundled estimates were fitted on the ideal paper sensor and on this preset under
    # structured light: the preset under ideal sensing gets the paper's, which refuses it.
    assert main(["stop", "error", "--config", str(zivid), "--sensing", "ideal", "--out",
                 str(tmp_path / "error"), "--episodes", str(episodes), "--planners",
                 "random2"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "paper" in line and "zivid2plus_mr60" in line
