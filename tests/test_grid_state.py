"""The `A_view` action and the `s_grid` state: spaces, mask, features, one builder for both."""

from __future__ import annotations

import math
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from scipy import ndimage

from vprobot.agents.trained import TrainedAgent
from vprobot.config import Config, ConfigError, replace, with_sensor
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import GAINS, OCCUPIED, EpisodeGrid, OccupancyGrid
from vprobot.coverage.view_gains import UNKNOWN_PASS
from vprobot.env.grid_state import FEATURES, SENSED_FEATURES, GridState
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode import Episode
from vprobot.episode.views import band_directions, offered
from vprobot.files.paths import MOTORS_DIR
from vprobot.geometry.poses import Pose
from vprobot.planners.agent import AgentPlanner

RESOLUTION = (64, 45)
# The sensor itself at a small resolution: the agent planner integrates frames at the sensor's.
CONFIG = replace(replace(Config(), "sensor", resolution=RESOLUTION), "env", action="A_view",
                 state="s_grid", parts="mesh",
                 mesh=str(MOTORS_DIR / "train" / "motor_000.stl"))
COLUMN = {name: index for index, name in enumerate(FEATURES)}


def unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


def requested_directions(episode: Episode) -> np.ndarray:
    return unit(np.array([view.requested.position - episode.center for view in episode.views]))


def brute_force_gains(grid: OccupancyGrid, poses: list[Pose]) -> tuple[np.ndarray, float]:
    """The gains (count, `GAINS`) of sensor poses, written out from their definition in
    `vprobot.coverage.occupancy` without its code, and the largest gain of a candidate (every sample
    of every ray unknown).

    16 x 12 rays through the pixel centres of the field of view; samples half a voxel apart
    from the near to the far bound; a sample's visibility is the product of the passes of the
    samples before it (free 1, unknown the root of `UNKNOWN_PASS` as two samples share a voxel,
    occupied 0; outside the grid 1); a gain sums the visibility of its unknown samples: all
    of them, those next to a free voxel (frontier), those next to an occupied one (rear side).
    """
    sensor = CONFIG.sensor
    half_x, half_y = (math.tan(math.radians(angle) / 2.0) for angle in sensor.fov_deg)
    u = half_x * ((np.arange(16) + 0.5) / 8.0 - 1.0)
    v = half_y * ((np.arange(12) + 0.5) / 6.0 - 1.0)
    rays = unit(np.array([(x, y, 1.0) for y in v for x in u]))
    step = grid.voxel_m / 2.0
    distances = sensor.near_m + step * np.arange(round((sensor.far_m - sensor.near_m) / step) + 1)
    unknown_pass = UNKNOWN_PASS ** 0.5
    unknown = grid.state == 0
    cross = ndimage.generate_binary_structure(3, 1)  # the six face neighbours and the voxel
    counted = np.stack([unknown, unknown & ndimage.binary_dilation(grid.state == 1, cross),
                        unknown & ndimage.binary_dilation(grid.state == 2, cross)], axis=-1)
    shape = np.array(grid.state.shape)
    gains = np.zeros((len(poses), len(GAINS)))
    for candidate, pose in enumerate(poses):
        world_rays = rays @ pose.rotation.T
        visible = np.ones(len(rays))
        for distance in distances:
            voxel = np.floor((pose.position + distance * world_rays - grid.origin)
                             / grid.voxel_m).astype(int)
            inside = ((voxel >= 0) & (voxel < shape)).all(axis=1)
            x, y, z = np.where(inside[:, None], voxel, 0).T
            state = np.where(inside, grid.state[x, y, z], 1)
            gains[candidate] += (visible[:, None] * (counted[x, y, z] & inside[:, None])).sum(0)
            visible = visible * np.select([state == 1, state == 0], [1.0, unknown_pass], 0.0)
    bound = len(rays) * sum(unknown_pass ** k for k in range(len(distances)))
    return gains, bound


@pytest.fixture(scope="module")
def stepped() -> tuple[InspectEnv, list[dict[str, np.ndarray]], int, int]:
    """An episode with the robot: the candidate from the top, then the one from -x (where the
    arm would collide: it stays at the top)."""
    env = InspectEnv(CONFIG)
    observations = [env.reset(seed=3)[0]]
    directions = band_directions()
    reached, failed = int(np.argmax(directions[:, 2])), int(np.argmin(directions[:, 0]))
    for action in (reached, failed):
        observation, _, _, _, info = env.step(action)
        observations.append(observation)
    assert env.episode.views[1].reachable and not info["reachable"]
    return env, observations, reached, failed


def test_check_env_passes_for_a_view_and_s_grid_with_the_robot() -> None:
    env = InspectEnv(CONFIG)
    assert env.action_space.n == len(band_directions()) == 128
    assert env.observation_space["candidates"].shape == (128, len(FEATURES))
    check_env(env, skip_render_check=True)


def test_the_mask_hides_unreachable_and_requested_candidates_and_those_within_10_deg(
        stepped: tuple) -> None:
    env, observations, reached, failed = stepped
    directions = band_directions()
    angles = np.degrees(np.arccos(np.clip(directions @ requested_directions(env.episode).T,
                                          -1.0, 1.0)))
    # After the step to `reached` (views 0-1), then after the failed one as well (views 0-2).
    for observation, views in ((observations[1], 2), (observations[2], 3)):
        reachable = observation["candidates"][:, COLUMN["reachable"]] == 1
        expected = (angles[:, :views] >= 10.0).all(axis=1) & reachable
        np.testing.assert_array_equal(observation["mask"], expected)
    # The screening agrees with what the carrier did: it reached one and failed the other.
    reachable = observations[2]["candidates"][:, COLUMN["reachable"]]
    assert reachable[reached] == 1 and reachable[failed] == 0 and 0 < reachable.mean() < 1
    assert observations[1]["mask"][reached] == 0 and observations[2]["mask"][failed] == 0
    assert observations[2]["candidates"][failed, COLUMN["failed"]] == 1
    assert observations[2]["candidates"][:, COLUMN["failed"]].sum() == 1
    assert observations[1]["candidates"][reached, COLUMN["current"]] == 1
    # The failed request left the sensor at `reached`.
    assert observations[2]["candidates"][:, COLUMN["current"]].tolist().index(1) == reached


def test_the_features_are_the_brute_force_values_and_the_gains_of_an_independent_grid(
        stepped: tuple) -> None:
    env, observations, _, _ = stepped
    episode = env.episode
    rows = observations[-1]["candidates"]
    directions = band_directions()
    np.testing.assert_allclose(rows[:, [COLUMN["direction_x"], COLUMN["direction_y"],
                                        COLUMN["direction_z"]]], directions, atol=1e-7)
    closest = [max(float(d @ r) for r in requested_directions(episode)) for d in directions]
    np.testing.assert_allclose(rows[:, COLUMN["closest_request_cos"]], closest, atol=1e-6)
    # A grid integrated here from every frame at once: the env integrated them one by one.
    grid = OccupancyGrid.for_cell(CONFIG)
    sensor = SensorModel.from_config(CONFIG.sensor)
    for view in episode.views:
        if view.acquired:
            grid.integrate(sensor, view.sensor_pose, view.points_world, view.pixels,
                           view.blocked_pixels)
    builder = env.observer.grid_state
    np.testing.assert_array_equal(episode.occupancy(builder.settings).grid.state, grid.state)
    # The candidates look at the centre from the working distance along their directions.
    poses = [target.pose for target in builder.band.targets]
    distance = CONFIG.sensor.working_distance_m
    np.testing.assert_allclose([pose.position for pose in poses],
                               episode.center + distance * directions, atol=1e-9)
    np.testing.assert_allclose([pose.view_axis for pose in poses], -directions, atol=1e-9)
    gains, bound = brute_force_gains(grid, poses)
    for index, gain in enumerate(GAINS):
        np.testing.assert_allclose(rows[:, index], np.minimum(gains[:, index] / bound, 1.0),
                                   rtol=1e-4, atol=1e-6, err_msg=gain)
        best = gains[observations[-1]["mask"] == 1, index].max()
        np.testing.assert_allclose(rows[:, len(GAINS) + index],
                                   np.minimum(gains[:, index] / best, 1.0), rtol=1e-4, atol=1e-6,
                                   err_msg=gain)
    counts = grid.counts()
    np.testing.assert_allclose(rows[0, COLUMN["requests_used"]:], [
        2 / 10, *(counts[kind] / grid.state.size for kind in ("occupied", "free", "unknown"))],
        rtol=1e-6)
    assert (rows[:, COLUMN["requests_used"]:] == rows[0, COLUMN["requests_used"]:]).all()


def test_under_structured_light_the_gains_are_what_each_candidates_sensor_measures() -> None:
    # The scorer itself is checked against closed forms in tests/test_view_gains.py; here the
    # state reads it, not the camera's, and normalises it as the camera's gains were.
    config = replace(with_sensor(CONFIG, "zivid2plus_mr60"), "sensor", resolution=RESOLUTION)
    env = InspectEnv(config)
    env.reset(seed=3)
    observation = env.step(int(np.argmax(band_directions()[:, 2])))[0]
    rows = observation["candidates"]
    builder = env.observer.grid_state
    gains = builder.band.gains
    grid = env.episode.occupancy(builder.settings).grid
    sensed = gains.scores(grid) / (gains.rays * gains.ray_bound)
    camera = gains.camera_scores(grid) / (gains.rays * gains.ray_bound)
    np.testing.assert_allclose(rows[:, :len(GAINS)], np.minimum(sensed, 1.0), rtol=1e-5,
                               atol=1e-7)
    # The projector and the incidence limits keep less than the camera sees.
    assert (sensed <= camera + 1e-12).all() and (sensed < 0.9 * camera).any()
    # After FEATURES, the revisit gain per ray, over the best offered, and the bound over the
    # reachable candidates that did not fail, the same on every row, as a share of the occupied
    # voxels and the measurable ones.
    columns = {name: index for index, name in enumerate(builder.features)}
    assert builder.features == (*FEATURES, *SENSED_FEATURES)
    revisit = gains.revisits(grid).revisit / gains.rays
    np.testing.assert_allclose(rows[:, columns["gain_revisit"]], revisit, rtol=1e-5)
    best = revisit[observation["mask"] > 0].max()
    assert best > 0.0
    np.testing.assert_allclose(rows[:, columns["gain_revisit_relative"]],
                               np.minimum(revisit / best, 1.0), rtol=1e-5)
    usable = (rows[:, COLUMN["reachable"]] == 1) & (rows[:, COLUMN["failed"]] == 0)
    assert 0 < usable.sum() < len(usable)
    measurable = gains.revisits(grid, usable).measurable
    occupied = int((grid.state == OCCUPIED).sum())
    assert rows[:, columns["measurable_left"]] == pytest.approx(
        measurable / (measurable + occupied))


def test_offered_drops_directions_within_10_deg_of_a_request_and_failed_ones() -> None:
    polar = np.deg2rad([9.9, 10.1, 30.0, 30.0])
    directions = np.column_stack([np.sin(polar), np.zeros(4), np.cos(polar)])
    failed = np.array([False, False, True, False])
    np.testing.assert_array_equal(offered(directions, np.array([[0.0, 0.0, 1.0]]), failed),
                                  [False, True, False, True])
    np.testing.assert_array_equal(offered(directions, np.zeros((0, 3)), failed), ~failed)


def test_the_mask_is_a_brute_force_angle_check_against_every_earlier_request() -> None:
    """Requests at candidates (some failed) and near others, free-flying: a candidate
    is offered exactly when it lies more than 10 deg from every request and did not fail."""
    rng = np.random.default_rng(4)
    center = np.asarray(CONFIG.cell.object_center_m)
    directions = band_directions()
    # Six at candidates, six about 10 deg off others (the mask's edge).
    picks = rng.choice(len(directions), 12, replace=False)
    requested = np.concatenate([directions[picks[:6]],
                                unit(directions[picks[6:]] + rng.normal(0.0, 0.12, (6, 3)))])
    reached = [True, False, True, False, True, True, True, True, False, True, False, True]
    views = [types.SimpleNamespace(requested=Pose(center + 0.47 * d, np.eye(3)), reachable=ok,
                                   sensor_pose=None)
             for d, ok in zip(requested, reached, strict=True)]
    episode = types.SimpleNamespace(views=views, center=center, uses_robot=False, q=np.zeros(0),
                                    occupancy=EpisodeGrid)  # nothing acquired: all unknown
    observation = GridState(CONFIG).observe(episode)  # type: ignore[arg-type]
    expected = []
    for candidate in directions:
        angles = [math.degrees(math.acos(min(1.0, float(candidate @ request))))
                  for request in requested]
        failed = any(angle <= 1.0 and not ok for angle, ok in zip(angles, reached, strict=True))
        expected.append(min(angles) > 10.0 and not failed)
    # Beside the six at candidates, some requested near others exclude them, some not.
    closest = np.degrees(np.arccos(np.clip(directions @ requested[6:].T, -1.0, 1.0))).min(axis=0)
    assert (closest < 10.0).any() and (closest > 10.0).any(), closest
    np.testing.assert_array_equal(observation["mask"], expected)


def test_when_every_candidate_is_masked_all_that_did_not_fail_are_offered() -> None:
    center = np.asarray(CONFIG.cell.object_center_m)
    directions = band_directions()
    views = [types.SimpleNamespace(requested=Pose(center + 0.47 * d, np.eye(3)),
                                   reachable=index != 5, sensor_pose=None)
             for index, d in enumerate(directions)]
    # Free-flying: every candidate is reachable.
    episode = types.SimpleNamespace(views=views, center=center, uses_robot=False, q=np.zeros(0),
                                    occupancy=EpisodeGrid)  # nothing acquired: all unknown
    observation = GridState(CONFIG).observe(episode)  # type: ignore[arg-type]
    expected = np.ones(len(directions))
    expected[5] = 0.0
    np.testing.assert_array_equal(observation["mask"], expected)


class Replaying:
    """A policy that requests given actions in turn and keeps the observations it is handed."""

    def __init__(self, actions: list[int]):
        self.actions = list(actions)
        self.handed: list[dict[str, np.ndarray]] = []

    def predict(self, observation: dict[str, np.ndarray], deterministic: bool = True) -> tuple:
        self.handed.append(observation)
        return np.array(self.actions.pop(0)), None


def test_the_agent_planner_builds_the_env_observation_of_the_same_episode(
        monkeypatch: pytest.MonkeyPatch) -> None:
    actions = [7, 60, 100]
    env = InspectEnv(CONFIG)
    expected = [env.reset(seed=5)[0]]
    for action in actions[:-1]:
        expected.append(env.step(action)[0])
    policy = Replaying(actions)

    def load(source: Any) -> TrainedAgent:
        return TrainedAgent(model=policy, config=CONFIG, path=Path("stub.zip"))  # type: ignore

    monkeypatch.setattr("vprobot.agents.trained.load_agent", load)
    planner = AgentPlanner("stub")
    spec = env.spec_of_episode
    episode = Episode.from_spec(env.scene(spec.part_path, spec.scale), spec)
    planner.reset(episode, np.random.default_rng(0))
    episode.begin(spec.initial_requests(episode.center, CONFIG.sensor.working_distance_m))
    for _ in actions:
        episode.request(planner.next_view(episode))
    assert len(policy.handed) == len(expected)
    for handed, observed in zip(policy.handed, expected, strict=True):
        assert handed.keys() == observed.keys()
        for key in observed:
            np.testing.assert_array_equal(handed[key], observed[key])


@pytest.mark.parametrize(("changes", "names"), [
    ({"state": "s_grid", "action": "A_2S0R"}, ("env.state 's_grid'", "env.action 'A_2S0R'")),
    ({"state": "s_grid", "action": "A_3S2R_lim"}, ("env.state 's_grid'", "'A_3S2R_lim'")),
    ({"action": "A_view", "stop_action": True}, ("env.action 'A_view'", "env.stop_action")),
])
def test_bad_combinations_are_config_errors_naming_both_settings(
        changes: dict[str, Any], names: tuple[str, ...]) -> None:
    with pytest.raises(ConfigError) as error:
        replace(Config(), "env", **changes)
    for name in names:
        assert name in str(error.value)


def test_an_a_view_request_drives_to_the_candidates_screened_configuration(
        stepped: tuple) -> None:
    env, _, reached, failed = stepped
    builder = env.observer.grid_state
    # The failed request left the robot where the first one took it: the screened joints.
    np.testing.assert_allclose(env.episode.q, builder.joints_of(reached), atol=1e-9)
    assert builder.joints_of(failed) is None
