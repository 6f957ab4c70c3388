"""Child processes end with their parent (`vprobot.compute.processes`): SIGTERM to `teacher
--workers 2` ends its workers at once, and neither the teacher's workers nor `report check`'s
`evaluate` outlive a parent killed with SIGKILL (nor does the check's temporary folder)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from vprobot.files.paths import CONFIGS_DIR

ROOT = Path(__file__).resolve().parents[1]
TEACHER = ["teacher", str(CONFIGS_DIR / "agents" / "cpu-candidates.yaml"), "--workers", "2",
           "--set", "env.resolution=[64,45]"]
"""12 shards of 25 episodes: minutes of work, far more than any of these tests waits."""
ENDED_WITHIN_S = 15.0
"""How long a process may take to end after its parent's signal (it polls every 0.2 s; the
rest is slack for two busy cores)."""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _children(pid: int, marker: str) -> list[int]:
    """The live children of `pid` whose command line holds `marker`."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            command = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue  # ended meanwhile
        if parent == pid and marker in command and _alive(int(stat.parent.name)):
            found.append(int(stat.parent.name))
    return found


def _wait_until(condition: Callable[[], bool], timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


@pytest.fixture
def start() -> Iterator[Callable[..., tuple[subprocess.Popen[str], list[int]]]]:
    """Start `vprobot ARGS` in a session of its own and wait for `count` children whose command
    line holds `marker`; afterwards kill whatever is left of it and of those children (so
    that a failing test leaves none running)."""
    started: list[tuple[subprocess.Popen[str], list[int]]] = []

    def run(argv: list[str], marker: str, count: int, env: dict[str, str] | None = None
            ) -> tuple[subprocess.Popen[str], list[int]]:
        process = subprocess.Popen([sys.executable, "-m", "vprobot.cli", *argv],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                   start_new_session=True, cwd=ROOT, env=env)
        children: list[int] = []
        started.append((process, children))
        assert _wait_until(lambda: len(_children(process.pid, marker)) >= count
                           or process.poll() is not None, 300), "its children never started"
        children += _children(process.pid, marker)
        assert process.poll() is None and len(children) == count, process.communicate()[1]
        return process, children

    yield run
    for process, children in started:
        for pid in [process.pid, *children]:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        process.communicate()


def test_sigterm_to_the_teacher_ends_its_workers_and_it_at_once(
        tmp_path: Path, start: Callable[..., tuple[subprocess.Popen[str], list[int]]]) -> None:
    """Not after every shard is written, as the pool's shutdown waited for (issue 42, P9)."""
    process, workers = start([*TEACHER, "--out", str(tmp_path / "teacher")], "spawn_main", 2)
    process.send_signal(signal.SIGTERM)
    try:
        _, stderr = process.communicate(timeout=ENDED_WITHIN_S)
    except subprocess.TimeoutExpired:
        pytest.fail("the teacher went on after SIGTERM")
    assert process.returncode == 130
    assert "vprobot teacher: interrupted" in stderr.splitlines()
    assert not [pid for pid in workers if _alive(pid)]
    assert not list((tmp_path / "teacher").glob("shard-*"))


def test_the_teachers_workers_end_when_it_is_killed(
        tmp_path: Path, start: Callable[..., tuple[subprocess.Popen[str], list[int]]]) -> None:
    """Not orphaned, rolling out their shards on (issue 42, P9)."""
    process, workers = start([*TEACHER, "--out", str(tmp_path / "teacher")], "spawn_main", 2)
    process.kill()
    process.wait()
    assert _wait_until(lambda: not any(_alive(pid) for pid in workers), ENDED_WITHIN_S), (
        "the workers outlived the killed teacher")


def test_report_checks_evaluation_ends_and_removes_its_folder_when_check_is_killed(
        tmp_path: Path, start: Callable[..., tuple[subprocess.Popen[str], list[int]]]) -> None:
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    process, (evaluation,) = start(
        ["report", "check", "results/motors", "--episodes", "0", "--planners", "hrec",
         "--carriers", "free"], "evaluate", 1, env={**os.environ, "TMPDIR": str(temporary)})
    assert [path.name[:14] for path in temporary.iterdir()] == ["check-results-"]
    process.kill()
    process.wait()
    assert _wait_until(lambda: not _alive(evaluation), ENDED_WITHIN_S), (
        "the evaluation outlived the killed check")
    assert list(temporary.iterdir()) == []
