"""Model-free planners (uniform<k>, nbv, an s_grid agent), the coverage estimate's features and
the stop rules a real cell can apply: what they may read, the occupancy grid, the planners'
gains."""

from __future__ import annotations

import itertools
import json
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch
import trimesh
from stable_baselines3.common.vec_env import DummyVecEnv

from vprobot.agents.candidate_q import CandidateDQN
from vprobot.agents.trained import TrainedAgent
from vprobot.benchmarks.grid import sampled_integration
from vprobot.config import Config, replace, with_sensing, with_sensor
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import (
    FREE,
    GAINS,
    OCCUPIED,
    UNKNOWN,
    VOXEL_M,
    EpisodeGrid,
    GridSettings,
    OccupancyGrid,
)
from vprobot.coverage.view_gains import UNKNOWN_PASS, ViewGains, _codes
from vprobot.env.grid_state import FEATURES as GRID_FEATURES
from vprobot.env.grid_state import candidate_count
from vprobot.env.observations import observation_space
from vprobot.episode import Episode, PartScene, seeded_episode
from vprobot.episode.views import band_candidates
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import Pose
from vprobot.planners.agent import AgentPlanner
from vprobot.planners.base import Planner
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.nbv import EXCLUDE_DEG
from vprobot.planners.runner import make_planner, parse_planner
from vprobot.planners.uniform import view_band
from vprobot.stopping.features import FEATURES, CoverageFeatures
from vprobot.stopping.rules import make_stop_rule
from vprobot.training.train import build_model

CONFIG = Config()
RESOLUTION = (107, 75)
VIEW_FIELDS = ("requested", "reachable", "sensor_pose", "points_world", "pixels", "blocked_pixels",
               "acquired", "joints")
"""What a model-free planner may read of a view: where it asked, where the sensor was and
what it measured, never the coverage."""


@pytest.fixture(scope="module")
def bracket(tmp_path_factory: pytest.TempPathFactory) -> PartScene:
    """An L-shaped part (two boxes)."""
    folder = tmp_path_factory.mktemp("model_free")
    mesh = trimesh.boolean.union([
        trimesh.creation.box(extents=(0.16, 0.10, 0.03)),
        trimesh.creation.box(extents=(0.03, 0.10, 0.12),
                             transform=trimesh.transformations.translation_matrix(
                                 (0.065, 0.0, 0.045))),
    ])
    path = folder / "bracket.stl"
    mesh.export(path)
    return PartScene.load(CONFIG, path, resolution=RESOLUTION)


class Guarded:
    """Lets a planner read only the named attributes; reading anything else fails the test."""

    def __init__(self, what: str, **allowed: Any):
        self._what = what
        self._allowed = allowed

    def __getattr__(self, name: str) -> Any:
        if name in self._allowed:
            return self._allowed[name]
        raise AssertionError(f"the planner read {self._what}.{name}")


_GRIDS: weakref.WeakKeyDictionary[Episode, dict[GridSettings, EpisodeGrid]] = (
    weakref.WeakKeyDictionary())
"""The grids of each guarded episode, kept from view to view as `Episode.occupancy` keeps them."""


def guarded_occupancy(grids: dict[GridSettings, EpisodeGrid], views: list[Guarded]
                      ) -> Callable[[GridSettings], EpisodeGrid]:
    """`Episode.occupancy` of guarded views: the grid integrates what they measured, no more."""

    def occupancy(settings: GridSettings) -> EpisodeGrid:
        grid = grids.setdefault(settings, EpisodeGrid(settings))
        grid.update(views)  # type: ignore[arg-type]
        return grid

    return occupancy


def planner_view(episode: Episode) -> Guarded:
    """The episode as a model-free planner may see it: the views' poses and points (and the
    episode's occupancy grid of them), the robot's state, kinematics and reach (IK and moves in
    the cell, shared between the planners of an episode), the fixture's centre;
    no mesh, ground truth or coverage."""
    views = [Guarded("view", **{name: getattr(view, name) for name in VIEW_FIELDS})
             for view in episode.views]
    robot = ({"collisions": episode.robot.collisions, "path_is_free": episode.robot.path_is_free,
              "reach": episode.robot.reach} if episode.uses_robot else {})
    return Guarded("episode", views=views, q=episode.q.copy(), center=episode.center.copy(),
                   occupancy=guarded_occupancy(_GRIDS.setdefault(episode, {}), views),
                   uses_robot=episode.uses_robot,
                   scene=Guarded("scene", arm=episode.scene.arm),
                   robot=Guarded("robot", **robot))


def guarded_run(planner: Planner, scene: PartScene, carrier: str, seed: int = 0,
                views: int = 6) -> Episode:
    """Run a planner for at most `views` requests, handing it only `planner_view`s."""
    spec = seeded_episode(CONFIG.env, scene.mesh.path, seed)
    episode = Episode.from_spec(scene, spec, carrier)
    planner.reset(planner_view(episode), np.random.default_rng(seed))  # type: ignore[arg-type]
    if isinstance(planner, InitialViewPlanner):
        episode.begin(spec.initial_requests(episode.center, CONFIG.sensor.working_distance_m))
    while len(episode.views) < views:
        request = planner.next_view(planner_view(episode))  # type: ignore[arg-type]
        if request is None:
            break
        episode.request(request)
    return episode


@pytest.mark.parametrize("carrier", ["robot", "free"])
@pytest.mark.parametrize("name", ["uniform4", "nbv", "nbv@grid"])
def test_model_free_planners_never_read_mesh_ground_truth_or_coverage(
        bracket: PartScene, name: str, carrier: str) -> None:
    # uniform's band screened with straight-line moves: seconds, where the default cell's takes
    # a minute of motion planning (test_results_regenerate's uniform4 screens that one); the
    # episode's robot still plans its moves.
    planner_config = replace(CONFIG, "kinematics", path_planner="line")
    episode = guarded_run(make_planner(name, planner_config), bracket, carrier)
    assert sum(view.acquired for view in episode.views) >= 3


class MaskedGreedy:
    """An `s_grid` policy: the offered candidate of the largest unknown gain."""

    def predict(self, observation: dict[str, np.ndarray], deterministic: bool = True) -> tuple:
        rows, mask = observation["candidates"], observation["mask"]
        return np.array(np.argmax(np.where(mask > 0, rows[:, 0], -1.0))), None


# With the robot: test_the_candidate_agent_never_requests_within_5_deg_of_an_earlier_request.
@pytest.mark.parametrize("carrier", ["free"])
def test_an_a_view_s_grid_agent_reads_no_model_and_never_asks_near_an_earlier_view(
        bracket: PartScene, carrier: str, monkeypatch: pytest.MonkeyPatch) -> None:
    # Frames at the scene's resolution, which the planner takes for the sensor's.
    config = replace(replace(CONFIG, "sensor", resolution=RESOLUTION), "env",
                     action="A_view", state="s_grid")
    monkeypatch.setattr("vprobot.agents.trained.load_agent", lambda source: TrainedAgent(
        model=MaskedGreedy(), config=config, path=Path("stub.zip")))  # type: ignore[arg-type]
    episode = guarded_run(AgentPlanner("stub"), bracket, carrier)
    # The greedy stub does not know what the robot reaches: only the count of requests is sure.
    assert len(episode.views) == 6
    directions = np.array([view.requested.position - episode.center for view in episode.views])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    angles = np.degrees(np.arccos(np.clip(directions @ directions.T, -1.0, 1.0)))
    np.fill_diagonal(angles, 180.0)
    assert angles.min() >= EXCLUDE_DEG


class CandidateSpaces(gym.Env):
    """The spaces of an `s_grid` / `A_view` env, to build a model on."""

    def __init__(self, config: Config):
        self.observation_space = observation_space(config)
        self.action_space = gym.spaces.Discrete(candidate_count())


def drawn_to_earlier_requests(model: CandidateDQN) -> None:
    """Give an untrained Q-network the worst wish: Q = 1 + the cosine to the closest earlier
    request, so that, unmasked, it would request the view it already took."""
    q_net = model.policy.q_net
    with torch.no_grad():
        for parameter in q_net.parameters():
            parameter.zero_()
        first, second, last = (layer for layer in q_net.head if isinstance(layer, torch.nn.Linear))
        first.weight[0, GRID_FEATURES.index("closest_request_cos")] = 1.0
        first.bias[0] = 1.0
        second.weight[0, 0] = last.weight[0, 0] = 1.0


def test_the_candidate_agent_never_requests_within_5_deg_of_an_earlier_request(
        bracket: PartScene, monkeypatch: pytest.MonkeyPatch) -> None:
    """The issue's target, on every episode: with the robot, from a Q-network that would rather
    repeat a view (the mask and the masked Q-values forbid it)."""
    config = replace(replace(replace(CONFIG, "sensor", resolution=RESOLUTION), "env",
                             action="A_view", state="s_grid"), "agent", algorithm="dqn",
                     encoder="candidates", net_arch=(8, 8), buffer_size=100)
    model = build_model(config, DummyVecEnv([lambda: CandidateSpaces(config)]), seed=0,
                        device="cpu")
    drawn_to_earlier_requests(model)
    monkeypatch.setattr("vprobot.agents.trained.load_agent", lambda source: TrainedAgent(
        model=model, config=config, path=Path("stub.zip")))
    for seed in (0, 1):
        episode = guarded_run(AgentPlanner("stub"), bracket, "robot", seed, views=7)
        assert len(episode.views) == 7
        directions = np.array([view.requested.position - episode.center
                               for view in episode.views])
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        angles = np.degrees(np.arccos(np.clip(directions @ directions.T, -1.0, 1.0)))
        np.fill_diagonal(angles, 180.0)
        assert angles.min() > 5.0, (seed, angles.min())


def test_the_coverage_estimate_features_never_read_mesh_ground_truth_or_coverage(
        bracket: PartScene) -> None:
    episode = guarded_run(make_planner("nbv", CONFIG), bracket, "robot")
    views = planner_view(episode).views
    features = CoverageFeatures(CONFIG)
    rows = np.array([features.update(views[:count]) for count in range(1, len(views) + 1)])
    assert np.isfinite(rows).all()
    assert rows[-1, FEATURES.index("acquired")] == sum(view.acquired for view in episode.views)


@pytest.mark.parametrize(("rule", "decides"), [("estimate:0.5", True), ("grid", False),
                                               ("views:3", True)])
def test_the_model_free_stop_rules_never_read_mesh_ground_truth_or_coverage(
        bracket: PartScene, rule: str, decides: bool) -> None:
    # A goal the estimate can pass, so that the rule runs to its decision, not only up to it
    # (the grid rule needs more quiet views than the episode has: it reads every frame anyway).
    config = replace(CONFIG, "env", coverage_goal=0.3)
    views = planner_view(guarded_run(make_planner("nbv", CONFIG), bracket, "robot")).views
    stop = make_stop_rule(rule, config)
    stop.reset()
    grids: dict[GridSettings, EpisodeGrid] = {}
    decisions = [stop.check(Guarded(  # type: ignore[arg-type]
        "episode", views=views[:count], occupancy=guarded_occupancy(grids, views[:count])))
        for count in range(len(views) + 1)]
    assert decisions[0] is None and any(decisions) == decides


def test_the_guard_catches_the_goal_rule_reading_the_coverage(bracket: PartScene) -> None:
    views = planner_view(guarded_run(make_planner("nbv", CONFIG), bracket, "robot")).views
    with pytest.raises(AssertionError, match=r"read episode\.coverage"):
        make_stop_rule("goal", CONFIG).check(Guarded("episode", views=views))  # type: ignore


@pytest.mark.parametrize("name", ["hrec", "optimum"])
def test_the_guard_catches_a_planner_that_reads_the_model(bracket: PartScene, name: str) -> None:
    with pytest.raises(AssertionError, match="the planner read"):
        guarded_run(make_planner(name, CONFIG), bracket, "free")


def test_uniform_views_are_the_same_whatever_the_object_and_its_pose(
        bracket: PartScene) -> None:
    motor = PartScene.load(CONFIG, DEFAULT_MOTOR, resolution=RESOLUTION)
    seen, rotations = [], []
    for scene, seed in ((bracket, 0), (bracket, 1), (motor, 2)):
        episode = guarded_run(make_planner("uniform5", CONFIG), scene, "free", seed)
        seen.append(sorted(tuple(np.round(view.requested.position, 9))
                           for view in episode.views))
        rotations.append(episode.object_pose.rotation)
        offsets = [view.requested.position - episode.center for view in episode.views]
        assert np.allclose(np.linalg.norm(offsets, axis=1), CONFIG.sensor.working_distance_m)
    # Three poses, two objects: one set of views.
    assert not any(np.allclose(a, b) for a, b in itertools.combinations(rotations, 2))
    assert len(seen[0]) == 5 and seen[0] == seen[1] == seen[2]


@pytest.mark.parametrize("sensor", ["phoxi_m", "zivid2plus_mr60"])
def test_uniform8_with_the_robot_and_a_real_sensor_takes_8_reachable_views_of_the_motor(
        sensor: str) -> None:
    """At these working distances the UR10 reaches no view of the band around the largest
    object the cell fits: the band is screened around the part, reading no model."""
    # Reachability does not depend on the sensing model; the ideal one builds the GT faster.
    config = with_sensing(with_sensor(CONFIG, sensor), "ideal")
    assert len(view_band(config, True)[0]) == 0
    scene = PartScene.load(config, DEFAULT_MOTOR, resolution=RESOLUTION)
    episode = guarded_run(make_planner("uniform8", config), scene, "robot", views=9)
    assert len(episode.views) == 8
    assert all(view.reachable and view.acquired for view in episode.views)
    offsets = [view.requested.position - episode.center for view in episode.views]
    assert np.allclose(np.linalg.norm(offsets, axis=1), config.sensor.working_distance_m)


def test_nbv_never_asks_again_for_a_view_near_an_earlier_one(bracket: PartScene) -> None:
    episode = guarded_run(make_planner("nbv", CONFIG), bracket, "free", views=8)
    directions = np.array([view.requested.position - episode.center for view in episode.views])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    angles = np.degrees(np.arccos(np.clip(directions @ directions.T, -1.0, 1.0)))
    np.fill_diagonal(angles, 180.0)
    assert angles.min() >= EXCLUDE_DEG


# The grid against hand-built scenes: a 21 x 21 pinhole sensor seeing 0.3 to 0.5 m.
SENSOR = SensorModel(resolution=(21, 21), fov_deg=(40.0, 40.0), near_m=0.3, far_m=0.5,
                     working_distance_m=0.4)
VOXEL = 0.02
DOWN = Pose(np.array([0.0, 0.0, 0.4]), np.diag([1.0, -1.0, -1.0]))
"""The sensor 0.4 m above the origin, looking straight down (+z of the sensor is -z)."""


def hits_on_plane(pose: Pose, height: float) -> np.ndarray:
    """Where every pixel's ray meets the horizontal plane z = height (ray-plane intersection)."""
    rays = SENSOR.ray_directions @ pose.rotation.T
    distance = (height - pose.position[2]) / rays[:, 2]
    return pose.position + rays * distance[:, None]


def state_at(grid: OccupancyGrid, point: tuple[float, float, float]) -> int:
    return int(grid.state.reshape(-1)[grid.flat_index(np.array(point))])


def test_a_plane_seen_from_above_is_occupied_free_in_front_unknown_behind() -> None:
    grid = OccupancyGrid.around(np.zeros(3), 0.2, VOXEL)
    grid.integrate(SENSOR, DOWN, hits_on_plane(DOWN, 0.0), np.arange(SENSOR.rays_per_frame))
    # The plane z = 0 lies in the voxel layer [0, 0.02): occupied under every ray.
    assert state_at(grid, (0.01, 0.01, 0.01)) == OCCUPIED
    assert state_at(grid, (-0.09, 0.07, 0.01)) == OCCUPIED
    # In front of the plane within range (0.3 m from the sensor is z = 0.1): free.
    for z in (0.03, 0.05, 0.07):
        assert state_at(grid, (0.01, 0.01, z)) == FREE
    # Closer than the near bound: not observed.
    assert state_at(grid, (0.01, 0.01, 0.15)) == UNKNOWN
    # Behind the plane, and outside the 40-degree frustum (tan 20 * 0.4 = 0.146 m): unknown.
    assert state_at(grid, (0.01, 0.01, -0.05)) == UNKNOWN
    assert state_at(grid, (0.19, 0.19, 0.05)) == UNKNOWN
    # The plane fills the frustum's cross-section at z = 0: 2 * 0.146 m, about 15 voxels across.
    occupied = grid.state[:, :, 10] == OCCUPIED
    assert 14 <= occupied.sum(axis=0).max() <= 16
    assert grid.counts()["occupied"] == occupied.sum()


def test_a_ray_that_measures_nothing_marks_free_space_up_to_the_far_bound() -> None:
    grid = OccupancyGrid.around(np.zeros(3), 0.2, VOXEL)
    grid.integrate(SENSOR, DOWN, np.zeros((0, 3)), np.zeros(0, dtype=int))
    # Range 0.3-0.5 m below the sensor at z = 0.4: z from 0.1 down to -0.1.
    assert [state_at(grid, (0.01, 0.01, z)) for z in (0.15, 0.09, 0.0, -0.09, -0.13)] == [
        UNKNOWN, FREE, FREE, FREE, UNKNOWN]
    assert grid.counts()["occupied"] == 0


def test_a_box_hides_what_is_behind_it_and_blocked_rays_observe_nothing() -> None:
    box = trimesh.creation.box(extents=(0.07, 0.07, 0.07))
    grid = OccupancyGrid.around(np.zeros(3), 0.2, VOXEL)
    rays = SENSOR.ray_directions @ DOWN.rotation.T
    locations, pixels, _ = box.ray.intersects_location(
        np.repeat(DOWN.position[None], len(rays), axis=0), rays, multiple_hits=False)
    assert len(locations) > 0
    # The robot blocks the rays of the left third of the image (image x < 0 is world x < 0).
    columns = np.arange(SENSOR.rays_per_frame) % SENSOR.resolution[0]
    blocked = np.flatnonzero(columns < 7)
    grid.integrate(SENSOR, DOWN, locations, pixels, blocked)
    assert state_at(grid, (0.01, 0.01, 0.03)) == OCCUPIED      # the box's top face, z = 0.035
    assert state_at(grid, (0.01, 0.01, 0.07)) == FREE          # above it
    assert state_at(grid, (0.01, 0.01, -0.01)) == UNKNOWN      # inside and under the box
    assert state_at(grid, (0.09, 0.01, -0.05)) == FREE         # beside it, seen past its edge
    assert state_at(grid, (-0.11, 0.01, 0.05)) == UNKNOWN      # behind the robot's rays


def _first_hits(mesh: trimesh.Trimesh, origin: np.ndarray, directions: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The nearest hit of each ray from `origin` on `mesh`: its points and ray indices, as
    trimesh's `intersects_location(..., multiple_hits=False)` gives them (the same bits on the
    test's scene; the order by ray), at a fraction of its per-ray search's seconds a frame for a
    mesh of a few triangles. Each ray's nearest triangle by Moller-Trumbore against every
    triangle at once, its point where trimesh puts it (`trimesh.intersections.planes_lines`,
    on that triangle's plane)."""
    corners = np.asarray(mesh.triangles)
    first = corners[:, 0]
    edge1, edge2 = corners[:, 1] - first, corners[:, 2] - first
    across = np.cross(directions[:, None, :], edge2[None])  # rays x triangles x 3
    determinant = np.einsum("tk,rtk->rt", edge1, across)
    offset = origin - first
    behind = np.cross(offset, edge1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = 1.0 / determinant
        u = np.einsum("tk,rtk->rt", offset, across) * inverse
        v = (directions @ behind.T) * inverse
        distance = (behind * edge2).sum(axis=1)[None] * inverse
    tolerance = 1e-12
    hit = ((np.abs(determinant) > tolerance) & (u >= -tolerance) & (v >= -tolerance)
           & (u + v <= 1.0 + tolerance) & (distance > tolerance))
    distance = np.where(hit, distance, np.inf)
    rays = np.flatnonzero(np.isfinite(distance.min(axis=1)))
    nearest = distance[rays].argmin(axis=1)
    points, valid = trimesh.intersections.planes_lines(
        plane_origins=corners[nearest, 0], plane_normals=mesh.face_normals[nearest],
        line_origins=np.repeat(origin[None], len(rays), axis=0), line_directions=directions[rays])
    assert valid.all()
    return points, rays


def test_first_hits_are_trimeshs() -> None:
    """`_first_hits` against trimesh's ray casting, on the scene of the test below from another
    pose, in a coarser frame (trimesh takes seconds for a whole one): the same rays hit, at the
    same points."""
    plate = trimesh.creation.box(extents=(0.3, 0.3, 0.01)).apply_translation((0.0, 0.0, -0.03))
    scene = trimesh.util.concatenate([trimesh.creation.box(extents=(0.08, 0.06, 0.05)), plate])
    sensor = SensorModel(resolution=(60, 50), fov_deg=(40.0, 34.0), near_m=0.3, far_m=0.6,
                         working_distance_m=0.45)
    position = np.array([0.12, -0.2, 0.38])
    forward = -position / np.linalg.norm(position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    rays = sensor.ray_directions @ np.column_stack([right, np.cross(forward, right), forward]).T
    expected, pixels, _ = scene.ray.intersects_location(
        np.repeat(position[None], len(rays), axis=0), rays, multiple_hits=False)
    points, hit = _first_hits(scene, position, rays)
    assert 0 < len(hit) < len(rays)
    order = np.argsort(pixels)
    np.testing.assert_array_equal(hit, pixels[order])
    np.testing.assert_array_equal(points, expected[order])


def test_projective_integration_classifies_as_the_sampled_reference_within_one_percent() -> None:
    """The grid's integration (each unknown voxel projected into the frame) against the
    reference it replaced (`sampled_integration`: every ray sampled half a voxel apart), on a
    box on a plate seen by a 240 x 200 sensor from five poses around it, part of one frame
    blocked (1 cm voxels, as the cells' grids): the same voxels occupied, and at most 1.5 % of
    the voxels classified otherwise (1.23 %: the frustum's borders cut more of this small grid
    than of the cells', where `vprobot benchmark grid` measures 0.7-0.9 % on the test lists)."""
    sensor = SensorModel(resolution=(240, 200), fov_deg=(40.0, 34.0), near_m=0.3, far_m=0.6,
                         working_distance_m=0.45)
    plate = trimesh.creation.box(extents=(0.3, 0.3, 0.01)).apply_translation((0.0, 0.0, -0.03))
    scene = trimesh.util.concatenate([trimesh.creation.box(extents=(0.08, 0.06, 0.05)), plate])
    projected, sampled = (OccupancyGrid.around(np.zeros(3), 0.2, VOXEL_M) for _ in range(2))
    rng = np.random.default_rng(3)
    for index in range(5):
        polar, azimuth = np.radians(25.0 + 10.0 * index), rng.uniform(0.0, 2.0 * np.pi)
        position = 0.45 * np.array([np.sin(polar) * np.cos(azimuth),
                                    np.sin(polar) * np.sin(azimuth), np.cos(polar)])
        forward = -position / np.linalg.norm(position)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        pose = Pose(position, np.column_stack([right, np.cross(forward, right), forward]))
        rays = sensor.ray_directions @ pose.rotation.T
        points, pixels = _first_hits(scene, position, rays)  # trimesh's (test_first_hits_...)
        distance = np.linalg.norm(points - position, axis=1)
        kept = sensor.in_range(distance)
        blocked = (np.flatnonzero(np.arange(sensor.rays_per_frame) % sensor.resolution[0] < 30)
                   if index == 2 else np.zeros(0, dtype=int))
        kept &= ~np.isin(pixels, blocked)
        projected.integrate(sensor, pose, points[kept], pixels[kept], blocked)
        sampled_integration(sampled, sensor, pose, points[kept], pixels[kept], blocked)
    assert projected.counts()["free"] > 0.2 * projected.state.size
    assert np.mean(projected.state != sampled.state) <= 0.015
    np.testing.assert_array_equal(projected.state == OCCUPIED, sampled.state == OCCUPIED)


def test_unknown_gain_of_a_ray_through_unknown_space_is_the_hand_computed_series() -> None:
    grid = OccupancyGrid.around(np.zeros(3), 0.4, VOXEL)
    single = SensorModel(resolution=(1, 1), fov_deg=(1.0, 1.0), near_m=0.3, far_m=0.5,
                         working_distance_m=0.4)
    pose = Pose(np.array([0.0, 0.0, 0.39]), np.diag([1.0, -1.0, -1.0]))
    gains = ViewGains(grid, single, [pose], rays=(1, 1))
    samples = len(np.arange(0.3, 0.5 + VOXEL / 2, VOXEL / 2))
    per_sample = UNKNOWN_PASS ** 0.5
    series = (1 - per_sample ** samples) / (1 - per_sample)
    assert gains.score(grid, "unknown")[0] == pytest.approx(series)
    # All three gains at once, over runs of samples in one voxel: the same series for unknown;
    # no free or occupied voxel, so no frontier or rear side.
    np.testing.assert_allclose(gains.camera_scores(grid)[0], [series, 0.0, 0.0], rtol=1e-12)
    # Free space holds nothing to learn; an occupied voxel ends the ray before what it hides.
    grid.state[:] = FREE
    assert gains.score(grid, "unknown")[0] == 0.0
    grid.state[:, :, :] = UNKNOWN
    grid.state.reshape(-1)[grid.flat_index(np.array([0.0, 0.0, 0.085]))] = OCCUPIED
    # Samples at 0.300 and 0.310 m lie in z [0.08, 0.10) (occupied): nothing is seen.
    assert gains.score(grid, "unknown")[0] == 0.0


def test_scores_of_all_gains_at_once_are_score_of_each_sample_by_sample_on_random_grids(
) -> None:
    gains = band_candidates(CONFIG, VOXEL_M).gains
    grid = OccupancyGrid.for_cell(CONFIG)
    rng = np.random.default_rng(0)
    for shares in ((1.0, 0.0, 0.0), (0.5, 0.45, 0.05), (0.2, 0.7, 0.1)):
        grid.state[:] = rng.choice([UNKNOWN, FREE, OCCUPIED], size=grid.shape, p=shares)
        expected = np.stack([gains.score(grid, gain) for gain in GAINS], axis=1)
        assert expected[:, 0].min() > 0.0
        np.testing.assert_allclose(gains.camera_scores(grid), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("threshold", [1e-2, 0.3])
def test_the_runs_walked_to_their_last_relevant_one_are_those_the_whole_table_selects(
        threshold: float) -> None:
    # The reference: every run's visibility over the whole table (what `camera_scores` sums,
    # checked sample by sample above; in single precision, as the walk multiplies), then the
    # runs of a gain seen at `threshold` or better, run by run; the walk drops rays as it goes
    # and must find the same runs, values and order.
    gains = band_candidates(CONFIG, VOXEL_M).gains
    runs = gains._runs
    grid = OccupancyGrid.for_cell(CONFIG)
    rng = np.random.default_rng(2)
    for shares in ((1.0, 0.0, 0.0), (0.1, 0.88, 0.02), (0.3, 0.6, 0.1)):
        grid.state[:] = rng.choice([UNKNOWN, FREE, OCCUPIED], size=grid.shape, p=shares)
        codes = _codes(grid)
        keys, visible = runs.visibility(codes, single=True)
        rows, columns = np.nonzero((runs.kinds(keys[1:]) != 0) & (visible[:-1] >= threshold))
        walked = runs.relevant(codes, threshold)
        assert len(rows) > 0
        for found, expected in zip(walked, (keys[1:][rows, columns], runs.voxels[1:][rows, columns],
                                            columns, visible[:-1][rows, columns]), strict=True):
            np.testing.assert_array_equal(found, expected)


def _next_to_by_hand(state: np.ndarray, kind: int) -> np.ndarray:
    """Whether each voxel has a face neighbour of state `kind`, over the six neighbours of a
    grid padded with a state that is none (a voxel on the border has fewer)."""
    padded = np.pad(state, 1, constant_values=-1)
    near = np.zeros(state.shape, dtype=bool)
    for axis in range(3):
        for step in (-1, 1):
            start = [1, 1, 1]
            start[axis] += step
            near |= padded[tuple(slice(first, first + size)
                                 for first, size in zip(start, state.shape, strict=True))] == kind
    return near


def test_voxel_codes_hold_each_state_and_gain_of_a_neighbour_by_neighbour_count() -> None:
    grid = OccupancyGrid.for_cell(CONFIG)
    rng = np.random.default_rng(3)
    for shares in ((1.0, 0.0, 0.0), (0.3, 0.6, 0.1), (0.1, 0.2, 0.7)):
        grid.state[:] = rng.choice([UNKNOWN, FREE, OCCUPIED], size=grid.shape, p=shares)
        unknown = grid.state == UNKNOWN
        kinds = [unknown, unknown & _next_to_by_hand(grid.state, FREE),
                 unknown & _next_to_by_hand(grid.state, OCCUPIED)]
        for gain, expected in zip(GAINS, kinds, strict=True):
            np.testing.assert_array_equal(grid.kind_mask(gain), expected)
        expected_codes = grid.state.astype(np.uint8) << len(GAINS)
        for bit, mask in enumerate(kinds):
            expected_codes |= mask.astype(np.uint8) << bit
        np.testing.assert_array_equal(
            _codes(grid), np.append(expected_codes.reshape(-1), np.uint8(FREE << len(GAINS))))
        for kind in (FREE, OCCUPIED):
            np.testing.assert_array_equal(grid.next_to(kind), _next_to_by_hand(grid.state, kind))


def test_flat_index_finds_the_voxel_of_points_inside_it_and_minus_one_outside() -> None:
    grid = OccupancyGrid.around(np.array([0.3, -0.2, 0.7]), 0.1, VOXEL)
    rng = np.random.default_rng(1)
    cells = rng.integers(0, grid.shape[0], (500, 3))
    # Anywhere in a voxel but within a tenth of a voxel of its faces (no rounding question).
    points = grid.origin + (cells + rng.uniform(0.1, 0.9, (500, 3))) * VOXEL
    expected = [(i * grid.shape[1] + j) * grid.shape[2] + k for i, j, k in cells]
    np.testing.assert_array_equal(grid.flat_index(points), expected)
    outside = points.copy()
    outside[np.arange(500), rng.integers(0, 3, 500)] += rng.choice([-1.0, 1.0], 500) * 0.25
    np.testing.assert_array_equal(grid.flat_index(outside), -1)
    assert grid.flat_index(points.reshape(50, 10, 3)).shape == (50, 10)


@pytest.mark.parametrize("spec, message", [
    ("uniform0", "unknown planner 'uniform0'"),
    ("uniform<k>", "unknown planner 'uniform<k>'"),
    ("nbv:bogus", "unknown gain 'bogus'; allowed: unknown, frontier, rear_side"),
])
def test_bad_model_free_planner_names_are_clear_errors(spec: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make_planner(parse_planner(spec)[0], CONFIG)


def test_uniform_takes_its_count_from_the_name_not_from_views() -> None:
    assert parse_planner("uniform6", counted=False) == ("uniform6", None)
    with pytest.raises(ValueError, match=r"applies to (\w+, )*bscp(, \w+)* only, not to "
                                         r"'uniform4'"):
        make_planner("uniform4", CONFIG, views=5)


def test_parse_accepts_every_model_free_form() -> None:
    for spec in ("uniform1", "uniform12", "nbv", "nbv:frontier", "nbv@grid",
                 "nbv:rear_side@grid", "nbv@views:5", "nbv:frontier@estimate:0.9"):
        assert parse_planner(spec) == (spec, None)


def test_the_arm_blocks_a_point_behind_its_own_links_but_not_one_in_front_of_the_sensor(
        bracket: PartScene) -> None:
    home = bracket.cell.joints.start
    sensor = bracket.arm.fk(home)
    base = bracket.cell.robot_base.position
    assert bracket.arm.hides(home, base)
    assert not bracket.arm.hides(home, sensor.position + 0.2 * sensor.view_axis)


def test_plan_with_a_self_stopped_nbv_says_why_it_stopped(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    from vprobot.cli import main

    plan = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--planner", "nbv@grid", "--carrier", "free", "--out",
                 str(plan)]) == 0
    document = json.loads(plan.read_text())
    assert document["planner"] == "nbv@grid"
    assert document["stop_reason"].startswith("grid: the latest 2 views")
    assert "stopped by the planner: grid" in capsys.readouterr().out
