"""`vprobot train`: train a SAC, PPO or DQN agent headless, resumably, into a run directory.

A run directory holds everything about one run:

| file | content |
|---|---|
| `config.yaml` | the resolved configuration (profile plus overrides) |
| `command.txt` | the command line, the seed and the vprobot commit |
| `memory.json` | the replay (or rollout) buffer in bytes: per transition and in total |
| `monitor.csv` | a row per training episode: reward, length, coverage, acquisitions, ... |
| `monitor_<rank>.monitor.csv` | the same for the env of each further rank (`agent.n_envs`) |
| `evaluations.csv` | the periodic evaluations on the validation episodes (model selection) |
| `logs/` | stable-baselines3's progress CSV and TensorBoard events, one folder per session |
| `checkpoints/`, `checkpoint.json` | the latest checkpoint (model, replay buffer, episode stream) |
| `best_model.zip`, `final_model.zip` | the best evaluated and the last model |
| `curves.png` | the training curves (`vprobot curves`) |
| `test/<list>/` | the best model on each test list, scored once after training |
| `run.lock` | locked by the process training in the directory (holds its pid) |
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import yaml
from stable_baselines3.common.callbacks import CallbackList
from stable_baselines3.common.logger import configure
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv

from vprobot.agents.candidate_q import CandidateDQN
from vprobot.agents.encoders import check_encoder
from vprobot.agents.models import build_model, check_spaces
from vprobot.agents.trained import ALGORITHMS, load_run_config
from vprobot.cell.fit import check_fits
from vprobot.config import (
    Config,
    ConfigError,
    config_document,
    load_config,
    parse_yaml,
    replace,
)
from vprobot.env.actions import ActionMapping
from vprobot.env.inspect_env import InspectEnv
from vprobot.env.observations import observation_space
from vprobot.episode import read_episode_list
from vprobot.episode.specs import bundled_episode_list, validation_episodes
from vprobot.evaluation import evaluate
from vprobot.extensions import plugins
from vprobot.files.atomic import atomic_output, exclusive_lock, refuse_link, write_text
from vprobot.files.paths import PACKAGE_DIR
from vprobot.kinematics import TRAVEL_COSTS
from vprobot.parts.generated import is_generated
from vprobot.parts.loading import load_mesh
from vprobot.training.callbacks import (
    ResumableCheckpoint,
    SharedEpisodeEvaluation,
    load_buffer,
    read_checkpoint,
    truncate_lines,
    upgrade_evaluations,
)
from vprobot.training.curves import NoEpisodesError, plot_curves
from vprobot.training.evaluation import evaluation_env
from vprobot.training.pretrain import pretrain
from vprobot.training.runs import RESULT_FILE, best_validation
from vprobot.training.stream import EpisodeStream
from vprobot.training.teacher import check_teacher_reward

MONITOR_KEYS = ("coverage", "acquisitions", "reachable_share",
                *(f"travel_sum_{name}" for name in TRAVEL_COSTS))
"""Info entries the per-episode monitor records at each episode's end."""
LOCK_FILE = "run.lock"
"""Held (flock) by the process training in a run directory, with its pid."""
MESH_SCALE_KEY = "env.mesh_scale"
"""How a training config sets the scale of its mesh file, for the hints of unit mistakes."""
MEMORY_LIMIT_BYTES = 8 * 1024**3
"""No profile may need more than this for its buffer (issue: 8 GB)."""


def _space_bytes(space: Any) -> int:
    if hasattr(space, "spaces"):
        return sum(_space_bytes(item) for item in space.spaces.values())
    return int(np.prod(space.shape)) * np.dtype(space.dtype).itemsize


def buffer_memory(config: Config) -> dict[str, Any]:
    """The agent's buffer in bytes, from the observation and action spaces.

    The replay buffer of SAC and DQN stores an observation and the next one per transition,
    the action (float32 each for SAC, one int64 candidate index for DQN), the reward and two
    flags (float32 each); PPO's rollout buffer one observation, the action and five float32
    (reward, return, advantage, value, log-probability) per env step.
    """
    agent = config.agent
    observation = _space_bytes(observation_space(config))
    action = (np.dtype(np.int64).itemsize if agent.algorithm == "dqn"
              else 4 * ActionMapping(config.env, config.sensor.working_distance_m).size)
    if issubclass(ALGORITHMS[agent.algorithm], OffPolicyAlgorithm):
        per_transition = 2 * observation + action + 3 * 4
        transitions = agent.buffer_size
    else:
        per_transition = observation + action + 5 * 4
        transitions = agent.n_steps * agent.n_envs
    return {"algorithm": agent.algorithm, "observation_bytes": observation,
            "bytes_per_transition": per_transition, "transitions": transitions,
            "total_bytes": per_transition * transitions}


def check_memory(config: Config) -> dict[str, Any]:
    """The buffer size, refused above `MEMORY_LIMIT_BYTES`.

    Raises:
        ConfigError: If the buffer would need more.
    """
    memory = buffer_memory(config)
    if memory["total_bytes"] > MEMORY_LIMIT_BYTES:
        raise ConfigError(f"the {memory['algorithm']} buffer would need "
                          f"{memory['total_bytes'] / 1024**3:.1f} GiB (> 8 GiB): lower "
                          f"agent.buffer_size or env.state_points")
    return memory


def resolve_device(device: str) -> str:
    """`cpu`, `cuda` (checked to exist) or `auto` (cuda when present).

    Raises:
        ValueError: For cuda on a machine without it.
    """
    if device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if device == "cuda" and not torch.cuda.is_available():
        raise ValueError("--device cuda: no CUDA device on this machine; use cpu or auto")
    return device


def env_factory(config: Config, seed: int, rank: int, start: int,
                monitor: Path | None) -> Callable[[], Monitor]:
    """A function making one training env: the inspect env, its episode stream, a monitor."""

    def make() -> Monitor:
        stream = EpisodeStream(InspectEnv(config), seed, rank, start)
        # A new file gets the monitor's header; a resumed run appends to its file.
        fresh = monitor is None or not monitor.exists()
        return Monitor(stream, filename=None if monitor is None else str(monitor),
                       info_keywords=MONITOR_KEYS, override_existing=fresh)

    return make


def monitor_file(rank: int) -> str:
    """The monitor file of the env of `rank` (SB3's Monitor appends `.monitor.csv` to a name
    that does not end with it)."""
    return "monitor.csv" if rank == 0 else f"monitor_{rank}.monitor.csv"


def make_vec_env(config: Config, seed: int, starts: Sequence[int],
                 monitor_dir: Path | None) -> VecEnv:
    """The run's envs: one in-process, several in subprocesses (one monitor file each), which
    load this process's plugins (`vprobot.extensions.plugins.in_child`) before they make their
    env."""
    factories: list[Callable[[], gym.Env]] = [
        env_factory(config, seed, rank, start,
                    None if monitor_dir is None else monitor_dir / monitor_file(rank))
        for rank, start in enumerate(starts)]
    if len(factories) == 1:
        return DummyVecEnv(factories)
    return SubprocVecEnv([plugins.in_child(factory) for factory in factories])


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                              cwd=PACKAGE_DIR, timeout=10).stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def check_environment(config: Config) -> None:
    """Check what the run will need before a run folder is touched: the encoder, the env
    settings, that the algorithm can act in the env's spaces and every part file episodes draw
    from (it loads and fits the cell; generated objects are made later).

    Raises:
        FileNotFoundError, ValueError, ConfigError: For a missing or unusable part file, an
            encoder not registered or not serving the algorithm, env settings that do not make
            an env, or an algorithm that cannot act in it.
    """
    check_encoder(config.agent)
    env = config.env
    scale = env.mesh_scale if env.parts == "mesh" else 1.0
    inspect_env = InspectEnv(config)
    check_spaces(config.agent, inspect_env.observation_space, inspect_env.action_space)
    if config.agent.pretrain_episodes:
        check_teacher_reward(env)
    # Generated objects fit by construction (their families' tests check it) and are made only
    # when an episode draws them.
    for path in inspect_env.part_files:
        if not is_generated(str(path)):
            check_fits(load_mesh(path, scale, scale_option=MESH_SCALE_KEY), config,
                       scale_option=MESH_SCALE_KEY)


def start_run(config: Config, run_dir: Path, seed: int, argv: Sequence[str]) -> None:
    """Write a new run's config, command line and memory figures into its (locked) directory.

    Raises:
        ValueError: If the directory already holds a run (resume it, or choose another).
    """
    refuse_existing_run(run_dir)
    write_text(run_dir / "config.yaml", yaml.safe_dump(config_document(config),
                                                        sort_keys=False))
    write_text(run_dir / "command.txt", f"{' '.join(argv)}\nseed: {seed}\n"
                                        f"commit: {_commit()}\nstarted: {time.ctime()}\n")
    write_text(run_dir / "memory.json", json.dumps(buffer_memory(config), indent=1) + "\n")
    write_text(run_dir / "run.json", json.dumps({"seed": seed, "started": time.time()}) + "\n")


def holds_run(run_dir: Path) -> bool:
    """Whether `run_dir` holds a started run: `run.json`, the last file `start_run` writes, is
    there (a start killed before it is started again from scratch)."""
    return (run_dir / "run.json").is_file()


def refuse_existing_run(run_dir: Path) -> None:
    """Raise ValueError if `run_dir` already holds a run."""
    if holds_run(run_dir):
        raise ValueError(f"{run_dir} already holds a run; add --resume to go on with it, or "
                         f"choose another --out")


def train(config: Config | None, run_dir: str | Path, seed: int = 0, resume: bool = False,
          device: str | None = None, progress: bool = True,
          argv: Sequence[str] = ()) -> dict[str, Any]:
    """Train (or resume) one run.

    Every check (config, device, buffer memory, part files) comes before the run directory is
    created; the directory is then locked (`run.lock`) for the whole run, so a second train or
    resume of it is refused while this one lives.

    Args:
        config: The resolved configuration (ignored on resume: the run's own is used).
        run_dir: The run directory.
        seed: Seed of the model and of the episode stream (the run's own on resume).
        resume: Go on from the run's latest checkpoint.
        device: Overrides `agent.device`.
        progress: Show a progress bar and print the memory figures.
        argv: The command line, recorded in the run directory.

    Returns:
        The final evaluation summary on the validation episodes, plus `steps`, `wall_s`,
        `curves` (the curves.png written, None before the first finished episode) and `best`:
        the evaluation of `best_model.zip`, the model selected (`runs.best_validation`).

    Raises:
        ValueError, ConfigError: For a bad config, a run directory in the wrong state or in use
            by another process, a device that is not there, or an unusable part file.
    """
    run_dir = Path(run_dir)
    if resume:
        config = load_run_config(run_dir)
        if not holds_run(run_dir):
            raise ValueError(f"{run_dir} holds no started run: its start was interrupted "
                             f"before run.json was written; train it again without --resume")
    elif config is None:
        raise ValueError("a new run needs a config")
    else:
        refuse_existing_run(run_dir)
    device = resolve_device(device or config.agent.device)
    memory = check_memory(config)
    check_environment(config)
    run_dir.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(run_dir / LOCK_FILE, str(run_dir)):
        if resume:
            run = json.loads((run_dir / "run.json").read_text())
            seed, clock_start = run["seed"], run["started"]
        else:
            start_run(config, run_dir, seed, argv)
            clock_start = time.time()
        if progress:
            print(f"{memory['algorithm']} buffer: {memory['bytes_per_transition']:,} bytes per "
                  f"transition x {memory['transitions']:,} = "
                  f"{memory['total_bytes'] / 1024**2:,.0f} MiB")
        return _train_locked(config, run_dir, seed, resume, device, progress, clock_start)


def _train_locked(config: Config, run_dir: Path, seed: int, resume: bool, device: str,
                  progress: bool, clock_start: float) -> dict[str, Any]:
    """The training itself, in a run directory this process holds the lock of."""
    agent = config.agent
    torch.set_num_threads(agent.torch_threads)
    # Every env's monitor: a resumed run cuts each back to its checkpoint.
    logs = [*(run_dir / monitor_file(rank) for rank in range(agent.n_envs)),
            run_dir / "evaluations.csv"]
    for log in logs:
        refuse_link(log)  # the monitors open their files themselves
    checkpoint = read_checkpoint(run_dir) if resume else None
    starts = [0] * agent.n_envs
    if checkpoint is not None:
        for log in logs:
            truncate_lines(log, checkpoint["log_lines"].get(log.name, 0))
        upgrade_evaluations(run_dir / "evaluations.csv")
        starts = checkpoint["episodes_started"]
    elif resume:
        for log in logs:
            log.unlink(missing_ok=True)
    env = make_vec_env(config, seed, starts, run_dir)
    if checkpoint is not None:
        model = ALGORITHMS[agent.algorithm].load(
            run_dir / "checkpoints" / checkpoint["model"], env=env, device=device)
        buffer = checkpoint["buffer"]
        # Only an off-policy model's checkpoint names a buffer, which loading it set up.
        if buffer is not None and isinstance(model, OffPolicyAlgorithm):
            if buffer.endswith(".pkl"):
                # A checkpoint written before buffers were saved as their filled part.
                model.load_replay_buffer(run_dir / "checkpoints" / buffer)
            elif model.replay_buffer is not None:
                load_buffer(model.replay_buffer, run_dir / "checkpoints" / buffer)
    else:
        model = build_model(config, env, seed, device)
    pretrained = checkpoint is None and agent.pretrain_episodes > 0
    if pretrained:
        assert isinstance(model, CandidateDQN)  # AgentConfig pretrains dqn only
        pretrain(model, config, seed, run_dir, progress)
    sessions = sorted((run_dir / "logs").glob("session_*")) if (run_dir / "logs").is_dir() else []
    model.set_logger(configure(str(run_dir / "logs" / f"session_{len(sessions)}"),
                               ["csv", "tensorboard"]))
    specs = validation_episodes(config)[: agent.eval_episodes]
    evaluation = SharedEpisodeEvaluation(evaluation_env(config), specs, run_dir,
                                         agent.eval_freq, clock_start, agent.select)
    if pretrained:
        # The imitation alone, as step 0 of the curve: RL must do better to replace it.
        evaluation.evaluate_model(model)
    checkpoints = ResumableCheckpoint(run_dir, agent.checkpoint_freq, logs)
    remaining = agent.total_steps - model.num_timesteps
    if remaining <= 0 and resume and progress:
        print(f"{run_dir} has finished: it trained its {agent.total_steps:,} steps "
              f"(agent.total_steps) already; nothing more to train")
    if remaining > 0:
        model.learn(remaining, callback=CallbackList([evaluation, checkpoints]),
                    reset_num_timesteps=checkpoint is None, progress_bar=progress)
        checkpoints.save()
    env.close()
    with atomic_output(run_dir / "final_model.zip") as temporary:
        model.save(temporary)
    summary = evaluation.latest if evaluation.latest_step == model.num_timesteps else (
        evaluation.evaluate_model(model))
    try:
        curves: Path | None = plot_curves([run_dir], run_dir / "curves.png")
    except NoEpisodesError:
        curves = None
    return {**summary, "steps": model.num_timesteps, "wall_s": time.time() - clock_start,
            "curves": curves, "best": best_validation(run_dir, agent.select)}


def train_to_result(config_of: Callable[[], Config], run_dir: Path, seed: int,
                    argv: Sequence[str], device: str | None = None,
                    progress: bool = False) -> dict[str, Any]:
    """Train a run into `run_dir`, or resume the one it holds, then write the result into
    `RESULT_FILE`, which marks the run finished.

    Args:
        config_of: Gives the configuration of a new run (not called when resuming, which
            reads the run's own).
        run_dir: The run directory.
        seed: The run's seed.
        argv: The command line the run records.
        device: Overrides `agent.device`.
        progress: Show the progress bar.
    """
    resume = holds_run(run_dir)
    result = train(None if resume else config_of(), run_dir, seed=seed, resume=resume,
                   device=device, progress=progress, argv=argv)
    # default=str: the result names its curves.png as a Path.
    write_text(run_dir / RESULT_FILE, json.dumps(result, indent=1, default=str) + "\n")
    return result


def score_test_lists(config: Config, run_dir: Path, progress: bool = False) -> list[Path]:
    """Score a finished run's best model once on each of `agent.test_lists`, with the run's
    carrier, into `test/<list>/` (the tables of `vprobot evaluate`; a rerun resumes them).
    Training itself never reads a test list.

    Returns:
        The folders written.
    """
    folders = []
    for name in config.agent.test_lists or ():
        folder = run_dir / "test" / name
        evaluate(config, [f"agent:{run_dir}"], read_episode_list(bundled_episode_list(name)),
                 folder, progress=progress, carriers=[config.env.carrier])
        folders.append(folder)
    return folders


def parse_overrides(pairs: Sequence[str]) -> dict[str, dict[str, Any]]:
    """`section.key=value` pairs (values in YAML) grouped by section.

    Raises:
        ConfigError: For a pair without `section.key=`.
    """
    sections: dict[str, dict[str, Any]] = {}
    for pair in pairs:
        key, separator, text = pair.partition("=")
        section, dot, name = key.partition(".")
        if not separator or not dot or not section or not name:
            raise ConfigError(f"override {pair!r} must look like section.key=value, e.g. "
                              f"env.state=s_bin or agent.algorithm=ppo")
        sections.setdefault(section, {})[name] = parse_yaml(text, f"override {pair!r}")
    return sections


def profile_config(profile: str | Path, overrides: Sequence[str] = (),
                   steps: int | None = None) -> Config:
    """A profile YAML (any config sections, `agent` among them) with `section.key=value`
    overrides and `--steps` applied, validated, its encoder too (`check_encoder`: what
    `train`, `teacher` and a sweep's trials start from).

    Raises:
        FileNotFoundError, ConfigError: For a missing profile or a bad key or value.
    """
    config = load_config(profile)
    for section, changes in parse_overrides(overrides).items():
        if section not in {field.name for field in dataclasses.fields(Config)}:
            raise ConfigError(f"unknown config section {section!r} in an override; allowed: "
                              f"{', '.join(field.name for field in dataclasses.fields(Config))}")
        config = replace(config, section, **changes)
    if steps is not None:
        config = replace(config, "agent", total_steps=steps)
    check_encoder(config.agent)
    return config

