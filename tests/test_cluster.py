"""Ray: a tiny sweep and its resume, distributed evaluation against serial, on a local Ray."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vprobot.cli import main

pytest.importorskip("ray")

from vprobot.agents.sweep import read_study, sweep
from vprobot.config import Config
from vprobot.episode import episode_list
from vprobot.evaluation import evaluate
from vprobot.paths import DEFAULT_MOTOR

TINY = ["env.resolution=[64,45]", "env.state_points=64", "agent.learning_starts=30",
        "agent.batch_size=32", "agent.buffer_size=400", "agent.eval_freq=1000",
        "agent.checkpoint_freq=60", "agent.eval_episodes=1", "agent.net_arch=[16,16]",
        "agent.n_steps=64", "agent.n_epochs=1"]
TIMING = ("plan_s", "plan_ms_per_view", "episode_s")


@pytest.fixture(scope="module", autouse=True)
def local_ray() -> None:
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def _study(tmp_path: Path, steps: int) -> Path:
    path = tmp_path / "study.yaml"
    path.write_text(json.dumps({"profile": "cpu.yaml", "steps": steps, "seeds": [0],
                                "set": TINY, "grid": {"agent.algorithm": ["sac", "ppo"]},
                                "note": "tiny"}))
    return path


def test_tiny_sweep_produces_its_table_and_curves(tmp_path: Path) -> None:
    table = sweep(_study(tmp_path, 100), tmp_path / "out", progress=False)
    assert [row["configuration"] for row in table] == ["agent.algorithm=sac",
                                                       "agent.algorithm=ppo"]
    assert all(row["seeds"] == 1 and 0 < row["coverage"] <= 1 for row in table)
    text = (tmp_path / "out" / "study.md").read_text()
    assert "1 seed(s) (0), 100 steps each. The paper: 75 000 steps, 3 runs" in text
    assert len(list((tmp_path / "out").glob("*/curves.png"))) == 2
    with pytest.raises(ValueError, match="--resume"):
        sweep(_study(tmp_path, 100), tmp_path / "out", progress=False)


def test_killed_sweep_resumes_without_rerunning_finished_trials(tmp_path: Path) -> None:
    study, out = _study(tmp_path, 200), tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", "sweep", str(study),
                                "--out", str(out), "--workers", "1"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    trials = read_study(study).trials(out)
    deadline = time.monotonic() + 300
    while process.poll() is None and time.monotonic() < deadline:
        if trials[0].finished:
            break
        time.sleep(0.2)
    # Kill the driver and its Ray (one process group): the second trial dies half-way.
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert trials[0].finished and not trials[1].finished
    first = (trials[0].run_dir / "result.json").stat().st_mtime_ns
    assert main(["sweep", str(study), "--out", str(out), "--resume"]) == 0
    assert (trials[0].run_dir / "result.json").stat().st_mtime_ns == first  # not rerun
    assert trials[1].finished


def _rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "evaluation_episodes.csv").open() as stream:
        rows = [{key: value for key, value in row.items() if key not in TIMING}
                for row in csv.DictReader(stream)]
    return sorted(rows, key=lambda row: (int(row["episode"]), row["carrier"], row["planner"]))


def test_distributed_evaluation_gives_the_serial_rows(tmp_path: Path) -> None:
    config = Config()
    specs = episode_list(config, [DEFAULT_MOTOR], [0, 1, 2])
    serial = evaluate(config, ["hrec", "random2"], specs, tmp_path / "serial", progress=False)
    spread = evaluate(config, ["hrec", "random2"], specs, tmp_path / "ray", progress=False,
                      workers=2)
    assert _rows(tmp_path / "serial") == _rows(tmp_path / "ray")
    assert [row["coverage_pct"] for row in serial] == [row["coverage_pct"] for row in spread]


def test_killed_distributed_evaluation_resumes(tmp_path: Path) -> None:
    """kill -9 of a `vprobot evaluate --workers 2` (driver and its Ray), then the same command:
    the rows of an uninterrupted serial run, none lost or duplicated."""
    argv = ["evaluate", "--planners", "hrec", "random2", "--motors", str(DEFAULT_MOTOR),
            "--seeds", "0", "1", "2"]
    assert main([*argv, "--out", str(tmp_path / "serial")]) == 0
    killed = tmp_path / "killed"
    process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", *argv, "--workers", "2",
                                "--out", str(killed)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    rows = killed / "evaluation_episodes.csv"
    deadline = time.monotonic() + 300
    while process.poll() is None and time.monotonic() < deadline:
        if rows.is_file() and rows.read_text().count("\n") >= 4:
            break
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert 4 <= rows.read_text().count("\n") < 13, "killed before the end"
    assert main([*argv, "--workers", "2", "--out", str(killed)]) == 0
    assert _rows(tmp_path / "serial") == _rows(killed)
