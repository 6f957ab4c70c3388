"""Cluster benchmark: how much a local Ray with two workers speeds up an evaluation and a
sweep on this machine.

`evaluate_speedup_2_workers`: the same episode list (B_SCP with the robot) evaluated in this
process (`--workers 1`) and on two Ray workers (`--workers 2`), Ray already started and its
workers warm.
`sweep_speedup_2_trials`: training steps per second of two trials run at once on two workers
over one trial alone.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

from vprobot.compute.cluster import parallel_map, start
from vprobot.config import Config
from vprobot.episode import episode_list
from vprobot.evaluation import evaluate, held_out_motors
from vprobot.files.paths import PROFILES_DIR
from vprobot.training.sweep import run_trial

TRIAL_STEPS = 1500
TRIAL_SET = ("agent.eval_freq=100000", "agent.checkpoint_freq=100000", "agent.eval_episodes=1")


def _timed_evaluation(config: Config, workers: int, folder: Path) -> float:
    specs = episode_list(config, held_out_motors(), [0, 1])
    start_time = time.perf_counter()
    evaluate(config, ["bscp"], specs, folder, progress=False, carriers=["robot"],
             workers=workers)
    return time.perf_counter() - start_time


def _timed_trials(count: int, folder: Path) -> float:
    items = [(PROFILES_DIR / "cpu.yaml", TRIAL_SET, TRIAL_STEPS, seed,
              folder / f"trial{seed}") for seed in range(count)]
    start_time = time.perf_counter()
    for _ in parallel_map(run_trial, items, 2):
        pass
    return time.perf_counter() - start_time


def _warm(config: Config) -> bool:
    import vprobot.planners.runner  # noqa: F401 - what an evaluation task imports first

    return True


def run_cluster_benchmark(config: Config) -> dict[str, Any]:
    """Both speed-ups on a local Ray with 2 CPUs, started before any timing, its two workers
    having imported vprobot (what a long evaluation pays once)."""
    start(None, 2)
    for _ in parallel_map(_warm, [(config,), (config,)], 2):
        pass
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        one = _timed_evaluation(config, 1, folder / "serial")
        two = _timed_evaluation(config, 2, folder / "ray")
        alone = _timed_trials(1, folder / "alone")
        pair = _timed_trials(2, folder / "pair")
    return {
        "evaluate_s_1_worker": one,
        "evaluate_s_2_workers": two,
        "evaluate_speedup_2_workers": one / two,
        "trial_s_alone": alone,
        "trials_s_two_at_once": pair,
        "sweep_speedup_2_trials": 2 * alone / pair,
        "trial_steps": TRIAL_STEPS,
        "episodes": 2 * len(held_out_motors()),
    }
