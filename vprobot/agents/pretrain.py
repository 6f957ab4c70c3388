"""Imitation before RL: fit the candidate Q-network to the teacher (`agent.pretrain_episodes`).

The teacher (`vprobot.agents.teacher`) rolls out episodes on the run's training objects,
requesting its best candidate, or with probability `EPSILON` a random allowed one, so that the
states also hold a learner's mistakes. Every state is stored with the values of all candidates,
and the Q-network (and its target) is fitted to them by least squares over the allowed
candidates: a target for every candidate at once, where RL sees one reward per step. DQN then
goes on from there, adding the discounted future to the immediate value.

The episodes come from a stream of their own (`PRETRAIN_RANK`), apart from the RL envs', drawn
from `agent.teacher_seed` (the run's seed by default). They are rolled out in shards of
`SHARD_EPISODES`, each saved as it is done into the teacher's folder (`agent.teacher_dir`, by
default the run's `teacher/`), with `teacher.json` saying what made them: a killed run keeps its
finished shards, runs with one teacher seed and folder share them (the teacher's data made once
for every seed of a study), and `vprobot teacher` fills the folder beforehand on several cores.
A folder made for another cell, sensor, env or teacher seed is refused.
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from vprobot.agents.candidate_q import MASK_KEY, CandidateDQN, allowed_rows
from vprobot.agents.stream import EpisodeStream
from vprobot.agents.teacher import CandidateTeacher
from vprobot.config import Config, ConfigError, config_document
from vprobot.env.grid_state import VERSION as GRID_STATE_VERSION
from vprobot.env.inspect_env import InspectEnv
from vprobot.files import atomic_output, folder_lock, read_text, write_text
from vprobot.processes import worker_pool

PRETRAIN_RANK = 1_000
EPSILON = 0.2
PRETRAIN_FILE = "pretrain.csv"
"""Per epoch of the fit: the mean squared error over the allowed candidates."""
SHARD_EPISODES = 25
"""Teacher episodes rolled out and saved together."""
TEACHER_FILE = "teacher.json"
"""What made a teacher folder's shards (`teacher_identity`)."""
_VALUES_KEY = "values"


@dataclasses.dataclass
class TeacherStates:
    """States of the teacher's episodes and the values of every candidate in each.

    Attributes:
        observations: The env's observations, stacked per key (n, ...).
        values: The teacher's value of every candidate (n, K).
    """

    observations: dict[str, np.ndarray]
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.values)


def teacher_seed(config: Config, seed: int) -> int:
    """The seed the teacher's episodes are drawn from: `agent.teacher_seed`, else the run's."""
    return seed if config.agent.teacher_seed is None else config.agent.teacher_seed


def teacher_identity(config: Config, seed: int) -> dict[str, Any]:
    """What decides the teacher's states: the cell, sensor, kinematics and env sections, the
    version of the `s_grid` state, the teacher's seed (`teacher_seed`'s) and its exploration."""
    document = config_document(config)
    return {**{section: document[section] for section in ("cell", "sensor", "kinematics", "env")},
            "grid_state_version": GRID_STATE_VERSION, "teacher_seed": seed, "epsilon": EPSILON,
            "shard_episodes": SHARD_EPISODES}


def shard_sizes(episodes: int) -> list[int]:
    """Episodes of each shard of `episodes` teacher episodes (the last may be shorter)."""
    return [min(SHARD_EPISODES, episodes - start) for start in range(0, episodes, SHARD_EPISODES)]


def collect_shard(config: Config, seed: int, shard: int, first: int,
                  episodes: int) -> TeacherStates:
    """Roll out shard `shard`: `episodes` teacher episodes on the config's training objects,
    from episode `first` of the teacher's stream on.

    Raises:
        ValueError: If episodes < 1.
    """
    if episodes < 1:
        raise ValueError(f"a shard holds at least one episode, got {episodes}")
    inspect = InspectEnv(config)
    env = EpisodeStream(inspect, seed, PRETRAIN_RANK, start=first)
    rng = np.random.default_rng([seed, PRETRAIN_RANK, shard])
    teacher = CandidateTeacher()
    observations: list[dict[str, np.ndarray]] = []
    values: list[np.ndarray] = []
    for _ in range(episodes):
        observation, _ = env.reset()
        episode = inspect.current_episode()
        # The `s_grid` state screened the candidates' reachability: the teacher reads it.
        grid_state = inspect.observer.grid_state
        teacher.reset(episode, grid_state.screening(episode) if grid_state is not None else None)
        done = False
        while not done:
            value = teacher.values(episode)
            observations.append(observation)
            values.append(value)
            allowed = np.flatnonzero(observation[MASK_KEY] > 0.5)
            if rng.random() < EPSILON:
                action = int(rng.choice(allowed))
            else:
                action = int(allowed[np.argmax(value[allowed])])
            observation, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
    env.close()
    stacked = {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}
    return TeacherStates(stacked, np.stack(values).astype(np.float32))


def _shard_file(folder: Path, shard: int, episodes: int) -> Path:
    return folder / f"shard-{shard:04d}-{episodes}.npz"


def _save_shard(config: Config, seed: int, shard: int, sizes: list[int], folder: Path) -> Path:
    states = collect_shard(config, seed, shard, sum(sizes[:shard]), sizes[shard])
    path = _shard_file(folder, shard, sizes[shard])
    with atomic_output(path) as temporary, temporary.open("wb") as file:
        arrays: dict[str, Any] = {_VALUES_KEY: states.values, **states.observations}
        np.savez(file, **arrays)
    return path


def _read_shard(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a shard `_save_shard` wrote.

    Raises:
        ValueError: If it is not one (damaged, or another file), naming it.
    """
    try:
        # Our own handle: np.load leaks the one it opens when the zip directory is corrupt.
        with path.open("rb") as stream, np.load(stream, allow_pickle=False) as shard:
            arrays = {key: shard[key] for key in shard.files}
    # An empty or cut file is an EOFError or a BadZipFile, a file of other bytes a ValueError
    # (numpy takes it for pickled data); a .npy instead of an .npz is no context manager.
    except (OSError, EOFError, zipfile.BadZipFile, ValueError, AttributeError,
            TypeError) as error:
        raise ValueError(f"cannot read teacher shard {path}: {error}; remove it, and "
                         f"`vprobot teacher` rolls it out again") from None
    if _VALUES_KEY not in arrays:
        raise ValueError(f"{path} is not a teacher shard (it has no {_VALUES_KEY!r} array); "
                         f"remove it, and `vprobot teacher` rolls it out again")
    return arrays


def _open_folder(config: Config, seed: int, folder: Path) -> None:
    """Write the folder's `teacher.json`, or check that it was made for this teacher.

    Raises:
        ConfigError: For a folder of another teacher, naming the sections that differ.
    """
    identity = teacher_identity(config, seed)
    record = folder / TEACHER_FILE
    if not record.is_file():
        write_text(record, json.dumps(identity, indent=1) + "\n")
        return
    held = json.loads(read_text(record))
    differing = [key for key in identity if held.get(key) != json.loads(json.dumps(identity[key]))]
    if differing:
        raise ConfigError(f"{folder} holds the teacher states of another run: its "
                          f"{TEACHER_FILE} differs in {', '.join(differing)}; give another "
                          f"agent.teacher_dir (or remove that folder)")


def collect(config: Config, episodes: int, seed: int, folder: Path, workers: int = 1,
            progress: bool = False) -> TeacherStates:
    """The states of `episodes` teacher episodes, from the shards in `folder`, rolling out
    (with `workers` processes) and saving the missing ones first.

    Raises:
        ValueError: If episodes < 1 or workers < 1.
        ConfigError: If `folder` holds another teacher's shards.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    seed = teacher_seed(config, seed)
    sizes = shard_sizes(episodes)
    files = [_shard_file(folder, shard, size) for shard, size in enumerate(sizes)]
    if all(file.is_file() for file in files):
        # Read without the folder's lock: the seeds of a study load one folder at once.
        _open_folder(config, seed, folder)
    else:
        with folder_lock(folder, f"teacher folder {folder}"):
            _open_folder(config, seed, folder)
            _roll_out([shard for shard, file in enumerate(files) if not file.is_file()],
                      sizes, config, seed, folder, workers, progress)
    shards = [_read_shard(file) for file in files]
    return TeacherStates({key: np.concatenate([shard[key] for shard in shards])
                          for key in shards[0] if key != _VALUES_KEY},
                         np.concatenate([shard[_VALUES_KEY] for shard in shards]))


def _roll_out(missing: list[int], sizes: list[int], config: Config, seed: int, folder: Path,
              workers: int, progress: bool) -> None:
    """Roll out and save the missing shards, in `workers` processes."""
    # Closed on an interrupt too, so that the command's "interrupted" starts a line of its own.
    with tqdm(total=len(sizes), initial=len(sizes) - len(missing),
              desc=f"teacher shards ({SHARD_EPISODES} episodes)", disable=not progress) as bar:
        if workers == 1 or len(missing) < 2:
            for shard in missing:
                _save_shard(config, seed, shard, sizes, folder)
                bar.update()
        else:
            with worker_pool(min(workers, len(missing))) as pool:
                futures = [pool.submit(_save_shard, config, seed, shard, sizes, folder)
                           for shard in missing]
                for future in futures:
                    future.result()
                    bar.update()


def teacher_folder(config: Config, run_dir: Path) -> Path:
    """Where a run's teacher shards are: `agent.teacher_dir`, else the run's `teacher/`."""
    return Path(config.agent.teacher_dir) if config.agent.teacher_dir else run_dir / "teacher"


def fit(model: CandidateDQN, states: TeacherStates, epochs: int, seed: int) -> list[float]:
    """Fit the model's Q-network to the teacher's values (Adam at the model's learning rate,
    its batch size), then copy it into the target network. Returns the loss of every epoch."""
    q_net = model.policy.q_net
    optimizer = torch.optim.Adam(q_net.parameters(), lr=model.lr_schedule(1.0))
    rng = np.random.default_rng(seed)
    losses = []
    for _ in range(epochs):
        order = rng.permutation(len(states))
        total = 0.0
        for start in range(0, len(order), model.batch_size):
            batch = order[start:start + model.batch_size]
            obs = {key: torch.as_tensor(value[batch], device=model.device)
                   for key, value in states.observations.items()}
            target = torch.as_tensor(states.values[batch], device=model.device)
            allowed = allowed_rows(obs[MASK_KEY]).float()
            error = (q_net(obs) - target) * allowed
            loss = error.square().sum() / allowed.sum()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += loss.item() * len(batch)
        losses.append(total / len(order))
    model.policy.q_net_target.load_state_dict(q_net.state_dict())
    return losses


def pretrain(model: CandidateDQN, config: Config, seed: int, run_dir: Path,
             progress: bool = False) -> list[float]:
    """Collect the teacher's states and fit the model to them; the losses go to
    `run_dir/pretrain.csv`."""
    agent = config.agent
    states = collect(config, agent.pretrain_episodes, seed, teacher_folder(config, run_dir),
                     progress=progress)
    losses = fit(model, states, agent.pretrain_epochs, seed)
    write_text(run_dir / PRETRAIN_FILE, "epoch,mse\n" + "".join(
        f"{epoch},{loss:.6g}\n" for epoch, loss in enumerate(losses, start=1)))
    return losses
