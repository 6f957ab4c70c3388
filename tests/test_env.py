"""The gymnasium environment: API checkers, episode logic, rewards from info, vector envs."""

from __future__ import annotations

import gc
import pickle
import subprocess
import sys
import weakref

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

import vprobot  # noqa: F401 - registers vprobot/Inspect-v0
from vprobot.env import ENV_ID, inspect_env
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode import EpisodeSpec
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.rewards import REWARDS

SMALL = {"parts": "mesh", "mesh": str(DEFAULT_MOTOR), "resolution": (107, 75)}


@pytest.mark.parametrize("first", ["vprobot", "gymnasium"])
def test_importing_vprobot_registers_the_env_in_gymnasiums_registry_whichever_comes_first(
        first: str) -> None:
    """The package registers the env without importing gymnasium (its command lines start
    faster), when gymnasium is imported, before or after it; gymnasium's own registry says so."""
    code = (f"import sys\nimport {first}\n"
            "import vprobot\n"
            "before = 'gymnasium' in sys.modules\n"
            "import gymnasium\n"
            "print(before, gymnasium.spec('vprobot/Inspect-v0').entry_point)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == [str(first == "gymnasium"), "vprobot.env.inspect_env:InspectEnv"]


def make(**overrides: object) -> InspectEnv:
    return InspectEnv(**{**SMALL, **overrides})


def look_at_action(phi: float, theta: float) -> np.ndarray:
    """A_2S0R action viewing from azimuth phi and polar angle theta."""
    return np.array([phi / np.pi - 1.0, 2.0 * theta / np.pi - 1.0], dtype=np.float32)


AROUND = [look_at_action(phi, theta) for phi, theta in [
    (0.0, 1.2), (2.1, 1.2), (4.2, 1.2), (1.0, 0.4), (3.1, 1.9), (5.2, 1.9), (0.5, 1.9),
    (3.6, 0.4), (1.6, 1.5), (4.7, 1.5),
]]


# Point clouds are (N, 3) by design; SB3 warns about any observation that is not 1-D or an image.
@pytest.mark.filterwarnings("ignore:Your observation.*unconventional shape")
@pytest.mark.parametrize(
    ("state", "action", "robot_state"),
    [("s_cov", "A_3S2R_lim", False), ("s_bin", "A_2S0R", False), ("s_cov", "A_3C2R", True),
     ("s_bin", "A_2S2R_lim", True)],
)
def test_gymnasium_and_sb3_checkers(state: str, action: str, robot_state: bool) -> None:
    env = make(state=state, action=action, robot_state=robot_state)
    gymnasium_check_env(env, skip_render_check=True)
    sb3_check_env(make(state=state, action=action, robot_state=robot_state), warn=True)


def test_observations_are_object_centred_and_bounded() -> None:
    env = make(state="s_bin", robot_state=True)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    points = obs["points"]
    assert points.shape == (2048, 4) and points.dtype == np.float32
    # The GT, turned with the object, centred on it and scaled by the fixed state scale.
    episode = env.episode
    expected = episode.scene.ground_truth.points @ episode.object_pose.rotation.T / 0.25
    np.testing.assert_allclose(points[:, :3], expected, atol=1e-6)
    assert points[:, 3].mean() == pytest.approx(info["coverage"])


def test_reset_places_the_robot_at_home_and_acquires_once() -> None:
    env = make()
    _, info = env.reset(seed=0)
    assert info["acquisitions"] == 1 and info["reachable"]
    assert 0.0 < info["coverage"] < 0.9
    assert env.episode.views[0].path[0] == pytest.approx(env.episode.start_joints)
    assert len(env.episode.views) == 1


def test_terminated_at_the_goal() -> None:
    env = make(action="A_2S0R", coverage_goal=0.6)
    env.reset(seed=1)
    for action in AROUND:
        _, _, terminated, truncated, info = env.step(action)
        assert terminated == (info["coverage"] >= 0.6)
        assert not truncated
        if terminated:
            break
    assert terminated
    with pytest.raises(RuntimeError, match="reset"):
        env.step(AROUND[0])


def test_real_goal_of_ninety_percent_is_reachable() -> None:
    env = make(action="A_2S0R", resolution=(215, 150))
    _, info = env.reset(seed=1)
    for action in AROUND:
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert terminated and info["coverage"] >= 0.90


def test_unreachable_request_keeps_joints_and_coverage() -> None:
    env = make(action="A_3C0R")
    _, before = env.reset(seed=0)
    _, reward, _, _, info = env.step(np.ones(3, dtype=np.float32))  # 1.7 m from the motor
    assert not info["reachable"]
    assert info["reason"] in ("out_of_reach", "did_not_converge", "joint_limits", "collision",
                              "path_not_found")
    np.testing.assert_array_equal(info["joints"], before["joints"])
    assert info["coverage"] == before["coverage"] and info["delta_coverage"] == 0.0
    assert info["travel_joint_time"] == 0.0
    assert reward == -1.0  # R2 for no gain


def test_same_seed_gives_the_identical_episode() -> None:
    def run() -> list:
        env = make()
        obs, _ = env.reset(seed=42)
        rng = np.random.default_rng(0)
        trace = [obs]
        for _ in range(4):
            obs, reward, terminated, truncated, info = env.step(
                rng.uniform(-1, 1, 5).astype(np.float32))
            trace += [obs, reward, info["coverage"], info["joints"]]
            if terminated or truncated:
                break
        return trace

    for first, second in zip(run(), run(), strict=True):
        np.testing.assert_array_equal(first, second)


@pytest.mark.parametrize(
    ("action", "message"),
    [
        (np.array([np.nan, 0, 0, 0, 0], dtype=np.float32), "finite"),
        (np.array([0, 0, 0, 0, 2.0], dtype=np.float32), r"\[-1, 1\]"),
        (np.zeros(3, dtype=np.float32), r"shape \(5,\)"),
    ],
)
def test_bad_actions_are_clear_errors(action: np.ndarray, message: str) -> None:
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)


def test_bad_configuration_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="unknown key 'colour'"):
        make(colour="red")
    with pytest.raises(ValueError, match=r"env\.reward must be one of"):
        make(reward="R99")
    with pytest.raises(FileNotFoundError, match=r"nowhere\.stl"):
        make(mesh="nowhere.stl")


def expected_reward(name: str, info: dict, steps: int, done: bool, goal: bool,
                    travel_sum: float, floor: float) -> float:
    """docs/states-actions-rewards.md#rewards, written out from the step's info and the test's
    own bookkeeping."""
    delta, coverage = info["delta_coverage"], info["coverage"]
    remaining = max(1.0 - (coverage - delta), floor)
    k = max(info["travel_cartesian"], floor)
    k_cum = max(travel_sum, floor)
    dense = {
        "R1": delta, "R2": delta if delta > 0 else -1.0,
        "R3": delta / remaining, "R4": delta / remaining if delta > 0 else -1.0,
        "R5": delta / k, "R6": delta / remaining / k,
        "R7": delta / k if delta > 0 else -1.0, "R8": delta / remaining / k if delta > 0 else -1.0,
    }
    if name in dense:
        return dense[name]
    if not done or (name in ("R13", "R14") and not goal):
        return 0.0
    return {"R9": coverage, "R10": coverage / steps, "R11": coverage / k_cum,
            "R12": coverage / (steps * k_cum), "R13": 1.0 / steps,
            "R14": 1.0 / (steps * k_cum)}[name]


@pytest.mark.parametrize("reward", list(REWARDS))
def test_every_reward_matches_its_formula(reward: str) -> None:
    env = make(reward=reward, goal_only_step_cap=4, travel_cost="cartesian")
    _, start = env.reset(seed=5)
    # The approach to the initial view is reported, and is no step of k_cum.
    assert start["approach_cartesian"] > 0.0 and start["travel_sum_cartesian"] == 0.0
    floor = env.config.env.travel_cost_floor
    rng = np.random.default_rng(7)
    done, steps, travel_sum = False, 0, 0.0
    while not done:
        _, value, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, 5).astype(np.float32))
        done, steps = terminated or truncated, steps + 1
        travel_sum += info["travel_cartesian"]
        assert info["travel_sum_cartesian"] == pytest.approx(travel_sum)
        assert info["approach_cartesian"] == start["approach_cartesian"]
        assert value == pytest.approx(expected_reward(reward, info, steps, done, terminated,
                                                      travel_sum, floor))
    limit = 4 if reward in ("R13", "R14") else 10
    assert steps == limit or terminated


def test_cycle_time_as_the_travel_cost_pays_coverage_per_second_of_the_cells_cycle() -> None:
    """With `travel_cost: cycle_time`, R5 pays ΔCOV_t / k_t where k_t is the time from the end
    of one acquisition to the end of the next on the clock of the episode's cycle timed whole
    (`EpisodeRecord.timed`): the move's duration under the robot's limits plus its acquisition. The
    last step's info has the cycle time: approach + steps + return home."""
    env = make(reward="R5", travel_cost="cycle_time", action="A_2S0R")
    _, start = env.reset(seed=5)
    floor = env.config.env.travel_cost_floor
    infos, rewards, done = [], [], False
    for action in AROUND:
        _, reward, terminated, truncated, info = env.step(action)
        infos.append(info)
        rewards.append(reward)
        done = terminated or truncated
        if done:
            break
    assert done and all("cycle_time" not in info for info in infos[:-1])
    record = env.episode_record()
    timed = record.timed
    ends = iter(stop.end_s for stop in timed.acquisitions)
    previous = next(ends)  # the initial view's: the approach is no step
    assert start["approach_cycle_time"] == pytest.approx(previous)
    reached = 0
    for info, reward in zip(infos, rewards, strict=True):
        if info["reachable"]:
            end = next(ends)
            k, previous, reached = end - previous, end, reached + 1
        else:
            k = 0.0
        assert info["travel_cycle_time"] == pytest.approx(k, abs=1e-12)
        assert info["reward_terms"]["travel_cost"] == info["travel_cycle_time"]
        assert reward == pytest.approx(info["delta_coverage"] / max(k, floor))
    assert reached >= 3
    last = infos[-1]
    assert last["travel_sum_cycle_time"] == pytest.approx(previous - start["approach_cycle_time"])
    back = env.episode.scene.arm.move_time(record.return_waypoints)
    assert last["cycle_time"] == pytest.approx(timed.cycle.total_s)
    assert last["cycle_time"] == pytest.approx(previous + back)


def test_truncated_exactly_at_the_step_limit() -> None:
    env = make(action="A_2S2R")
    env.reset(seed=0)
    away = np.array([0.0, 0.0, -1.0, -1.0], dtype=np.float32)
    flags = [env.step(away)[2:4] for _ in range(10)]
    assert flags == [(False, False)] * 9 + [(False, True)]


def test_different_seeds_give_different_episodes() -> None:
    # Three seeds, since every new training motor costs its ground truth on a cold cache.
    env = make(parts="train", mesh=None)
    quaternions, parts = set(), set()
    for seed in range(3):
        _, info = env.reset(seed=seed)
        quaternions.add(tuple(np.round(env.episode.object_pose.quaternion, 6)))
        parts.add(info["part"])
    assert len(quaternions) == 3 and len(parts) >= 2


def test_initial_view_attempts_that_fail_leave_no_trace() -> None:
    env = make()
    # Straight from below (inside the fixture) first, then the paper's fixed view.
    spec = EpisodeSpec(part=str(DEFAULT_MOTOR), object_quaternion=(1.0, 0.0, 0.0, 0.0),
                       initial_views=((0.0, np.pi), (1.42, 0.71)), seed=0)
    _, info = env.reset(options={"episode": spec})
    assert len(env.episode.views) == 1 and env.episode.views[0].reachable
    assert info["acquisitions"] == 1
    record = env.episode_record()
    assert len(record.views) == 1
    random = make(initial_view="random")
    for seed in range(3):
        random.reset(seed=seed)
        assert len(random.episode.views) == 1 and random.episode.views[0].reachable


@pytest.mark.parametrize("points", [512, 3000])
def test_s_bin_state_has_the_declared_rows(points: int) -> None:
    env = make(state="s_bin", state_points=points)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (points, 4) and env.observation_space.contains(obs)
    gt = env.episode.tracker.gt_points
    rows = np.arange(points) % len(gt)
    np.testing.assert_allclose(obs[:, :3], gt[rows] @ env.episode.object_pose.rotation.T / 0.25,
                               atol=1e-6)


def test_a_spec_gives_the_same_episode_to_both_carriers() -> None:
    spec = EpisodeSpec(part=str(DEFAULT_MOTOR), object_quaternion=(0.9, 0.1, 0.0, 0.3),
                       initial_views=((1.42, 0.71),), seed=3)
    robot, free = make(action="A_2S0R"), make(action="A_2S0R", carrier="free")
    _, robot_info = robot.reset(options={"episode": spec})
    _, free_info = free.reset(options={"episode": spec.as_dict()})
    np.testing.assert_allclose(robot.episode.object_pose.rotation,
                               free.episode.object_pose.rotation)
    # The same view from the same pose: only the arm's occlusion can differ.
    assert free_info["coverage"] >= robot_info["coverage"] > 0.2
    action = look_at_action(4.2, 1.2)
    _, _, _, _, info = free.step(action)
    assert info["reachable"] and info["carrier"] == "free"
    assert info["travel_joint_time"] == 0.0 and info["travel_paper"] > 0.0
    start = np.asarray(free_info["sensor_position"]) - free.episode.center
    end = np.asarray(info["sensor_position"]) - free.episode.center
    arc = np.linalg.norm(start) * np.arccos(np.clip(start @ end / (np.linalg.norm(start)
                                                                   * np.linalg.norm(end)), -1, 1))
    assert info["travel_paper"] == pytest.approx(arc, rel=1e-6)
    assert info["travel_cartesian"] == pytest.approx(np.linalg.norm(end - start))


def test_free_carrier_rejects_joint_travel_in_its_reward() -> None:
    with pytest.raises(ValueError, match="needs the robot"):
        make(carrier="free", reward="R5", travel_cost="joint_time")
    make(carrier="free", reward="R5", travel_cost="paper")


def test_bad_episode_option_is_a_clear_error() -> None:
    env = make()
    with pytest.raises(ValueError, match="object_quaternion"):
        env.reset(options={"episode": {"part": str(DEFAULT_MOTOR), "seed": 0,
                                       "object_quaternion": [0, 0, 0, 0],
                                       "initial_views": [[1.42, 0.71]]}})


def test_registered_id_and_vector_envs() -> None:
    env = gym.make(ENV_ID, **SMALL)
    assert env.spec.id == ENV_ID
    copy = pickle.loads(pickle.dumps(make()))
    assert copy.observation_space.shape == (2048, 3)
    for vec in (DummyVecEnv([lambda: make()] * 2),
                SubprocVecEnv([lambda: make()] * 2, start_method="fork")):
        observations = vec.reset()
        assert observations.shape == (2, 2048, 3)
        observations, rewards, _, infos = vec.step(
            np.stack([vec.action_space.sample() for _ in range(2)]))
        assert rewards.shape == (2,) and "coverage" in infos[0]
        vec.close()
    vector = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", **SMALL)
    observations, _ = vector.reset(seed=0)
    assert observations.shape == (2, 2048, 3)
    vector.close()


def test_render_returns_a_frame() -> None:
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (480, 640, 3) and frame.std() > 10
    env.close()


def test_stop_action_ends_the_episode_with_the_goal_as_its_signal() -> None:
    env = make(action="A_2S0R", stop_action=True, coverage_goal=0.6)
    assert env.action_space.shape == (3,)
    env.reset(seed=1)
    go = [np.append(action, -1.0).astype(np.float32) for action in AROUND]
    # Not stopped at the goal: the agent has to say so.
    for action in go:
        _, reward, terminated, truncated, info = env.step(action)
        if info["coverage"] >= 0.6:
            break
    assert info["coverage"] >= 0.6 and not terminated and not truncated
    _, reward, terminated, truncated, info = env.step(np.array([0, 0, 1.0], dtype=np.float32))
    assert (reward, terminated, truncated, info["stopped"]) == (1.0, True, False, True)
    assert info["reward_terms"]["stop"] == 1.0 and info["points_acquired"] == 0
    env.reset(seed=1)
    _, reward, terminated, _, _ = env.step(np.array([0, 0, 1.0], dtype=np.float32))
    assert (reward, terminated) == (-1.0, True)  # stopped short of the goal
    env.reset(seed=1)
    away = np.array([0.0, -1.0, -1.0], dtype=np.float32)  # looking from straight above
    for _ in range(9):
        env.step(away)
    _, reward, _, truncated, info = env.step(away)
    assert truncated and info["reward_terms"]["stop"] == -1.0  # never stopped
    env.reset(seed=1)
    with pytest.raises(ValueError, match="plus a stop component"):
        env.step(np.zeros(2, dtype=np.float32))


def test_an_evicted_scene_is_freed_and_its_memory_released(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(inspect_env, "SCENES_KEPT", 1)
    env = make()
    released: list[bool] = []
    # Records, when memory is released, whether the evicted scene had already left the cache.
    monkeypatch.setattr(inspect_env, "release_freed_memory",
                        lambda: released.append(first() not in env._scenes.values()))
    first = weakref.ref(env.scene(DEFAULT_MOTOR))
    assert released == []
    # The same file by another path: another cache key, and its ground truth is not built again.
    env.scene(DEFAULT_MOTOR.parent / ".." / DEFAULT_MOTOR.parent.name / DEFAULT_MOTOR.name)
    assert released == [True]
    gc.collect()
    assert first() is None
