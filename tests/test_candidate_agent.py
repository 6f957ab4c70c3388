"""The candidate-view agent (DQN, `vprobot.agents.candidate_q`), mostly on a toy env of the
same kind of spaces: the Q-network's permutation equivariance, masking (greedy and exploration,
brute force), config and space checks, a small training that learns the toy's best candidate,
and two env processes; on the inspect env's own spaces (`A_view`, `s_grid`), the buffer's
memory against SB3's allocation, and save and load."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from vprobot.agents.candidate_q import MASKED_Q, CandidateDQN, CandidateQNetwork
from vprobot.agents.trained import load_agent
from vprobot.config import Config, ConfigError, replace
from vprobot.env.inspect_env import InspectEnv
from vprobot.files.paths import CONFIGS_DIR
from vprobot.training.train import (
    buffer_memory,
    build_model,
    check_memory,
    config_document,
    profile_config,
    train,
)

COUNT, FEATURES = 8, 3
DQN_AGENT = {"algorithm": "dqn", "encoder": "candidates", "net_arch": (16, 16),
             "learning_rate": 3e-3, "learning_rate_schedule": "constant", "gamma": 0.5,
             "batch_size": 32, "buffer_size": 400, "learning_starts": 50,
             "target_update_interval": 50, "exploration_fraction": 0.5,
             "exploration_final_eps": 0.05}


def candidate_space(robot: bool) -> gym.spaces.Dict:
    spaces = {"candidates": gym.spaces.Box(-1, 1, (COUNT, FEATURES), np.float32),
              "mask": gym.spaces.Box(0, 1, (COUNT,), np.float32)}
    if robot:
        spaces["robot"] = gym.spaces.Box(-1, 1, (2,), np.float32)
    return gym.spaces.Dict(spaces)


def random_observations(rng: np.random.Generator, count: int, robot: bool = False,
                        rows: tuple[int, int] = (COUNT, FEATURES)) -> dict[str, np.ndarray]:
    """`count` observations of `rows` (candidates, features): uniform rows, masks of random
    density with one candidate or more allowed."""
    masks = rng.random((count, rows[0])) < rng.uniform(0.1, 0.9, (count, 1))
    masks[np.arange(count), rng.integers(0, rows[0], count)] = True
    observations = {"candidates": rng.uniform(-1, 1, (count, *rows)).astype(np.float32),
                    "mask": masks.astype(np.float32)}
    if robot:
        observations["robot"] = rng.uniform(-1, 1, (count, 2)).astype(np.float32)
    return observations


class ToyCandidateEnv(gym.Env):
    """One request per episode among `COUNT` candidates; candidate k pays its first feature.

    A masked request raises: any training that requests one fails.
    """

    def __init__(self, robot: bool = False):
        self.observation_space = candidate_space(robot)
        self.action_space = gym.spaces.Discrete(COUNT)
        self.robot = robot
        self.observation: dict[str, np.ndarray] = {}

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict[str, np.ndarray], dict]:
        super().reset(seed=seed)
        batch = random_observations(self.np_random, 1, self.robot)
        self.observation = {key: value[0] for key, value in batch.items()}
        return self.observation, {}

    def step(self, action: int) -> tuple[dict[str, np.ndarray], float, bool, bool, dict]:
        if self.observation["mask"][action] != 1:
            raise AssertionError(f"masked candidate {action} requested")
        return self.observation, float(self.observation["candidates"][action, 0]), True, False, {}


class ToyBoxEnv(gym.Env):
    """A continuous-action, point-cloud env: not one DQN can act in."""

    observation_space = gym.spaces.Box(-1, 1, (16, 3), np.float32)
    action_space = gym.spaces.Box(-1, 1, (2,), np.float32)


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread() -> Iterator[None]:
    """One thread, as training sets it (`agent.torch_threads`): two threads on two busy cores
    made the trained fixture 15 times slower."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def dqn_config(**changes: Any) -> Config:
    return replace(Config(), "agent", **{**DQN_AGENT, **changes})


def candidate_config(robot: bool, **changes: Any) -> Config:
    """`dqn_config` with the inspect env's candidate views (`A_view`, `s_grid`)."""
    return replace(dqn_config(**changes), "env", action="A_view", state="s_grid",
                   robot_state=robot)


REAL_ROWS = (128, 19)
"""The inspect env's candidate rows with the paper's sensor: the 128 band candidates, 19 features
each (`grid_state.FEATURES`)."""


@pytest.fixture(scope="module")
def trained() -> CandidateDQN:
    """A DQN trained 400 steps on the toy env (about 350 gradient steps)."""
    model = build_model(dqn_config(), DummyVecEnv([ToyCandidateEnv]), seed=3, device="cpu")
    return model.learn(400)


def _regrets(model: CandidateDQN, observations: dict[str, np.ndarray]) -> tuple[float, float]:
    """Mean regret of the greedy choice and of a uniform allowed choice, from the toy's
    rewards."""
    values = np.where(observations["mask"] > 0, observations["candidates"][..., 0], np.nan)
    best = np.nanmax(values, axis=1)
    actions, _ = model.predict(observations, deterministic=True)
    chosen = values[np.arange(len(actions)), actions]
    return float(np.mean(best - chosen)), float(np.mean(best - np.nanmean(values, axis=1)))


def test_training_on_the_toy_env_learns_to_choose_the_best_candidate(
        trained: CandidateDQN) -> None:
    observations = random_observations(np.random.default_rng(11), 300)
    greedy, uniform = _regrets(trained, observations)
    assert uniform > 0.4
    assert greedy < 0.15 * uniform, (greedy, uniform)


def test_permuting_the_candidates_permutes_the_q_values() -> None:
    torch.manual_seed(0)
    network = CandidateQNetwork(candidate_space(robot=True), gym.spaces.Discrete(COUNT), [8, 8])
    observations = random_observations(np.random.default_rng(1), 5, robot=True)
    permutation = np.random.default_rng(2).permutation(COUNT)
    permuted = {**observations, "candidates": observations["candidates"][:, permutation],
                "mask": observations["mask"][:, permutation]}
    with torch.no_grad():
        values = network({key: torch.as_tensor(value) for key, value in observations.items()})
        values_permuted = network({key: torch.as_tensor(value)
                                   for key, value in permuted.items()})
    allowed = observations["mask"] > 0
    assert np.ptp(values.numpy()[allowed]) > 1e-3  # the rows do get different values
    np.testing.assert_allclose(values_permuted.numpy(), values.numpy()[:, permutation],
                               rtol=1e-5, atol=1e-6)


def test_no_masked_candidate_is_ever_chosen_greedily_or_in_exploration() -> None:
    model = build_model(dqn_config(), DummyVecEnv([ToyCandidateEnv]), seed=0, device="cpu")
    observations = random_observations(np.random.default_rng(5), 2000)
    rows = np.arange(2000)
    greedy, _ = model.predict(observations, deterministic=True)
    assert np.all(observations["mask"][rows, greedy] == 1)
    model.exploration_rate = 1.0
    explored, _ = model.predict(observations, deterministic=False)
    assert np.all(observations["mask"][rows, explored] == 1)
    # Before learning_starts SB3 draws warm-up actions itself.
    model._last_obs = observations
    warmup, stored = model._sample_action(learning_starts=10**6, n_envs=2000)
    assert np.all(observations["mask"][rows, warmup] == 1) and np.array_equal(warmup, stored)
    # One observation at a time: exploration reaches every allowed candidate and nothing else.
    single = {key: value[0] for key, value in observations.items()}
    drawn = {int(model.predict(single, deterministic=False)[0]) for _ in range(300)}
    assert drawn == set(np.flatnonzero(single["mask"]))


def test_exploration_refuses_an_observation_that_is_not_a_candidate_dict() -> None:
    model = build_model(dqn_config(), DummyVecEnv([ToyCandidateEnv]), seed=0, device="cpu")
    masks = random_observations(np.random.default_rng(5), 4)["mask"]
    with pytest.raises(TypeError, match="a candidate-view observation is a dict"):
        model.random_actions(masks)


def test_a_state_with_no_allowed_candidate_keeps_finite_q_values() -> None:
    network = CandidateQNetwork(candidate_space(robot=False), gym.spaces.Discrete(COUNT), [8, 8])
    observations = random_observations(np.random.default_rng(0), 2)
    observations["mask"][0] = 0.0
    with torch.no_grad():
        values = network({key: torch.as_tensor(value) for key, value in observations.items()})
    assert torch.all(values[0] > MASKED_Q / 2)
    assert torch.all((values[1] == MASKED_Q) == torch.as_tensor(observations["mask"][1] == 0))


@pytest.mark.parametrize(("changes", "message"), [
    ({"encoder": "candidates"}, "agent.encoder 'candidates' serves agent.algorithm ['dqn'], got "
                                "'sac'; agent.algorithm 'sac' takes agent.encoder ['pcn', "
                                "'pointnet', 'sphere']"),
    ({"algorithm": "dqn"}, "agent.encoder 'pcn' serves agent.algorithm ['sac', 'ppo'], got "
                           "'dqn'; agent.algorithm 'dqn' takes agent.encoder ['candidates']"),
])
def test_an_encoder_serving_another_algorithm_is_refused_where_the_model_is_built(
        changes: dict[str, Any], message: str) -> None:
    # The config loads: it does not read the encoders, whose modules import torch.
    config = replace(Config(), "agent", **changes)
    with pytest.raises(ConfigError, match=re.escape(message)):
        build_model(config, DummyVecEnv([ToyCandidateEnv]), seed=0, device="cpu")


@pytest.mark.parametrize(("changes", "message"), [
    ({**DQN_AGENT, "exploration_fraction": 0.0},
     "agent.exploration_fraction must lie in (0, 1], got 0.0"),
    ({**DQN_AGENT, "exploration_initial_eps": 0.2, "exploration_final_eps": 0.5},
     "agent needs 0 <= exploration_final_eps <= exploration_initial_eps <= 1, got 0.5, 0.2"),
    ({**DQN_AGENT, "target_update_interval": 0},
     "agent.target_update_interval must be >= 1, got 0"),
])
def test_bad_dqn_settings_are_clear_errors(changes: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        replace(Config(), "agent", **changes)


def test_algorithms_refuse_envs_they_cannot_act_in(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=re.escape("agent.algorithm dqn needs an env that "
                                                    "chooses among candidate views (env.action: "
                                                    "A_view, env.state: s_grid")):
        build_model(dqn_config(), DummyVecEnv([ToyBoxEnv]), seed=0, device="cpu")
    with pytest.raises(ConfigError, match=re.escape("needs agent.algorithm dqn with "
                                                    "agent.encoder candidates")):
        build_model(Config(), DummyVecEnv([ToyCandidateEnv]), seed=0, device="cpu")
    # The inspect env of the default settings has a continuous action: refused before the
    # run folder is made.
    with pytest.raises(ConfigError, match=re.escape("env.action: A_view")):
        train(dqn_config(), tmp_path / "run", progress=False)
    assert not (tmp_path / "run").exists()


def test_buffer_memory_is_what_the_dqn_replay_buffer_allocates() -> None:
    config = candidate_config(robot=True, buffer_size=64)
    buffer = build_model(config, DummyVecEnv([lambda: InspectEnv(config)]), seed=0,
                         device="cpu").replay_buffer
    allocated = sum(array.nbytes for name in ("observations", "next_observations")
                    for array in getattr(buffer, name).values())
    allocated += sum(getattr(buffer, name).nbytes
                     for name in ("actions", "rewards", "dones", "timeouts"))
    assert check_memory(config)["total_bytes"] == allocated
    # Candidates, mask and the UR10's robot state (15) twice (float32), an int64 action, reward
    # and two flags.
    assert buffer_memory(config)["bytes_per_transition"] == (
        2 * (REAL_ROWS[0] * REAL_ROWS[1] + REAL_ROWS[0] + 15) * 4 + 8 + 12)
    with pytest.raises(ConfigError, match="the dqn buffer would need"):
        check_memory(candidate_config(robot=True, buffer_size=10**8))


def test_a_saved_dqn_run_loads_with_identical_greedy_actions(tmp_path: Path) -> None:
    config = candidate_config(robot=False)
    model = build_model(config, DummyVecEnv([lambda: InspectEnv(config)]), seed=0,
                        device="cpu")
    # Weights no fresh model of this seed has: a load that built one would act otherwise.
    torch.manual_seed(1)
    with torch.no_grad():
        for parameter in model.q_net.parameters():
            parameter.add_(torch.randn_like(parameter))
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "best_model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump(config_document(config)))
    loaded = load_agent(run)
    assert isinstance(loaded.model, CandidateDQN)
    observations = random_observations(np.random.default_rng(7), 500, rows=REAL_ROWS)
    expected, _ = model.predict(observations, deterministic=True)
    actions, _ = loaded.model.predict(observations, deterministic=True)
    assert np.array_equal(actions, expected)
    assert len(set(expected)) > 1


def test_two_env_processes_train_and_store_only_allowed_requests() -> None:
    # fork: the default start method would import this module (torch, vprobot) per process.
    env = SubprocVecEnv([ToyCandidateEnv, ToyCandidateEnv], start_method="fork")
    try:
        model = build_model(dqn_config(n_envs=2), env, seed=0, device="cpu").learn(120)
    finally:
        env.close()
    buffer = model.replay_buffer
    assert model.num_timesteps >= 120 and buffer.n_envs == 2 and buffer.pos >= 60
    actions = buffer.actions[: buffer.pos, :, 0]
    masks = buffer.observations["mask"][: buffer.pos]
    assert np.all(np.take_along_axis(masks, actions[..., None], axis=2) == 1)
    # The two processes drew different candidate sets.
    candidates = buffer.observations["candidates"][: buffer.pos]
    assert not np.array_equal(candidates[:, 0], candidates[:, 1])


@pytest.mark.parametrize("name, target", [("real-cover", "cover"), ("real-views", "views")])
def test_the_cover_profiles_are_the_realistic_one_fitted_to_the_labels_on_its_teacher(
        name: str, target: str) -> None:
    """real-cover.yaml and real-views.yaml differ from real-candidates.yaml only in what the
    imitation fits and the RL steps after it, so that all read one teacher folder."""
    values = profile_config(CONFIGS_DIR / "agents" / "real-candidates.yaml")
    fitted = profile_config(CONFIGS_DIR / "agents" / f"{name}.yaml")
    assert (values.agent.pretrain_target, fitted.agent.pretrain_target) == ("values", target)
    assert fitted.agent.teacher_dir == values.agent.teacher_dir
    assert replace(fitted, "agent", pretrain_target="values",
                   total_steps=values.agent.total_steps) == values


def test_the_paper_cells_cover_profile_is_its_generalist_fitted_to_the_labels() -> None:
    """cpu-cover.yaml differs from cpu-candidates.yaml only in what the imitation fits, the
    teacher folder it fits (the paper cell's own: the realistic cell's states are another
    sensor's), drawn once from its teacher seed, and a shorter RL run on one env, so that two
    seeds train at once."""
    values = profile_config(CONFIGS_DIR / "agents" / "cpu-candidates.yaml")
    fitted = profile_config(CONFIGS_DIR / "agents" / "cpu-cover.yaml")
    assert (values.agent.pretrain_target, fitted.agent.pretrain_target) == ("values", "cover")
    assert fitted.agent.teacher_dir not in (
        values.agent.teacher_dir, profile_config(CONFIGS_DIR / "agents" /
                                                 "real-cover.yaml").agent.teacher_dir)
    assert fitted.agent.n_envs == 1 < values.agent.n_envs
    assert fitted.agent.total_steps < values.agent.total_steps
    assert replace(fitted, "agent", pretrain_target="values", teacher_seed=None, teacher_dir=None,
                   n_envs=values.agent.n_envs, total_steps=values.agent.total_steps) == values


def test_the_candidate_profile_loads_pretrains_a_dqn_and_passes_the_memory_check() -> None:
    config = profile_config(CONFIGS_DIR / "agents" / "cpu-candidates.yaml")
    agent = config.agent
    assert (agent.algorithm, agent.encoder, config.env.action, config.env.state,
            config.env.reward) == ("dqn", "candidates", "A_view", "s_grid", "R2")
    assert agent.pretrain_episodes > 0 and agent.n_envs == 2
    assert check_memory(config)["total_bytes"] < 2**30
