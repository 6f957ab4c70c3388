"""Ray: a tiny sweep stopped and resumed, distributed evaluation against serial, on a local Ray;
SIGTERM to either command and kill -9 to the distributed evaluation (exit 130, partial tables,
resumable) and bad study files."""

from __future__ import annotations

import collections
import csv
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from helpers import SERIAL_EVALUATION

from vprobot.cli import main

pytest.importorskip("ray")

from vprobot.compute.cluster import parallel_map, start
from vprobot.files.atomic import exclusive_lock
from vprobot.files.paths import MOTORS_DIR
from vprobot.training.sweep import read_study, sweep

# Training draws from one motor (its ground truth is built once per session, not that of all 20
# training motors).
ONE_MOTOR = ["env.parts=mesh", f"env.mesh={MOTORS_DIR / 'train' / 'motor_000.stl'}"]
TINY = [*ONE_MOTOR, "env.resolution=[64,45]", "env.state_points=64", "agent.learning_starts=30",
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
    # The free-flying sensor: what is tested is the sweep, and its env steps are the fastest.
    free = [*TINY, "env.carrier=free", "env.travel_cost=cartesian"]
    path.write_text(json.dumps({"profile": "cpu.yaml", "steps": steps, "seeds": [0],
                                "set": free, "grid": {"agent.algorithm": ["sac", "ppo"]},
                                "note": "tiny"}))
    return path


@pytest.mark.parametrize(("written", "shown"), [
    ("set:\n  agent.eval_freq: 5000\n", "got {agent.eval_freq: 5000}"),
    ("set:\n  - agent.eval_freq: 5000\n", "got {agent.eval_freq: 5000}"),
    ("set: agent.eval_freq=5000\n", "got agent.eval_freq=5000"),
], ids=["mapping", "list-of-mappings", "string"])
def test_study_set_that_is_not_a_list_of_overrides_is_a_one_line_error(
        written: str, shown: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    study = tmp_path / "study.yaml"
    study.write_text(f"profile: cpu.yaml\n{written}grid:\n  agent.algorithm: [sac]\n")
    assert main(["sweep", str(study), "--out", str(tmp_path / "out")]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line == (f"vprobot sweep: error: {study}: set must be a list of section.key=value, "
                    f"e.g. set: [agent.eval_freq=5000]; {shown}")


def _terminate(command: list[str], started: Callable[[], bool], log: Path) -> tuple[int, str]:
    """Run `vprobot COMMAND` in a subprocess, send it SIGTERM (as `kill PID` does) once
    `started()` holds, and return its exit code and stderr."""
    with log.open("w") as stderr:
        process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", *command],
                                   stdout=subprocess.DEVNULL, stderr=stderr,
                                   start_new_session=True)
        try:
            deadline = time.monotonic() + 300
            while process.poll() is None and time.monotonic() < deadline and not started():
                time.sleep(0.05)
            assert process.poll() is None and started(), "it ended or stalled before SIGTERM"
            process.send_signal(signal.SIGTERM)
            process.wait(timeout=120)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
    return process.returncode, log.read_text()


def _assert_interrupted_quietly(code: int, stderr: str, command: str) -> None:
    assert code == 130
    assert f"vprobot {command}: interrupted" in stderr
    # Ray's own SIGTERM handler would print a C++ stack dump and exit with 15.
    assert "SIGTERM received" not in stderr and "***" not in stderr


def test_sweep_stopped_by_sigterm_resumes_to_its_whole_table(
        tmp_path: Path) -> None:
    """SIGTERM (exit 130, partial table), then a resume: finished trials are never rerun and
    the table and curves are whole. (kill -9 of a Ray driver and its rerun: the distributed
    evaluation's test below; of a training run and its resume: tests/test_agents.py.)"""
    # 128 steps: two rollouts of PPO's n_steps (no step unused), and long enough (seconds: the
    # trial also builds its env, evaluates and draws its curves) that the second trial cannot
    # end while the SIGTERM sent at the first one's end is handled (about a second).
    study, out = _study(tmp_path, 128), tmp_path / "out"
    trials = read_study(study).trials(out)
    code, stderr = _terminate(["sweep", str(study), "--out", str(out), "--workers", "1"],
                              lambda: trials[0].finished, tmp_path / "stderr.txt")
    _assert_interrupted_quietly(code, stderr, "sweep")
    assert trials[0].finished and not trials[1].finished
    assert "saved 1 of 2 trials" in stderr
    assert (out / "study.md").read_text().startswith("**Partial: 1 of 2 trials;")
    first = (trials[0].run_dir / "result.json").stat().st_mtime_ns
    with pytest.raises(ValueError, match="--resume"):
        sweep(study, out, progress=False)

    table = sweep(study, out, resume=True, progress=False)
    assert (trials[0].run_dir / "result.json").stat().st_mtime_ns == first  # not rerun
    assert trials[1].finished
    assert [row["configuration"] for row in table] == ["agent.algorithm=sac",
                                                       "agent.algorithm=ppo"]
    assert all(row["seeds"] == 1 and 0 < row["coverage_pct"] <= 100 for row in table)
    text = (out / "study.md").read_text()
    assert "Partial" not in text
    assert "1 seed(s) (0), 128 steps each. The paper: 75 000 steps, 3 runs" in text
    assert len(list(out.glob("*/curves.png"))) == 2


def test_a_user_error_in_a_ray_task_reaches_the_user_as_itself() -> None:
    """Not as Ray's RayTaskError, whose first line (all the CLI shows) is the worker's name."""
    with pytest.raises(FileNotFoundError) as caught:
        list(parallel_map(read_study, [("missing.yaml",)], 1))
    assert str(caught.value) == "study file not found: missing.yaml"


def _rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "evaluation_episodes.csv").open() as stream:
        rows = [{key: value for key, value in row.items() if key not in TIMING}
                for row in csv.DictReader(stream)]
    return sorted(rows, key=lambda row: (int(row["episode"]), row["carrier"], row["planner"]))


EVALUATE = list(SERIAL_EVALUATION)


@pytest.fixture(scope="module")
def serial_rows(serial_evaluation: Path) -> list[dict[str, str]]:
    """The rows of `EVALUATE` run in the test process, without Ray."""
    return _rows(serial_evaluation)


def test_distributed_evaluation_stopped_by_sigterm_then_killed_resumes_to_the_serial_rows(
        tmp_path: Path, serial_rows: list[dict[str, str]]) -> None:
    """SIGTERM to `evaluate --workers 2` (exit 130, partial tables), then kill -9 of the rerun
    (driver and its Ray), then the same command: the serial rows, none lost or duplicated.
    Every row is an episode run on a Ray worker, so this also proves that a distributed
    evaluation gives the serial rows."""
    out = tmp_path / "out"
    argv = [*EVALUATE, "--workers", "2", "--out", str(out)]
    rows = out / "evaluation_episodes.csv"

    def lines() -> int:
        return rows.read_text().count("\n") if rows.is_file() else 0

    code, stderr = _terminate(argv, lambda: lines() >= 2, tmp_path / "stderr.txt")
    _assert_interrupted_quietly(code, stderr, "evaluate")
    done = len(_rows(out))
    assert 1 <= done < 12
    assert f"Partial: {done} of 12 episodes" in (out / "evaluation.md").read_text()
    with (out / "evaluation.csv").open() as stream:
        assert sum(int(row["episodes"]) for row in csv.DictReader(stream)) == done

    # The rerun must have work left after its first new rows, or it may end while this process
    # waits to kill it: a Ray task runs one episode's 4 rows and they arrive together, two at a
    # time. Keeping at most 3 rows of each episode (any subset of whole rows is a state to
    # resume from) leaves all three episodes to run, the third only after one of the first two.
    header, *finished = rows.read_text().splitlines(keepends=True)
    per_episode: collections.Counter[str] = collections.Counter()
    kept_rows = []
    for line in finished:
        episode = line.split(",", 1)[0]
        per_episode[episode] += 1
        if per_episode[episode] <= 3:
            kept_rows.append(line)
    rows.write_text("".join([header, *kept_rows]))
    kept = len(kept_rows)
    process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", *argv],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    deadline = time.monotonic() + 300
    # Killed at its first new row.
    while process.poll() is None and time.monotonic() < deadline and lines() < kept + 2:
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert kept + 2 <= lines() < 13, "killed before the end"
    assert main(argv) == 0
    assert _rows(out) == serial_rows
    assert "Partial" not in (out / "evaluation.md").read_text()


def _hold_lock(path: str) -> None:
    with exclusive_lock(Path(path), path):
        time.sleep(60)


def test_an_interrupted_parallel_map_ends_its_running_workers_before_going_on(
        tmp_path: Path) -> None:
    """A rerun right after Ctrl-C must not find the run folder locked by a dying worker."""
    from ray import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests
    lock = tmp_path / "run.lock"

    interrupted = []

    def interrupt_once_locked(signum: int, frame: object) -> None:
        if not interrupted and lock.is_file() and lock.read_text().strip():
            interrupted.append(signum)
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt_once_locked)
    signal.setitimer(signal.ITIMER_REAL, 0.1, 0.1)
    try:
        with pytest.raises(KeyboardInterrupt):
            list(parallel_map(_hold_lock, [(str(lock),)], 1))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    with exclusive_lock(lock, str(lock)):  # raises InUseError while the worker lives
        pass


def test_sigterm_while_ray_starts_reaches_the_callers_handler(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Ray's handler, in place during ray.init, would exit with 15 and skip the partial tables."""
    import ray

    def init_interrupted(**options: object) -> None:
        raise SystemExit(signal.SIGTERM)  # what Ray's handler does on SIGTERM

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", init_interrupted)
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        with pytest.raises(KeyboardInterrupt):
            start(None, 1)
        assert signal.getsignal(signal.SIGTERM) is interrupt
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_task_runs_on_one_thread_and_imports_no_torch_for_it() -> None:
    code = ("import os, sys; from vprobot.compute.cluster import _one_thread; "
            "print(_one_thread(lambda: (os.environ['OMP_NUM_THREADS'], 'torch' in sys.modules)))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env={**os.environ, "OMP_NUM_THREADS": "4"})
    assert done.stdout.strip() == "('1', False)"
