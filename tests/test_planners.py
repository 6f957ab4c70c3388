"""Planners: set cover on a cube, greedy and ordering properties, plan export, honest records."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from dh_reference import quaternion_matrix, rotation_difference, world_sensor

from vprobot.cell.scene import Cell
from vprobot.config import Config, replace, with_sensing, with_sensor
from vprobot.config.sensor import SensorModel
from vprobot.coverage.tracker import CoverageTracker
from vprobot.episode import Episode, EpisodeSpec, PartScene, ViewRequest, seeded_episode
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import Pose
from vprobot.kinematics import TRAVEL_COSTS, SensorTarget, TravelCost
from vprobot.kinematics.travel import joint_time
from vprobot.plan import write_json
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.greedy import greedy_cover
from vprobot.planners.hrec import BoxFacesPlanner
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.oracle import OraclePlanner
from vprobot.planners.ordering import LazyCosts, cost_matrix, order_views, path_cost
from vprobot.planners.proof import ExactPlanner, Proof
from vprobot.planners.random_views import Random1Planner, Random2Planner
from vprobot.planners.runner import (
    PLAN_RAN_OUT,
    counted_planners,
    make_planner,
    parse_planner,
    plan_part,
    run,
    run_episode,
)
from vprobot.planners.self_stopping import SelfStopping
from vprobot.planners.visibility import VisibilityRenderer
from vprobot.sensing import IDEAL
from vprobot.stopping.rules import make_stop_rule

CONFIG = Config()


@pytest.fixture(scope="module")
def millimetre_cube(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 150 mm cube stored in millimetres, as a user's CAD export would be."""
    path = tmp_path_factory.mktemp("meshes") / "cube_mm.stl"
    trimesh.creation.box(extents=(150.0, 150.0, 150.0)).export(path)
    return path


@pytest.fixture(scope="module")
def motor() -> PartScene:
    return PartScene.load(CONFIG, DEFAULT_MOTOR)


def episode_of(scene: PartScene, seed: int, robot: bool) -> tuple[Episode, EpisodeSpec,
                                                                  np.random.Generator]:
    spec = seeded_episode(CONFIG.env, scene.mesh.path, seed, scene.mesh.scale)
    return (Episode.from_spec(scene, spec, "robot" if robot else "free"), spec,
            np.random.default_rng(seed))


def test_bscp_free_flying_covers_a_cube(millimetre_cube: Path) -> None:
    scene = PartScene.load(CONFIG, millimetre_cube, scale=0.001)
    episode, spec, rng = episode_of(scene, seed=0, robot=False)
    planner = SetCoverPlanner(goal=0.95, max_views=6, candidate_count=300)
    record = run_episode(planner, episode, spec, CONFIG, rng).record
    assert record.coverage >= 0.95
    assert len(record.views) <= 6
    # Every pick was confirmed by a simulated acquisition: the plan measured what it predicted.
    assert sum(planner.gains) == pytest.approx(record.coverage * 2048, abs=2)


def test_five_set_cover_views_free_flying_cover_the_motor_as_in_the_paper(
        motor: PartScene) -> None:
    # The paper's B_SCP,5 covers 98.17 % of its motors; docs/benchmarks.md#measured-figures
    # holds ours to that within 3 pp.
    episode, spec, rng = episode_of(motor, seed=0, robot=False)
    record = run_episode(make_planner("bscp", CONFIG, views=5), episode, spec, CONFIG, rng).record
    assert len(record.views) == 5
    assert record.coverage >= 0.95


@pytest.mark.parametrize("seed", range(5))
def test_greedy_gains_are_non_increasing(seed: int) -> None:
    rng = np.random.default_rng(seed)
    visibility = rng.random((60, 400)) < rng.uniform(0.05, 0.4, size=(60, 1))
    covered = rng.random(400) < 0.1
    picks, gains = greedy_cover(visibility, covered, count=20)
    assert all(a >= b for a, b in itertools.pairwise(gains))
    assert len(set(picks)) == len(picks)
    union = covered | visibility[picks].any(axis=0)
    assert union.sum() - covered.sum() == sum(gains)
    # Each pick is the best one at its step.
    state = covered.copy()
    for pick, gain in zip(picks, gains, strict=True):
        assert gain == np.count_nonzero(visibility & ~state, axis=1).max()
        state |= visibility[pick]
    goal_picks, _ = greedy_cover(visibility, covered, count=60, goal=0.8)
    reached = (covered | visibility[goal_picks].any(axis=0)).mean()
    assert reached >= 0.8 or len(goal_picks) == 60
    assert (covered | visibility[goal_picks[:-1]].any(axis=0)).mean() < 0.8


def test_ordering_never_lengthens_travel() -> None:
    rng = np.random.default_rng(7)
    velocity = Cell(CONFIG).joints.velocity_limits
    for trial in range(40):
        count = rng.integers(1, 9)
        if trial % 2:
            configurations = rng.uniform(-np.pi, np.pi, size=(count + 1, 6))
            cost = cost_matrix(list(configurations), lambda a, b: joint_time(a, b, velocity))
        else:
            cost = rng.uniform(0.0, 1.0, size=(count + 1, count + 1))  # asymmetric
        given = list(rng.permutation(np.arange(1, count + 1)))
        for start in (0, None):
            nodes = given if start is not None else [0, *given]
            order = order_views(cost, start, nodes)
            assert sorted(order) == sorted(nodes)
            assert path_cost(cost, start, order) <= path_cost(cost, start, nodes) + 1e-12


def test_costs_computed_as_read_give_the_order_of_the_whole_matrix_from_fewer_entries(
        ) -> None:
    rng = np.random.default_rng(11)
    for count in range(1, 10):
        cost = rng.uniform(0.0, 1.0, size=(count + 1, count + 1))  # asymmetric
        read: list[tuple[int, int]] = []

        def entry(a: int, b: int, matrix: np.ndarray = cost,
                  log: list[tuple[int, int]] = read) -> float:
            log.append((a, b))
            return float(matrix[a, b])

        nodes = list(rng.permutation(np.arange(1, count + 1)))
        lazy = LazyCosts(count + 1, entry)
        assert order_views(lazy, 0, nodes) == order_views(cost, 0, nodes)
        # Each entry is computed once; none back to the start or in place.
        assert len(read) == len(set(read))
        assert all(b != 0 and a != b for a, b in read)
        assert len(read) <= count * count
    # Of a larger plan's moves, not all are read.
    assert len(read) < count * count


def test_ordered_plan_is_not_longer_than_the_greedy_order(motor: PartScene) -> None:
    episode, spec, rng = episode_of(motor, seed=1, robot=True)
    planner = SetCoverPlanner(views=5, candidate_count=300)
    record = run_episode(planner, episode, spec, CONFIG, rng).record
    candidates = planner.candidates
    velocity = motor.cell.joints.velocity_limits
    greedy = [record.start_joints, *(candidates.joints[i] for i in planner.picks)]
    unordered = sum(joint_time(a, b, velocity) for a, b in itertools.pairwise(greedy))
    assert all(view.reachable for view in record.views)
    assert (record.approach + record.travel_sum).joint_time <= unordered + 1e-9


class _Proven(ExactPlanner, SelfStopping):
    """An exact planner that proves a one-view plan and plans nothing."""

    name = "proven"

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self.proof = Proof(proven=True, bound=1, gap_views=0)

    def next_view(self, episode: Episode) -> ViewRequest | None:
        return None


class _FromInitialView(InitialViewPlanner, _Proven):
    """The same, starting from the environment's initial view."""


def test_the_runner_reports_what_a_planner_has_and_only_that(motor: PartScene) -> None:
    spec = seeded_episode(CONFIG.env, motor.mesh.path, 0, motor.mesh.scale)
    goal = make_stop_rule("goal", CONFIG)
    bscp = SetCoverPlanner(views=2, candidate_count=100)
    result = run(CONFIG, motor, "bscp", spec, "free", built=(bscp, goal))
    assert result.candidates is bscp.candidates and len(result.candidates) == 100
    assert result.proof is None and result.requested == 2
    hrec = run(CONFIG, motor, "hrec", spec, "free", built=(BoxFacesPlanner(), goal))
    assert hrec.candidates is None and hrec.proof is None
    for planner, requested in ((_Proven(), 0), (_FromInitialView(), 1)):
        proven = run(CONFIG, motor, "proven", spec, "free", built=(planner, goal))
        assert proven.proof == Proof(proven=True, bound=1, gap_views=0)
        assert (proven.candidates, proven.requested) == (None, requested)
        assert (proven.stop_reason, proven.planner_stopped) == (PLAN_RAN_OUT, True)


@pytest.fixture(scope="module")
def bscp_plan() -> tuple[object, object, dict, str]:
    return plan_part(CONFIG, planner="bscp", seed=0)


def test_exported_plan_reproduces_sensor_poses_by_fk(bscp_plan: tuple, tmp_path: Path) -> None:
    _, _, document, text = bscp_plan
    assert {"object", "robot", "sensor", "views", "coverage"} <= set(document)
    assert set(document["object"]) >= {"mesh", "position", "quaternion", "scale"}
    assert document["coverage"] >= CONFIG.env.coverage_goal
    assert "coverage" in text and "bscp" in text
    json.loads(write_json(tmp_path / "plan.json", document).read_text())
    previous = 0.0
    for view in document["views"]:
        assert view["reachable"] is True
        # Independent FK: the published DH parameters, base and mount from the config.
        pose = world_sensor(np.array(view["joints"]), CONFIG)
        assert np.linalg.norm(pose[:3, 3] - view["position"]) <= 1e-3
        expected = quaternion_matrix(view["quaternion"])
        assert rotation_difference(pose[:3, :3], expected) <= 1e-3
        assert view["coverage"] >= previous
        previous = view["coverage"]
        assert set(view["travel"]) == set(TRAVEL_COSTS)
    assert previous == pytest.approx(document["coverage"])


def test_plan_carries_what_re_checks_its_coverage(bscp_plan: tuple) -> None:
    """A third party's check from the JSON alone: the coverage after each view follows from the
    per-point first-covering view, and each point lies in the frustum and range of the view
    that covered it (plain geometry on the exported poses and sensor block)."""
    _, record, document, _ = bscp_plan
    gt = document["ground_truth"]
    points = np.array(gt["points"])
    first = np.array(gt["first_covered_by_view"])
    assert points.shape == (2048, 3) and first.shape == (2048,)
    assert 0.001 < gt["epsilon_m"] < 0.005
    np.testing.assert_allclose(points, record.gt_points_world, atol=1e-6)
    sensor = document["sensor"]
    half_tangent = np.tan(np.deg2rad(np.array(sensor["fov_deg"])) / 2.0)
    near, far = sensor["range"]
    for index, view in enumerate(document["views"]):
        assert view["coverage"] == pytest.approx(np.mean((first >= 0) & (first <= index)))
        local = (points[first == index] - view["position"]) @ quaternion_matrix(
            view["quaternion"])
        assert len(local) > 0
        slack = gt["epsilon_m"] / local[:, 2:3]
        assert np.all(np.abs(local[:, :2] / local[:, 2:3]) <= half_tangent + slack)
        distance = np.linalg.norm(local, axis=1)
        assert np.all((distance >= near - gt["epsilon_m"]) & (distance <= far + gt["epsilon_m"]))
    # The approach is reported on its own; the travel total sums the later moves only.
    steps = [view["travel"] for view in document["views"]]
    assert document["approach"] == steps[0]
    for name, total in document["travel_sum"].items():
        assert total == pytest.approx(sum(step[name] for step in steps[1:]))


def _placed_file_bounds(document: dict) -> np.ndarray:
    """Bounds of the mesh file's own vertices placed as the object block says."""
    block = document["object"]
    vertices = trimesh.load(block["mesh"], process=False).vertices * block["scale"]
    rotation = Pose.from_quat(block["position"], block["quaternion"]).rotation
    placed = vertices @ rotation.T + block["position"]
    return np.array([placed.min(axis=0), placed.max(axis=0)])


def test_object_block_places_the_file_as_stored(bscp_plan: tuple, motor: PartScene) -> None:
    _, record, document, _ = bscp_plan
    world = motor.mesh.mesh.vertices @ record.object_pose.rotation.T + record.object_pose.position
    np.testing.assert_allclose(_placed_file_bounds(document),
                               [world.min(axis=0), world.max(axis=0)], atol=1e-6)


PLANNERS = {
    "random1": lambda: Random1Planner(CONFIG),
    "random2": lambda: Random2Planner(CONFIG),
    "hrec": BoxFacesPlanner,
    "bscp": lambda: SetCoverPlanner(candidate_count=200),
    "oracle": lambda: OraclePlanner(candidate_count=200),
}


@pytest.mark.parametrize("name", PLANNERS)
def test_no_planner_reports_an_unreachable_view_as_executed(name: str,
                                                            motor: PartScene) -> None:
    episode, spec, rng = episode_of(motor, seed=2, robot=True)
    record = run_episode(PLANNERS[name](), episode, spec, CONFIG, rng).record
    arm = motor.arm
    joints, coverage = record.start_joints, 0.0
    for view in record.views:
        if view.reachable:
            assert view.sensor_pose is not None and view.path is not None
            np.testing.assert_allclose(arm.fk(view.joints).position, view.sensor_pose.position,
                                       atol=1e-9)
            assert not episode.carrier.collisions.in_collision(view.joints)
            np.testing.assert_allclose(view.path[0], joints)
            np.testing.assert_allclose(view.path[-1], view.joints)
        else:
            assert view.reason is not None and view.sensor_pose is None and view.path is None
            assert len(view.points_world) == 0 and view.travel == TravelCost()
            np.testing.assert_array_equal(view.joints, joints)
            assert view.coverage == coverage
        joints, coverage = view.joints, view.coverage
    if name == "random1":
        assert not all(view.reachable for view in record.views)


def test_user_mesh_in_millimetres_plans(millimetre_cube: Path) -> None:
    _, record, document, text = plan_part(CONFIG, mesh_path=millimetre_cube, scale=0.001)
    assert document["object"]["scale"] == 0.001
    assert record.coverage >= CONFIG.env.coverage_goal
    assert all(view.reachable for view in record.views)
    world = (PartScene.load(CONFIG, millimetre_cube, scale=0.001).mesh.mesh.vertices
             @ record.object_pose.rotation.T + record.object_pose.position)
    np.testing.assert_allclose(_placed_file_bounds(document),
                               [world.min(axis=0), world.max(axis=0)], atol=1e-6)
    assert "cube_mm.stl" in text


def test_predicted_visibility_agrees_with_the_sensor(motor: PartScene) -> None:
    episode, _, _ = episode_of(motor, seed=3, robot=False)
    tracker = CoverageTracker.from_ground_truth(motor.ground_truth)
    renderer = VisibilityRenderer(motor.mesh.mesh, SensorModel.from_config(CONFIG.sensor),
                                  tolerance_m=tracker.epsilon)
    center, to_mesh = episode.center, episode.object_pose.inverse()
    directions = np.array([[1.0, 0.0, 0.3], [0.0, -1.0, 0.5], [-0.6, 0.6, 0.6], [0.0, 0.0, 1.0],
                           [0.3, 0.9, -0.3]])
    poses = [Pose.look_at(center + 0.47 * d / np.linalg.norm(d), center) for d in directions]
    predicted = renderer.visible([to_mesh.compose(pose) for pose in poses],
                                 motor.ground_truth.points)
    measured = np.array([episode.preview(ViewRequest(SensorTarget(pose, roll_free=False)))
                         for pose in poses])
    # The prediction is coarse near edges and grazing surfaces, which the greedy confirms by
    # simulated acquisitions; on the whole it must agree with the sensor.
    jaccard = (predicted & measured).sum(axis=1) / (predicted | measured).sum(axis=1)
    assert jaccard.min() >= 0.7
    assert (predicted & measured).sum() / (predicted | measured).sum() >= 0.85


def test_predicted_visibility_follows_the_structured_light_limits() -> None:
    """With the Zivid's structured light the prediction keeps to the projector's shadow and the
    incidence limits: it agrees with the modelled sensor's frames better than an ideal
    prediction does and predicts far fewer points the frames do not measure. (It misses some
    that they do: a GT point on a grazing facet within ε of a measured neighbouring facet
    counts as measured, whereas the prediction judges its own facet; 0.76 overall.)"""
    config = with_sensing(with_sensor(CONFIG, "zivid2plus_mr60"), "structured_light")
    scene = PartScene.load(config, DEFAULT_MOTOR)
    episode, _, _ = episode_of(scene, seed=3, robot=False)
    epsilon = CoverageTracker.from_ground_truth(scene.ground_truth).epsilon
    center, to_mesh = episode.center, episode.object_pose.inverse()
    directions = np.array([[1.0, 0.0, 0.3], [0.0, -1.0, 0.5], [-0.6, 0.6, 0.6], [0.0, 0.0, 1.0],
                           [0.3, 0.9, -0.3]])
    distance = config.sensor.working_distance_m
    poses = [Pose.look_at(center + distance * d / np.linalg.norm(d), center) for d in directions]
    measured = np.array([episode.preview(ViewRequest(SensorTarget(pose, roll_free=False)))
                         for pose in poses])

    def agreement(sensing: object) -> tuple[float, int]:
        renderer = VisibilityRenderer(scene.mesh.mesh, SensorModel.from_config(config.sensor),
                                      tolerance_m=epsilon, sensing=sensing)
        predicted = renderer.visible([to_mesh.compose(pose) for pose in poses],
                                     scene.ground_truth.points)
        return ((predicted & measured).sum() / (predicted | measured).sum(),
                int((predicted & ~measured).sum()))

    (modelled, modelled_extra), (ideal, ideal_extra) = (agreement(config.sensor.sensing_model),
                                                        agreement(IDEAL))
    assert modelled >= 0.72 and modelled > ideal + 0.05
    assert modelled_extra < ideal_extra / 4


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: make_planner("astar", CONFIG), "unknown planner 'astar'"),
        (lambda: make_planner("hrec", CONFIG, views=4),
         f"applies to {', '.join(counted_planners())} only, not to 'hrec'"),
        (lambda: parse_planner("bscp0"), "unknown planner 'bscp0'"),
        (lambda: SetCoverPlanner(views=0), "views must lie in 1..100"),
        (lambda: SetCoverPlanner(goal=1.5), "goal must lie in (0, 1]"),
        (lambda: VisibilityRenderer(trimesh.creation.box(),
                                           SensorModel.from_config(CONFIG.sensor),
                                           resolution=(1, 5)),
         "resolution must be two integers >= 2"),
        (lambda: order_views(np.zeros((2, 3)), 0, [1]), "square"),
    ],
)
def test_bad_arguments_are_clear_errors(call: object, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()


def test_parse_planner() -> None:
    assert parse_planner("bscp5") == ("bscp", 5)
    assert parse_planner("random1") == ("random1", None)
    assert parse_planner("agent6") == ("agent", 6)
    assert parse_planner("agent:runs/cpu") == ("agent:runs/cpu", None)
    for bad in ("agent:", "agent0", "hrec3"):
        with pytest.raises(ValueError, match="unknown planner"):
            parse_planner(bad)


def test_the_robots_view_band_is_screened_once_per_cell_and_read_back_from_the_cache(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Another process (the memory cache cleared) reads the band instead of screening it; a
    setting that cannot change it (the resolution) finds it too, one of the cell does not, and
    a damaged file is screened again."""
    from vprobot.planners import uniform

    monkeypatch.setenv("VPROBOT_CACHE_DIR", str(tmp_path))
    band = uniform._band()[:5]
    screened: list[float] = []

    def screen(*args: object) -> tuple[np.ndarray, np.ndarray]:
        screened.append(len(screened))
        return band, np.arange(30.0).reshape(5, 6) + len(screened)

    monkeypatch.setattr(uniform, "_reachable_band", screen)

    def fresh(config: Config) -> tuple[np.ndarray, np.ndarray | None]:
        uniform.view_band.cache_clear()
        return uniform.view_band(config, True)

    try:
        directions, joints = fresh(CONFIG)
        assert len(screened) == 1 and np.array_equal(directions, band)
        again = fresh(replace(CONFIG, "sensor", resolution=(43, 30)))
        assert len(screened) == 1
        assert np.array_equal(again[0], band) and np.array_equal(again[1], joints)
        fresh(replace(CONFIG, "cell", object_center_m=(0.45, 0.0, 0.76)))
        assert len(screened) == 2
        for path in (tmp_path / "view_band").glob("*.npz"):
            path.write_bytes(b"not an npz")
        assert not np.array_equal(fresh(CONFIG)[1], joints) and len(screened) == 3
        assert not np.array_equal(fresh(CONFIG)[1], joints) and len(screened) == 3
    finally:
        uniform.view_band.cache_clear()


def test_uniform_targets_beyond_the_usable_band_name_the_count_and_the_way_out(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The Panda cannot hold the PhoXi M at its working distance (0.79 m) around the motor:
    neither around the largest object the cell fits nor around the part itself does the band
    leave 4 views, and the error says how many are usable and what to do, not an index range."""
    from vprobot.planners import uniform
    from vprobot.planners.uniform import uniform_targets, view_band

    # The episode's band screened once (seconds of inverse kinematics), here and again in
    # uniform_targets: the same episode in the same configuration, so the same band.
    screened: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    original = uniform.episode_band

    def episode_band(config: Config, episode: Episode) -> tuple[np.ndarray, np.ndarray]:
        if id(episode) not in screened:
            screened[id(episode)] = original(config, episode)
        return screened[id(episode)]

    monkeypatch.setattr(uniform, "episode_band", episode_band)
    config = replace(with_sensing(with_sensor(CONFIG, "phoxi_m"), "ideal"), "cell",
                     robot="panda")
    episode = Episode.from_spec(PartScene.load(config, DEFAULT_MOTOR, resolution=(43, 30)),
                                seeded_episode(config.env, DEFAULT_MOTOR, 0), "robot")
    enveloped, usable = len(view_band(config, True)[0]), len(episode_band(config, episode)[0])
    assert enveloped < 4 and usable < 4
    with pytest.raises(ValueError, match=rf"uniform4 needs 4 views of the band, but only "
                                         rf"{usable} are usable with robot 'panda'.* around this "
                                         rf"part at its pose \({enveloped} around the largest "
                                         rf"object.*--carrier free"):
        uniform_targets(config, 4, episode)
