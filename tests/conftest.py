"""Shared test setup: vprobot's caches (ground truth, generated objects) go into one temporary
folder per test run, shared by every test, both pytest-xdist workers and the processes they
start, never into the user's ~/.cache (the caches write atomically, so the workers may fill it
at once). Tests that need a cache of their own set `VPROBOT_CACHE_DIR` themselves.
Expensive results that several test modules compare against are made once per session here."""

from __future__ import annotations

# isort: off
# First, before helpers import numpy: vprobot pins the arithmetic kernels as it loads
# (vprobot/compute/kernels.py), which numpy's OpenBLAS reads only when it loads.
import vprobot  # noqa: F401
# isort: on
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import (
    SERIAL_EVALUATION,
    TINY_TRAINING,
    SmokeRuns,
    held_out_test_objects,
    shape_descriptor,
)

from vprobot.files.atomic import waiting_lock
from vprobot.files.paths import CACHE_ENV_VAR


def _run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The temporary folder of the whole test run: under pytest-xdist each worker's base
    folder sits in it."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session", autouse=True)
def session_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    folder = _run_folder(tmp_path_factory) / "vprobot-cache"
    folder.mkdir(exist_ok=True)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_ENV_VAR, str(folder))
        yield folder


@pytest.fixture(scope="session")
def serial_evaluation(session_cache: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder of the tables of `SERIAL_EVALUATION`, run once per test run in a test
    process (the first worker to need it; the other waits for it). Read only."""
    from vprobot.cli import main

    folder = _run_folder(tmp_path_factory) / "serial-evaluation"
    with waiting_lock(folder.parent / "serial-evaluation.lock"):
        # Made whole while the lock is held: present means done.
        if not (folder / "evaluation.md").is_file():
            assert main([*SERIAL_EVALUATION, "--out", str(folder)]) == 0
    return folder


@pytest.fixture(scope="session")
def held_out_descriptors(tmp_path_factory: pytest.TempPathFactory
                         ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """`shape_descriptor` of each of helpers' `held_out_test_objects()`, in order, computed
    once per test run (building the 32 family instances takes seconds) in a test process (the
    first worker to need them; the other waits for them) for tests/test_procedural.py and
    tests/test_manifold.py. Stored as written (float64): the same numbers. Read only."""
    path = _run_folder(tmp_path_factory) / "held-out-descriptors.npz"
    with waiting_lock(path.with_suffix(".lock")):
        # Written whole while the lock is held: present means done.
        if not path.is_file():
            descriptors = [shape_descriptor(mesh) for mesh in held_out_test_objects()]
            with path.open("wb") as stream:
                np.savez(stream, **{name: np.array([one[part] for one in descriptors])
                                    for part, name in enumerate(("d2", "angles", "sizes"))})
        with np.load(path) as stored:
            return list(zip(stored["d2"], stored["angles"], stored["sizes"], strict=True))


@pytest.fixture(scope="session")
def default_plans(session_cache: Path, tmp_path_factory: pytest.TempPathFactory
                  ) -> dict[str, Path]:
    """`vprobot plan --carrier CARRIER --no-summary` of the bundled motor (the default planner
    and seed) with the UR10 in the loop (`robot`) and with a free sensor (`free`), made once per
    test run in a test process (the first worker to need them; the other waits for them), for
    the viewer's tests. Read only."""
    from vprobot.cli import main

    folder = _run_folder(tmp_path_factory) / "default-plans"
    made = {carrier: folder / f"{carrier}.json" for carrier in ("robot", "free")}
    with waiting_lock(folder.parent / "default-plans.lock"):
        # Each plan is written whole (atomically) while the lock is held: present means done.
        for carrier, plan in made.items():
            if not plan.is_file():
                folder.mkdir(exist_ok=True)
                assert main(["plan", "--out", str(plan), "--carrier", carrier,
                             "--no-summary"]) == 0
    return made


@pytest.fixture(scope="session")
def smoke_runs(session_cache: Path, tmp_path_factory: pytest.TempPathFactory) -> SmokeRuns:
    """Trains (once per session) 64 steps of the CPU profile with `TINY_TRAINING`, an
    algorithm, an encoder and a robot state, evaluating and checkpointing at the end; gives its
    config, result and run folder. 64 steps: one rollout of PPO's n_steps."""
    from vprobot.files.paths import CONFIGS_DIR
    from vprobot.training.train import profile_config, train

    runs: dict[tuple[str, str, bool], tuple[Any, dict[str, Any], Path]] = {}

    def smoke_run(algorithm: str, encoder: str, robot_state: bool
                  ) -> tuple[Any, dict[str, Any], Path]:
        key = (algorithm, encoder, robot_state)
        if key not in runs:
            config = profile_config(CONFIGS_DIR / "agents" / "cpu.yaml", [
                *TINY_TRAINING, "agent.eval_freq=64", "agent.checkpoint_freq=64",
                f"agent.algorithm={algorithm}", f"agent.encoder={encoder}",
                f"env.robot_state={str(robot_state).lower()}"], steps=64)
            run = tmp_path_factory.mktemp(f"{algorithm}-{encoder}") / "run"
            runs[key] = config, train(config, run, seed=1, progress=False), run
        return runs[key]

    return smoke_run
