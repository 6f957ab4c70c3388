"""Training callbacks: evaluation on the validation episodes with the best model kept, and
resumable checkpoints (model, replay buffer, episode stream, log lengths)."""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from vprobot.config import Selection
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode import EpisodeSpec
from vprobot.files.atomic import (
    append_line,
    atomic_output,
    csv_text,
    read_text,
    truncate_output,
    write_text,
)
from vprobot.training.evaluation import SUMMARY_KEYS, evaluate_policy, policy_summary
from vprobot.training.runs import best_evaluation, current_names, evaluation_score

EVALUATION_COLUMNS = ("step", "wall_s", *SUMMARY_KEYS)
CHECKPOINT_FILE = "checkpoint.json"
BUFFER_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")
"""A replay buffer's per-transition arrays (Dict observations: one array per key)."""


def upgrade_evaluations(path: Path) -> None:
    """Rewrite an `evaluations.csv` written before the one summary in today's columns, so that
    a run resumed by this version appends rows under the header they belong to."""
    lines = read_text(path).splitlines() if path.is_file() else []
    if lines and lines[0].split(",") != list(EVALUATION_COLUMNS):
        rows = [current_names(row) for row in csv.DictReader(lines)]
        write_text(path, csv_text(EVALUATION_COLUMNS, rows))


def count_lines(path: Path) -> int:
    return path.read_bytes().count(b"\n") if path.is_file() else 0


def truncate_lines(path: Path, lines: int) -> None:
    """Keep the first `lines` lines of a log (what a checkpoint had seen).

    Raises:
        LinkError: If the log is a symbolic link.
    """
    if not path.is_file():
        return
    data = path.read_bytes()
    end = 0
    for _ in range(lines):
        end = data.index(b"\n", end) + 1
    truncate_output(path, end)


def grid_step(steps: int, frequency: int) -> int:
    """The last multiple of `frequency` at or before `steps`: evaluations and checkpoints stay on
    that grid, a resumed run's too.

    The callbacks read the model's step count when they are set up: their own `num_timesteps`
    is still 0 then (SB3 sets it at the first step), which put a resumed run's first
    evaluation one step after its checkpoint (at 201, then 301, ...), off the grid.
    """
    return steps - steps % frequency


class SharedEpisodeEvaluation(BaseCallback):
    """Every `frequency` env steps, score the deterministic policy on the validation episodes.

    Appends a row to `evaluations.csv`, records `eval/*` in the logger (TensorBoard, CSV) and
    keeps `best_model.zip`: the best under `select` (`agent.select`, `runs.evaluation_score`).

    Args:
        env: The evaluation env (`evaluation.evaluation_env`).
        specs: The episodes.
        run_dir: The run directory.
        frequency: Env steps between evaluations.
        clock_start: `time.time()` the run's wall clock counts from (kept across resumes).
        select: How evaluations rank (`agent.select`).
    """

    def __init__(self, env: InspectEnv, specs: list[EpisodeSpec], run_dir: Path,
                 frequency: int, clock_start: float, select: Selection):
        super().__init__()
        self.eval_env = env
        self.specs = specs
        self.run_dir = run_dir
        self.frequency = frequency
        self.clock_start = clock_start
        self.path = run_dir / "evaluations.csv"
        self.select = select
        self.best = best_so_far(self.path, select)
        self.last = 0
        self.latest: dict[str, Any] = {}
        self.latest_step = -1

    def _init_callback(self) -> None:
        self.last = grid_step(self.model.num_timesteps, self.frequency)

    def _on_step(self) -> bool:
        if self.num_timesteps - self.last >= self.frequency:
            self.last = grid_step(self.num_timesteps, self.frequency)
            self.evaluate()
        return True

    def evaluate(self) -> dict[str, Any]:
        return self.evaluate_model(self.model)

    def evaluate_model(self, model: BaseAlgorithm) -> dict[str, Any]:
        """Evaluate `model` (at its step count), log the row, keep it if it is the best."""
        summary = policy_summary(evaluate_policy(model, self.eval_env, self.specs))
        self.latest, self.latest_step = summary, model.num_timesteps
        row = {"step": model.num_timesteps, "wall_s": time.time() - self.clock_start, **summary}
        # A resume from a checkpoint older than the first evaluation leaves an empty file.
        append_line(self.path, csv_text(EVALUATION_COLUMNS, [row],
                                         header=count_lines(self.path) == 0))
        for key, value in summary.items():
            if value is not None:  # e.g. joint travel without the robot
                model.logger.record(f"eval/{key}", value)
        score = evaluation_score(summary, self.select)
        if self.best is None or score > self.best:
            self.best = score
            with atomic_output(self.run_dir / "best_model.zip") as temporary:
                model.save(temporary)
        return summary


def best_so_far(path: Path, select: Selection) -> tuple[float, ...] | None:
    """The best score under `select` in an evaluations file, None when there is none."""
    best = best_evaluation(path, select)
    return None if best is None else evaluation_score(best, select)


class ResumableCheckpoint(BaseCallback):
    """Every `frequency` env steps, save what a resume needs, each file atomically, then
    `checkpoint.json` naming them (written last, so it only ever names complete files).

    Saved: the model (weights, optimiser, step counter, learning-rate schedule), the filled
    part of the replay buffer (off-policy algorithms; `save_buffer`), each env's episode count
    (the episode stream goes on from there) and the line counts of the logs (a resume cuts
    what was written after the checkpoint). The previous checkpoint's files are removed once
    the new one is complete.

    Args:
        run_dir: The run directory.
        frequency: Env steps between checkpoints.
        logs: Log files whose length to record.
    """

    def __init__(self, run_dir: Path, frequency: int, logs: list[Path]):
        super().__init__()
        self.run_dir = run_dir
        self.folder = run_dir / "checkpoints"
        self.frequency = frequency
        self.logs = logs
        self.last = 0

    def _init_callback(self) -> None:
        self.folder.mkdir(exist_ok=True)
        self.last = grid_step(self.model.num_timesteps, self.frequency)

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        # At the end of a rollout the buffer holds every step counted so far (during a step
        # the callback runs before the step's transition is stored).
        if self.num_timesteps - self.last >= self.frequency:
            self.last = grid_step(self.num_timesteps, self.frequency)
            self.save()

    def save(self) -> dict[str, Any]:
        steps = self.num_timesteps
        previous = read_checkpoint(self.run_dir)
        model_path = self.folder / f"model_{steps}.zip"
        with atomic_output(model_path) as temporary:
            self.model.save(temporary)
        state: dict[str, Any] = {
            "steps": steps,
            "model": model_path.name,
            "episodes_started": self.training_env.get_attr("episodes_started"),
            "log_lines": {log.name: count_lines(log) for log in self.logs},
            "buffer": None,
        }
        if isinstance(self.model, OffPolicyAlgorithm) and self.model.replay_buffer is not None:
            buffer_path = self.folder / f"replay_buffer_{steps}.npz"
            with atomic_output(buffer_path) as temporary:
                save_buffer(self.model.replay_buffer, temporary)
            state["buffer"] = buffer_path.name
        write_text(self.run_dir / CHECKPOINT_FILE, json.dumps(state, indent=1) + "\n")
        if previous is not None and previous["steps"] != steps:
            for name in (previous["model"], previous["buffer"]):
                if name is not None:
                    (self.folder / name).unlink(missing_ok=True)
        return state


def read_checkpoint(run_dir: Path) -> dict[str, Any] | None:
    """The latest complete checkpoint of a run, None when there is none."""
    path = run_dir / CHECKPOINT_FILE
    return json.loads(path.read_text()) if path.is_file() else None


def _buffer_arrays(buffer: ReplayBuffer) -> dict[str, np.ndarray]:
    """The buffer's per-transition arrays by name (`observations.points` for a Dict)."""
    arrays: dict[str, np.ndarray] = {}
    for name in BUFFER_ARRAYS:
        value = getattr(buffer, name, None)
        if isinstance(value, dict):
            arrays.update({f"{name}.{key}": array for key, array in value.items()})
        elif value is not None:
            # None: next_observations of a buffer that optimises memory usage.
            arrays[name] = value
    return arrays


def save_buffer(buffer: ReplayBuffer, path: Path) -> None:
    """Save the transitions a replay buffer holds (not its empty pre-allocated rest) as `.npz`.

    SB3's `save_replay_buffer` pickles the whole allocation: 615 MB at step 100 of the CPU
    profile, where this writes what those 100 transitions take.
    """
    filled = buffer.buffer_size if buffer.full else buffer.pos
    # Any: numpy's stub takes a ** mapping for one that may hold its `allow_pickle` flag.
    arrays: dict[str, Any] = {name: array[:filled]
                              for name, array in _buffer_arrays(buffer).items()}
    with path.open("wb") as stream:
        np.savez(stream, pos=buffer.pos, full=buffer.full, **arrays)


def load_buffer(buffer: ReplayBuffer, path: Path) -> None:
    """Restore what `save_buffer` saved into a fresh buffer of the same size and spaces.

    Raises:
        ValueError: If the file does not hold this buffer's arrays.
    """
    arrays = _buffer_arrays(buffer)
    with np.load(path) as stored:
        if set(stored.files) != {"pos", "full", *arrays}:
            raise ValueError(f"{path} holds {', '.join(sorted(stored.files))}, not the arrays "
                             f"of this run's replay buffer")
        for name, array in arrays.items():
            transitions = stored[name]
            array[: len(transitions)] = transitions
        buffer.pos, buffer.full = int(stored["pos"]), bool(stored["full"])
