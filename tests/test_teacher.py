"""The candidate agent's teacher and the imitation before RL (`agent.pretrain_episodes`)."""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
import yaml
from stable_baselines3.common.vec_env import DummyVecEnv

from vprobot.agents.trained import load_agent
from vprobot.config import Config, ConfigError, config_document, replace
from vprobot.env.grid_state import FEATURES
from vprobot.env.grid_state import VERSION as GRID_STATE_VERSION
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode.views import BAND_COUNT, screen_reachability
from vprobot.files.paths import MOTORS_DIR
from vprobot.planners.candidates import candidate_views
from vprobot.training.pretrain import (
    LABELS_VERSION,
    TeacherStates,
    collect,
    fit,
    fit_labels,
    joined_states,
    more_teacher_states,
)
from vprobot.training.stream import EpisodeStream
from vprobot.training.teacher import WASTED, CandidateTeacher
from vprobot.training.train import build_model, train

ENV = {"action": "A_view", "state": "s_grid", "parts": "mesh",
       "mesh": str(MOTORS_DIR / "train" / "motor_000.stl"), "resolution": (96, 67)}
AGENT = {"algorithm": "dqn", "encoder": "candidates", "net_arch": (32, 32), "batch_size": 16,
         "learning_rate": 3e-3, "buffer_size": 1000}


def config(carrier: str = "robot", **agent: object) -> Config:
    return replace(replace(Config(), "env", carrier=carrier, **ENV), "agent",
                   **{**AGENT, **agent})


TRAINING_RESOLUTION = (320, 224)
"""cpu.yaml's: fine enough for an acquisition to cover what the renderer predicts it sees."""


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread() -> Iterator[None]:
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def test_the_teachers_best_value_is_the_coverage_its_request_then_adds() -> None:
    """The env's step measures the gain itself: the teacher's confirmation must agree."""
    env = InspectEnv(replace(config("free"), "env", resolution=TRAINING_RESOLUTION))
    env.reset(seed=5)
    teacher = CandidateTeacher()
    teacher.reset(env.episode)
    for _ in range(2):
        values = teacher.values(env.episode)
        best = int(np.argmax(values))
        before = env.episode.coverage
        env.step(best)
        assert env.episode.coverage - before == pytest.approx(values[best], abs=1e-6)
        # The view just taken has next to nothing left to add.
        assert teacher.values(env.episode)[best] < 0.02


def test_candidates_the_robot_cannot_take_are_worth_a_wasted_request() -> None:
    env = InspectEnv(config("robot"))
    env.reset(seed=5)
    teacher = CandidateTeacher()
    teacher.reset(env.episode)
    values = teacher.values(env.episode)
    unusable = ~teacher._views.usable
    assert unusable.any() and np.all(values[unusable] == WASTED)
    assert np.all(values[~unusable] >= 0.0) and values[~unusable].max() > 0.0
    # Its own screening is the state's: the same candidates, the same configurations.
    joints, _ = env.observer.grid_state.screening(env.episode)
    np.testing.assert_array_equal(teacher._views.joints, joints)


def test_collecting_teacher_states_screens_each_episode_once(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    screenings = []

    def counted(*args: object) -> tuple:
        screenings.append(args)
        return screen_reachability(*args)

    monkeypatch.setattr("vprobot.episode.views.screen_reachability", counted)
    monkeypatch.setattr("vprobot.planners.candidates.screen_reachability", counted)
    states = collect(config("robot"), episodes=1, seed=0, folder=tmp_path)
    assert len(screenings) == 1 and len(states) >= 1
    # The candidates the state shows unreachable are the ones the teacher values as wasted.
    unreachable = states.observations["candidates"][:, :, FEATURES.index("reachable")] == 0
    np.testing.assert_array_equal(states.values == WASTED, unreachable)


def test_the_fitted_q_network_picks_candidates_nearly_as_good_as_the_teachers_best(
        tmp_path: Path) -> None:
    cfg = config("free")
    states = collect(cfg, episodes=2, seed=0, folder=tmp_path)
    model = build_model(cfg, DummyVecEnv([lambda: InspectEnv(cfg)]), seed=0, device="cpu")
    losses = fit(model, states, epochs=150, seed=0)["mse"]
    assert losses[-1] < 0.2 * losses[0]
    q_net, target = model.policy.q_net, model.policy.q_net_target
    assert all(torch.equal(a, b) for a, b in zip(q_net.state_dict().values(),
                                                  target.state_dict().values(), strict=True))
    actions, _ = model.predict(states.observations, deterministic=True)
    allowed = states.observations["mask"] > 0.5
    values = np.where(allowed, states.values, np.nan)
    best = np.nanmax(values, axis=1)
    chosen = states.values[np.arange(len(actions)), actions]
    regret, uniform_regret = np.mean(best - chosen), np.mean(best - np.nanmean(values, axis=1))
    assert regret < 0.35 * uniform_regret, (regret, uniform_regret)


def _fewest_by_enumeration(rows: np.ndarray, covered: np.ndarray, needed: int,
                           most: int) -> tuple[int | None, int]:
    """The fewest of `rows` (candidates, points) adding `needed` points to `covered`, by
    trying every set of 1, 2, ... `most` rows (None if none does), and the most points one row
    adds."""
    seen = rows[:, ~covered]
    best_single = int(seen.sum(axis=1).max())
    for size in range(1, most + 1):
        for chosen in itertools.combinations(range(len(rows)), size):
            if seen[list(chosen)].any(axis=0).sum() >= needed:
                return size, best_single
    return None, best_single


def test_the_remaining_cover_is_the_fewest_views_that_enumeration_finds() -> None:
    """On the measured rows of a state, the label is a smallest set reaching the goal (every
    pair tried when it takes two), and with one view left the row that adds the most."""
    env = InspectEnv(replace(config("free"), "env", resolution=(64, 45)))
    env.reset(seed=3)
    episode = env.episode
    teacher = CandidateTeacher()
    teacher.reset(episode)
    views = candidate_views(episode, BAND_COUNT)
    usable = np.flatnonzero(views.usable)
    rows = np.array([views.measured(int(index), episode) for index in usable])
    covered = episode.covered
    seen = rows[:, ~covered]
    # A goal the best single row misses by a few points, which some pair reaches.
    single = int(seen.sum(axis=1).max())
    goal = (covered.sum() + single + 3) / covered.size
    needed = int(np.ceil(goal * covered.size - 1e-9)) - int(covered.sum())
    fewest, best_single = _fewest_by_enumeration(rows, covered, needed, 2)
    assert fewest == 2
    cover = teacher.remaining_cover(episode, goal, views_left=4)
    assert len(cover.picks) == 2 and cover.goal_reached and cover.views_bound == 2
    assert (rows[np.searchsorted(usable, cover.picks)][:, ~covered].any(axis=0).sum()
            >= needed)
    one = teacher.remaining_cover(episode, goal, views_left=1)
    assert not one.goal_reached and len(one.picks) == 1 and one.points == best_single


def test_the_labels_leave_the_teachers_values_as_they_were() -> None:
    """Measuring every candidate for the labels must not change what the values know: a teacher
    asked for both gives the values of one asked for the values alone, step after step."""
    values: list[list[np.ndarray]] = []
    for label in (False, True):
        env = InspectEnv(replace(config("free"), "env", resolution=(64, 45)))
        env.reset(seed=4)
        teacher = CandidateTeacher()
        teacher.reset(env.episode)
        values.append([])
        for _ in range(3):
            values[-1].append(teacher.values(env.episode))
            if label:
                teacher.remaining_cover(env.episode, 0.9, 5)
            env.step(int(np.argmax(values[-1][-1])))
    for alone, labelled in zip(*values, strict=True):
        np.testing.assert_array_equal(alone, labelled)


def test_the_cover_labels_hold_every_candidate_of_some_smallest_cover() -> None:
    """Hand-made views to the goal: `cover` marks every candidate with the fewest (the state's
    one cover where the goal is out of reach), `views` fits the value minus the views beyond the
    fewest where finite."""
    inf = np.inf
    views = np.array([[2, 3, 2, inf], [inf, inf, inf, inf]], dtype=np.float32)
    values = np.array([[0.1, 0.3, 0.2, -1.0], [0.0, 0.2, 0.1, -1.0]], dtype=np.float32)
    cover = np.array([[True, False, False, False], [False, True, True, False]])
    states = TeacherStates({}, values, cover, np.array([True, False]), np.array([True, False]),
                           views)
    members, where = fit_labels(states, "cover")
    np.testing.assert_array_equal(members, [[1, 0, 1, 0], [0, 1, 1, 0]])
    assert where.all()
    targets, where = fit_labels(states, "views")
    np.testing.assert_allclose(targets[0, :3], [0.1, -0.7, 0.2])
    np.testing.assert_array_equal(where, [[1, 1, 1, 0], [0, 0, 0, 0]])
    np.testing.assert_array_equal(fit_labels(states, "values")[0], values)


@pytest.fixture(scope="module")
def labelled_states(tmp_path_factory: pytest.TempPathFactory) -> TeacherStates:
    """The teacher's states of one episode in the free cell, with their labels."""
    return collect(config("free"), episodes=1, seed=0, folder=tmp_path_factory.mktemp("teacher"))


@pytest.mark.parametrize("target", ["cover", "views"])
def test_a_network_fitted_to_the_labels_of_a_toy_state_chooses_a_candidate_with_the_fewest_views(
        labelled_states: TeacherStates, target: str) -> None:
    """`agent.pretrain_target: cover` or `views`: fitted to the labels of three states of an
    episode (those with the fewest members), the policy's choice in each is a member of one of
    its smallest remaining covers, which a uniform allowed choice is far less often."""
    cfg = config("free", pretrain_target=target, learning_rate=1e-2)
    states = labelled_states
    allowed = states.observations["mask"] > 0.5
    assert (states.cover & ~allowed).sum() <= (states.cover & allowed).sum()
    assert states.cover_reaches.any()
    fewest = np.where(allowed, states.cover_views, np.inf).min(axis=1, keepdims=True)
    members = allowed & (states.cover_views <= fewest)
    # The one cover the labels name is one of them.
    assert (members | ~states.cover | ~allowed).all()
    first = np.argsort(members.sum(axis=1) / allowed.sum(axis=1), kind="stable")[:3]
    toy = TeacherStates({key: value[first] for key, value in states.observations.items()},
                        states.values[first], states.cover[first], states.cover_reaches[first],
                        states.cover_proven[first], states.cover_views[first])
    model = build_model(cfg, DummyVecEnv([lambda: InspectEnv(cfg)]), seed=0, device="cpu")
    log = fit(model, toy, epochs=600, seed=0, target=target)
    losses = log["bce" if target == "cover" else "mse"]
    assert losses[-1] < 0.2 * losses[0]
    actions, _ = model.predict(toy.observations, deterministic=True)
    assert members[first][np.arange(len(actions)), actions].all()
    uniform = members[first].sum(axis=1) / allowed[first].sum(axis=1)
    assert uniform.mean() < 0.5, uniform
    # The head of the views left: fitted to each state's fewest views (within a quarter view),
    # as its logged error says; the Q-values are those of the same fit without the head.
    observations = {key: torch.as_tensor(value) for key, value in toy.observations.items()}
    q_net = model.policy.q_net
    with torch.no_grad():
        left = q_net.views_left(observations).numpy()
    np.testing.assert_allclose(left, toy.cover_views.min(axis=1), atol=0.25)
    assert log["views_left_mae"][-1] < 0.25 < log["views_left_mae"][0]
    headless = build_model(cfg, DummyVecEnv([lambda: InspectEnv(cfg)]), seed=0, device="cpu")
    headless.policy.q_net.views_left_head = headless.policy.q_net_target.views_left_head = None
    assert list(fit(headless, toy, epochs=600, seed=0, target=target)) == list(log)[:1]
    with torch.no_grad():
        torch.testing.assert_close(headless.policy.q_net(observations), q_net(observations))


def test_pretraining_needs_dqn_and_the_r2_reward(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=re.escape(
            "agent.pretrain_episodes fits a candidate Q-network: it needs agent.algorithm dqn, "
            "got 'sac'")):
        replace(Config(), "agent", pretrain_episodes=3)
    with pytest.raises(ConfigError, match=re.escape("agent.pretrain_episodes must be >= 0")):
        config(pretrain_episodes=-1)
    refused = replace(config(pretrain_episodes=2), "env", reward="R5")
    with pytest.raises(ConfigError, match=re.escape(
            "agent.pretrain_episodes needs env.reward R2 (the teacher's values are R2's "
            "rewards), got env.reward 'R5'")):
        train(refused, tmp_path / "run", progress=False)
    assert not (tmp_path / "run").exists()


def test_a_pretrained_run_evaluates_the_imitation_as_step_0(tmp_path: Path) -> None:
    """With the cover's fit, whose network has the head of the views left: its log and its
    weights come back with the trained agent."""
    cfg = replace(config("free", pretrain_episodes=1, pretrain_epochs=3, total_steps=30,
                         learning_starts=10, eval_freq=1000, eval_episodes=1,
                         checkpoint_freq=1000, test_lists=None, pretrain_target="cover"),
                  "env", resolution=(64, 45))
    train(cfg, tmp_path / "run", progress=False)
    epochs = (tmp_path / "run" / "pretrain.csv").read_text().splitlines()
    assert epochs[0] == "epoch,bce,views_left_mae" and len(epochs) == 4
    assert load_agent(tmp_path / "run").model.policy.q_net.views_left_head is not None
    steps = [line.split(",")[0] for line in
             (tmp_path / "run" / "evaluations.csv").read_text().splitlines()[1:]]
    assert steps == ["0", "30"]


def test_teacher_shards_are_the_same_rolled_out_alone_or_in_two_processes_and_are_shared(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr("vprobot.training.pretrain.SHARD_EPISODES", 1)
    # Episodes of 3 requests (not 10): each state's labels search the remaining cover, the
    # test's cost, and 6 states of two episodes compare the shards as well as 20.
    cfg = replace(config("free", teacher_seed=7), "env", resolution=(64, 45), max_acquisitions=3)
    alone = collect(cfg, episodes=2, seed=0, folder=tmp_path / "alone")
    parallel = collect(cfg, episodes=2, seed=1, folder=tmp_path / "two", workers=2)
    assert sorted(path.name for path in (tmp_path / "two").glob("shard-*")) == [
        "shard-0000-1.npz", "shard-0001-1.npz"]
    for states in (parallel, alone):
        assert states.values.shape[0] == states.observations["mask"].shape[0] > 2
    np.testing.assert_array_equal(alone.values, parallel.values)
    for key, value in alone.observations.items():
        np.testing.assert_array_equal(value, parallel.observations[key])
    # Another run of the same teacher reads the shards; it rolls out nothing.
    monkeypatch.setattr("vprobot.training.pretrain.collect_shard", None)
    again = collect(cfg, episodes=2, seed=2, folder=tmp_path / "two")
    np.testing.assert_array_equal(again.values, alone.values)


def test_a_teacher_folder_of_another_cell_seed_state_or_labels_version_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = replace(config("free", teacher_seed=3), "env", resolution=(64, 45))
    collect(cfg, episodes=1, seed=0, folder=tmp_path)

    def refused(other: Config, differs: str) -> None:
        with pytest.raises(ConfigError, match=re.escape(
                f"{tmp_path} holds the teacher states of another run: its teacher.json differs "
                f"in {differs}; give another agent.teacher_dir")):
            collect(other, episodes=1, seed=0, folder=tmp_path)

    refused(replace(cfg, "agent", teacher_seed=4), "teacher_seed")
    refused(replace(cfg, "env", reward="R1"), "env")
    # States stored before a column changed its meaning are not this state's.
    monkeypatch.setattr("vprobot.training.pretrain.GRID_STATE_VERSION", GRID_STATE_VERSION + 1)
    refused(cfg, "grid_state_version")
    monkeypatch.undo()
    # Shards made before they held the remaining cover lack the labels a cover fit needs.
    monkeypatch.setattr("vprobot.training.pretrain.LABELS_VERSION", LABELS_VERSION + 1)
    refused(cfg, "labels_version")
    with pytest.raises(ConfigError, match=re.escape("agent.teacher_seed must be >= 0")):
        config(teacher_seed=-1)


def test_an_agents_rollouts_follow_its_greedy_choices_and_are_fitted_beside_the_teachers(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`agent.rollout_agent` (DAgger): without exploration, every request of the teacher's
    episodes is the agent's greedy choice in the state before it, not the teacher's best; the
    folder records the agent, and `more_teacher_dirs` adds its states to a run's fit."""
    cfg = replace(config("free", teacher_seed=5), "env", resolution=(64, 45))
    run = tmp_path / "run"
    run.mkdir()
    model = build_model(cfg, DummyVecEnv([lambda: InspectEnv(cfg)]), seed=0, device="cpu")
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump(config_document(cfg)))
    requested: list[int] = []

    class Recorded(EpisodeStream):
        def step(self, action: int) -> Any:
            requested.append(action)
            return super().step(action)

    monkeypatch.setattr("vprobot.training.pretrain.EPSILON", 0.0)
    monkeypatch.setattr("vprobot.training.pretrain.EpisodeStream", Recorded)
    dagger = replace(cfg, "agent", rollout_agent=str(run))
    states = collect(dagger, episodes=1, seed=0, folder=tmp_path / "rollouts")
    greedy, _ = model.predict(states.observations, deterministic=True)
    assert requested == greedy.tolist()
    best = [int(np.argmax(np.where(mask > 0.5, value, -np.inf)))
            for mask, value in zip(states.observations["mask"], states.values, strict=True)]
    assert requested != best
    record = json.loads((tmp_path / "rollouts" / "teacher.json").read_text())
    assert record["rollout_agent"] == hashlib.sha256((run / "model.zip").read_bytes()).hexdigest()

    own = collect(cfg, episodes=1, seed=0, folder=tmp_path / "teacher")
    more = replace(cfg, "agent", more_teacher_dirs=(str(tmp_path / "rollouts"),))
    (extra,) = more_teacher_states(more)
    joined = joined_states([own, extra])
    assert len(joined) == len(own) + len(states)
    np.testing.assert_array_equal(joined.cover_views[len(own):], states.cover_views)
    with pytest.raises(ConfigError, match=re.escape(
            f"agent.more_teacher_dirs: {tmp_path / 'rollouts'} was made for another run: its "
            f"teacher.json differs in env")):
        more_teacher_states(replace(more, "env", reward="R1"))
    with pytest.raises(ConfigError, match="holds no teacher shards"):
        more_teacher_states(replace(cfg, "agent", more_teacher_dirs=(str(tmp_path / "none"),)))
