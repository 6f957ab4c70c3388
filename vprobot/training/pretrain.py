"""Imitation before RL: fit the candidate Q-network to the teacher (`agent.pretrain_episodes`).

The teacher (`vprobot.training.teacher`) rolls out episodes on the run's training objects,
requesting its best candidate, or with probability `EPSILON` a random allowed one, so that the
states also hold a learner's mistakes. Every state is stored with the values of all candidates
and its remaining cover (`CandidateTeacher.remaining_cover`: which candidates, whether they
reach the goal within the views left, and whether they are proven the fewest). With
`agent.pretrain_target: values` the Q-network (and its target) is fitted to the values by least
squares over the allowed candidates: a target for every candidate at once, where RL sees one
reward per step. DQN then goes on from there, adding the discounted future to the immediate
value. With `cover` the network's outputs are fitted as logits of membership in a remaining cover
(binary cross-entropy; every candidate of some smallest cover is a member), so that the policy's
choice is a view of a smallest plan to the goal; with `views` they are fitted (least squares) to
how many views more than the fewest the goal takes when the candidate is taken next (negated),
plus its value as the tie-break. RL then only goes on where validation keeps it.

The episodes come from a stream of their own (`PRETRAIN_RANK`), apart from the RL envs', drawn
from `agent.teacher_seed` (the run's seed by default). They are rolled out in shards of
`SHARD_EPISODES`, each saved as it is done into the teacher's folder (`agent.teacher_dir`, by
default the run's `teacher/`), with `teacher.json` saying what made them: a killed run keeps its
finished shards, runs with one teacher seed and folder share them (the teacher's data made once
for every seed of a study), and `vprobot teacher` fills the folder beforehand on several cores.
A folder made for another cell, sensor, env or teacher seed is refused.

With `agent.rollout_agent` the episodes follow a trained agent's greedy choices instead of the
teacher's best (still one time in five a random allowed one), and the teacher labels the states
the agent itself visits (DAgger): an imitation is only ever fitted to the teacher's states, and
its own mistakes lead it where the teacher never went. `agent.more_teacher_dirs` adds such
folders' states to a run's fit.
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from vprobot.agents.candidate_q import MASK_KEY, CandidateDQN, CandidateQNetwork, allowed_rows
from vprobot.agents.trained import load_agent, model_file
from vprobot.compute.processes import worker_pool
from vprobot.config import Config, ConfigError, config_document
from vprobot.env.grid_state import VERSION as GRID_STATE_VERSION
from vprobot.env.inspect_env import InspectEnv
from vprobot.files.atomic import atomic_output, file_sha256, folder_lock, read_text, write_text
from vprobot.training.stream import EpisodeStream
from vprobot.training.teacher import CandidateTeacher

PRETRAIN_RANK = 1_000
EPSILON = 0.2
PRETRAIN_FILE = "pretrain.csv"
"""Per epoch of the fit: its loss over the allowed candidates (`mse` for the values and the
views, `bce` for the cover) and, with the head of the views left, its error
(`VIEWS_LEFT_COLUMN`)."""
VIEWS_LEFT_COLUMN = "views_left_mae"
"""The head of the views left's mean absolute error (views) over the states whose goal is in
reach, per epoch."""
COVER_POSITIVE_WEIGHT = 1.5
"""`agent.pretrain_target: cover`: the weight of a member in the cross-entropy (MA-SCVP's 1.5: a
cover holds a few of the candidates)."""
SHARD_EPISODES = 25
"""Teacher episodes rolled out and saved together."""
TEACHER_FILE = "teacher.json"
"""What made a teacher folder's shards (`teacher_identity`)."""
LABELS_VERSION = 2
"""What the shards hold besides the states: 1, the values and the remaining cover; 2, also
every candidate's views to the goal."""
_VALUES_KEY = "values"
_COVER_KEY = "cover"
_REACHES_KEY = "cover_reaches"
_PROVEN_KEY = "cover_proven"
_VIEWS_KEY = "cover_views"
_LABEL_KEYS = (_VALUES_KEY, _COVER_KEY, _REACHES_KEY, _PROVEN_KEY, _VIEWS_KEY)


@dataclasses.dataclass
class TeacherStates:
    """States of the teacher's episodes and the values of every candidate in each.

    Attributes:
        observations: The env's observations, stacked per key (n, ...).
        values: The teacher's value of every candidate (n, K).
        cover: Whether each candidate is in the state's remaining cover (n, K).
        cover_reaches: Whether that cover reaches the goal within the views left (n,).
        cover_proven: Whether it is proven a smallest one (n,).
        cover_views: The views to the goal when each candidate is taken next (n, K); inf where
            it cannot be taken or the goal is out of reach.
    """

    observations: dict[str, np.ndarray]
    values: np.ndarray
    cover: np.ndarray
    cover_reaches: np.ndarray
    cover_proven: np.ndarray
    cover_views: np.ndarray

    def __len__(self) -> int:
        return len(self.values)

    @property
    def views_left(self) -> np.ndarray:
        """The fewest views to the goal of every state (n,), the next one included: what the
        head of the views left is fitted to; inf where the goal is out of reach."""
        return self.cover_views.min(axis=1)


def teacher_seed(config: Config, seed: int) -> int:
    """The seed the teacher's episodes are drawn from: `agent.teacher_seed`, else the run's."""
    return seed if config.agent.teacher_seed is None else config.agent.teacher_seed


_WORLD_KEYS = ("cell", "sensor", "kinematics", "env", "grid_state_version", "labels_version")
"""What a teacher folder's states must share with a run to be fitted by it: the world they were
made in and what the shards hold (not the seed or the choices that drove the episodes)."""


def teacher_identity(config: Config, seed: int) -> dict[str, Any]:
    """What decides the teacher's states: the cell, sensor, kinematics and env sections, the
    version of the `s_grid` state, the teacher's seed (`teacher_seed`'s), its exploration and
    the agent whose choices it follows (`agent.rollout_agent`, by the sha256 of its model file);
    and what its shards hold (`LABELS_VERSION`)."""
    document = config_document(config)
    rollout = config.agent.rollout_agent
    return {**{section: document[section] for section in ("cell", "sensor", "kinematics", "env")},
            "grid_state_version": GRID_STATE_VERSION, "labels_version": LABELS_VERSION,
            "teacher_seed": seed, "epsilon": EPSILON, "shard_episodes": SHARD_EPISODES,
            "rollout_agent": None if rollout is None else file_sha256(model_file(rollout))}


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
    rollout = (None if config.agent.rollout_agent is None
               else load_agent(config.agent.rollout_agent).model)
    observations: list[dict[str, np.ndarray]] = []
    values: list[np.ndarray] = []
    covers: list[np.ndarray] = []
    reaches: list[bool] = []
    proven: list[bool] = []
    views: list[np.ndarray] = []
    goal = config.env.coverage_goal
    for _ in range(episodes):
        observation, _ = env.reset()
        episode = inspect.current_episode()
        # The `s_grid` state screened the candidates' reachability: the teacher reads it.
        grid_state = inspect.observer.grid_state
        teacher.reset(episode, grid_state.screening(episode) if grid_state is not None else None)
        done = False
        while not done:
            value = teacher.values(episode)
            cover = teacher.remaining_cover(episode, goal, inspect.step_limit - inspect.steps)
            observations.append(observation)
            values.append(value)
            covers.append(np.isin(np.arange(len(value)), cover.picks))
            reaches.append(cover.goal_reached)
            proven.append(cover.proven)
            views.append(teacher.views_to_goal(episode, goal, cover))
            allowed = np.flatnonzero(observation[MASK_KEY] > 0.5)
            if rng.random() < EPSILON:
                action = int(rng.choice(allowed))
            elif rollout is not None:
                action = int(rollout.predict(observation, deterministic=True)[0])
            else:
                action = int(allowed[np.argmax(value[allowed])])
            observation, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
    env.close()
    stacked = {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}
    return TeacherStates(stacked, np.stack(values).astype(np.float32), np.stack(covers),
                         np.array(reaches), np.array(proven),
                         np.stack(views).astype(np.float32))


def _shard_file(folder: Path, shard: int, episodes: int) -> Path:
    return folder / f"shard-{shard:04d}-{episodes}.npz"


def _save_shard(config: Config, seed: int, shard: int, sizes: list[int], folder: Path) -> Path:
    states = collect_shard(config, seed, shard, sum(sizes[:shard]), sizes[shard])
    path = _shard_file(folder, shard, sizes[shard])
    with atomic_output(path) as temporary, temporary.open("wb") as file:
        arrays: dict[str, Any] = {_VALUES_KEY: states.values, _COVER_KEY: states.cover,
                                  _REACHES_KEY: states.cover_reaches,
                                  _PROVEN_KEY: states.cover_proven,
                                  _VIEWS_KEY: states.cover_views, **states.observations}
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
    missing = [key for key in _LABEL_KEYS if key not in arrays]
    if missing:
        raise ValueError(f"{path} is not a teacher shard (it has no {missing[0]!r} array); "
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
    differing = _differing(record, identity, identity)
    if differing:
        raise ConfigError(f"{folder} holds the teacher states of another run: its "
                          f"{TEACHER_FILE} differs in {', '.join(differing)}; give another "
                          f"agent.teacher_dir (or remove that folder)")


def _differing(record: Path, identity: dict[str, Any], keys: Iterable[str]) -> list[str]:
    """The `keys` whose values in the `teacher.json` at `record` are not `identity`'s (compared
    as JSON holds them)."""
    held = json.loads(read_text(record))
    return [key for key in keys if held.get(key) != json.loads(json.dumps(identity[key]))]


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
    return read_shards(files)


def read_shards(files: list[Path]) -> TeacherStates:
    """The states of teacher shards, in the order given.

    Raises:
        ValueError: If a file is not a teacher shard (`_read_shard`).
    """
    shards = [_read_shard(file) for file in files]
    joined = {key: np.concatenate([shard[key] for shard in shards]) for key in shards[0]}
    return TeacherStates({key: array for key, array in joined.items() if key not in _LABEL_KEYS},
                         joined[_VALUES_KEY], joined[_COVER_KEY], joined[_REACHES_KEY],
                         joined[_PROVEN_KEY], joined[_VIEWS_KEY])


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


def more_teacher_states(config: Config) -> list[TeacherStates]:
    """The states of every folder of `agent.more_teacher_dirs`: all their shards.

    Raises:
        ConfigError: For a folder that holds no teacher shards, or shards made in another world
            (cell, sensor, kinematics, env) or holding other labels, naming what differs.
    """
    identity = teacher_identity(config, 0)
    found = []
    for name in config.agent.more_teacher_dirs or ():
        folder = Path(name)
        record, files = folder / TEACHER_FILE, sorted(folder.glob("shard-*.npz"))
        if not record.is_file() or not files:
            raise ConfigError(f"agent.more_teacher_dirs: {folder} holds no teacher shards "
                              f"(make them with `vprobot teacher ... --out {folder}`)")
        differing = _differing(record, identity, _WORLD_KEYS)
        if differing:
            raise ConfigError(f"agent.more_teacher_dirs: {folder} was made for another run: its "
                              f"{TEACHER_FILE} differs in {', '.join(differing)}")
        found.append(read_shards(files))
    return found


def joined_states(parts: list[TeacherStates]) -> TeacherStates:
    """One set of the states of several (the one itself, uncopied)."""
    if len(parts) == 1:
        return parts[0]
    return TeacherStates(
        {key: np.concatenate([part.observations[key] for part in parts])
         for key in parts[0].observations},
        *(np.concatenate([getattr(part, field.name) for part in parts])
          for field in dataclasses.fields(TeacherStates)[1:]))


def teacher_folder(config: Config, run_dir: Path) -> Path:
    """Where a run's teacher shards are: `agent.teacher_dir`, else the run's `teacher/`."""
    return Path(config.agent.teacher_dir) if config.agent.teacher_dir else run_dir / "teacher"


def fit(model: CandidateDQN, states: TeacherStates, epochs: int, seed: int,
        target: str = "values") -> dict[str, list[float]]:
    """Fit the model's Q-network to the teacher's `target` (`agent.pretrain_target`: `values`
    by least squares, `cover` by binary cross-entropy on logits) over the allowed candidates
    (Adam at the model's learning rate, its batch size), then copy it into the target network.
    A network with the head of the views left (`CandidateQNetwork.views_left`) fits it beside,
    by least squares on their logarithms to the state's fewest views to the goal where the goal
    is in reach; the head shares no parameter with the Q-values, which it leaves as they would be
    without it.

    Returns:
        Per epoch, the loss over the allowed candidates (`mse` or, for `cover`, `bce`) and, with
        the head, its mean absolute error in views (`views_left_mae`), by column name.
    """
    q_net = model.policy.q_net
    assert isinstance(q_net, CandidateQNetwork)  # a CandidateDQN's policy makes one
    optimizer = torch.optim.Adam(q_net.parameters(), lr=model.lr_schedule(1.0))
    labels, fitted = fit_labels(states, target)
    left = states.views_left.astype(np.float32)
    in_reach = max(int(np.isfinite(left).sum()), 1)
    has_head = q_net.views_left_head is not None
    weight = torch.tensor(COVER_POSITIVE_WEIGHT, device=model.device)
    rng = np.random.default_rng(seed)
    column = loss_column(target)
    log: dict[str, list[float]] = {column: []}
    if has_head:
        log[VIEWS_LEFT_COLUMN] = []
    for _ in range(epochs):
        order = rng.permutation(len(states))
        total = head_error = 0.0
        for start in range(0, len(order), model.batch_size):
            batch = order[start:start + model.batch_size]
            obs = {key: torch.as_tensor(value[batch], device=model.device)
                   for key, value in states.observations.items()}
            wanted = torch.as_tensor(labels[batch], device=model.device)
            allowed = allowed_rows(obs[MASK_KEY]).float() * torch.as_tensor(
                fitted[batch], device=model.device)
            if target != "cover":
                error = (q_net(obs) - wanted).square()
            else:
                error = torch.nn.functional.binary_cross_entropy_with_logits(
                    q_net(obs), wanted, pos_weight=weight, reduction="none")
            loss = (error * allowed).sum() / allowed.sum()
            total += loss.item() * len(batch)
            if has_head:
                views = torch.as_tensor(left[batch], device=model.device)
                known = torch.isfinite(views)
                if known.any():
                    logs = q_net.log_views_left(obs)[known]
                    loss = loss + (logs - views[known].log()).square().mean()
                    head_error += (logs.detach().exp() - views[known]).abs().sum().item()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        log[column].append(total / len(order))
        if has_head:
            log[VIEWS_LEFT_COLUMN].append(head_error / in_reach)
    model.policy.q_net_target.load_state_dict(q_net.state_dict())
    return log


def loss_column(target: str) -> str:
    """The name of `fit`'s loss for `target` in its log and `pretrain.csv`: `bce` for the cover's
    cross-entropy, `mse` for the least squares of the values and the views."""
    return "bce" if target == "cover" else "mse"


def fit_labels(states: TeacherStates, target: str) -> tuple[np.ndarray, np.ndarray]:
    """What `fit` fits the network's outputs to (n, K), and where (n, K), for `target`:

    - `values`: the teacher's values, everywhere;
    - `cover`: 1 for the candidates of some smallest remaining cover (those with the fewest
      views to the goal), else 0; where the goal is out of reach, the remaining cover's (the
      candidates adding the most);
    - `views`: the value minus the views to the goal beyond the state's fewest, where the goal
      is in reach: the fewest views first, then the most coverage now (the value, a gain, stays
      below one view). Beyond the fewest, not the views themselves: the network then ranks the
      candidates of a state without also fitting how far it lies from the goal (fitted to the
      views themselves, its choice was in a smallest cover less often than the values' was).
    """
    views = states.cover_views
    reachable = np.isfinite(views)
    if target == "values":
        return states.values, np.ones(views.shape, dtype=np.float32)
    fewest = states.views_left[:, None]  # inf where none is reachable
    if target == "cover":
        members = np.where(reachable.any(axis=1, keepdims=True), views <= fewest, states.cover)
        return members.astype(np.float32), np.ones(views.shape, dtype=np.float32)
    # A state out of reach has no fewest: 0 there keeps its (unfitted) entries finite.
    beyond = views - np.where(np.isfinite(fewest), fewest, 0.0)
    return (np.where(reachable, states.values - beyond, 0.0).astype(np.float32),
            reachable.astype(np.float32))


def pretrain(model: CandidateDQN, config: Config, seed: int, run_dir: Path,
             progress: bool = False) -> dict[str, list[float]]:
    """Collect the teacher's states and fit the model to them; the fit's log (`fit`) goes to
    `run_dir/pretrain.csv`."""
    agent = config.agent
    states = joined_states([collect(config, agent.pretrain_episodes, seed,
                                    teacher_folder(config, run_dir), progress=progress),
                            *more_teacher_states(config)])
    log = fit(model, states, agent.pretrain_epochs, seed, agent.pretrain_target)
    write_text(run_dir / PRETRAIN_FILE, ",".join(["epoch", *log]) + "\n" + "".join(
        ",".join([str(epoch), *(f"{values[epoch - 1]:.6g}" for values in log.values())]) + "\n"
        for epoch in range(1, agent.pretrain_epochs + 1)))
    return log
