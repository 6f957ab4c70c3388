"""The inspection engine: carriers, explicit state, episode specs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vprobot.config import Config, replace
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import OCCUPIED, GridSettings, OccupancyGrid
from vprobot.episode import (
    Episode,
    EpisodeSpec,
    PartScene,
    ViewRequest,
    describe_cycle,
    seeded_episode,
)
from vprobot.episode.specs import FALLBACK_INITIAL_VIEWS
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import rotation_about_x, rotation_about_z
from vprobot.kinematics import SensorTarget, TravelCost
from vprobot.planners.runner import run, summary
from vprobot.stopping.features import FEATURES, CoverageFeatures, episode_features

CONFIG = Config()
DIRECTIONS = [(0.0, 1.0), (2.0, 1.1), (4.0, 0.8), (1.0, 1.9)]


@pytest.fixture(scope="module")
def scene() -> PartScene:
    return PartScene.load(CONFIG, DEFAULT_MOTOR, resolution=(107, 75))


def _requests(episode: Episode) -> list[ViewRequest]:
    center = episode.center
    spec = EpisodeSpec(part="unused", object_quaternion=(1.0, 0.0, 0.0, 0.0),
                       initial_views=tuple(DIRECTIONS), seed=0)
    # The spec's own views, without the fallbacks after them.
    return spec.initial_requests(center, CONFIG.sensor.working_distance_m)[:len(DIRECTIONS)]


def _trace(episode: Episode) -> list[tuple]:
    return [(view.reachable, view.reason, view.coverage, len(view.points_world))
            for view in episode.views]


def test_interleaved_episodes_do_not_share_state(scene: PartScene) -> None:
    """Two episodes of one scene, object turned differently, stepped in turn, give what each
    gives alone: no consumer reads another episode's object placement or configuration."""
    rotations = [np.eye(3), rotation_about_x(0.4) @ rotation_about_z(2.0)]
    alone = []
    for rotation in rotations:
        episode = Episode(scene, rotation)
        for request in _requests(episode):
            episode.request(request)
        alone.append(_trace(episode))
    assert alone[0] != alone[1]
    together = [Episode(scene, rotation) for rotation in rotations]
    requests = [_requests(episode) for episode in together]
    for step in range(len(DIRECTIONS)):
        for episode, own in zip(together, requests, strict=True):
            episode.request(own[step])
            # FK and collision checks of the other episode's arm in between.
            scene.arm.reach(own[-1].target, scene.cell.joints.start)
    assert [_trace(episode) for episode in together] == alone


def test_only_a_robot_episode_has_a_robot(scene: PartScene) -> None:
    robot = Episode(scene, np.eye(3))
    assert robot.robot is robot.carrier and robot.robot.collisions is not None
    with pytest.raises(RuntimeError, match="the free carrier has no robot"):
        _ = Episode(scene, np.eye(3), carrier="free").robot


def test_free_carrier_acquires_exactly_at_every_request(scene: PartScene) -> None:
    episode = Episode(scene, np.eye(3), carrier="free")
    below = SensorTarget.look_at(episode.center + [0.0, 0.0, -0.47], episode.center)
    for request in [*_requests(episode), ViewRequest(below)]:
        view = episode.request(request)
        assert view.reachable and view.reason is None and view.joints is None
        np.testing.assert_array_equal(view.sensor_pose.position, request.target.pose.position)
    first, second = episode.views[0], episode.views[1]
    assert first.travel.paper == 0.0 and second.travel.paper > 0.0
    assert second.travel.joint_time == 0.0
    assert second.travel.cartesian == pytest.approx(np.linalg.norm(
        second.sensor_pose.position - first.sensor_pose.position))
    with pytest.raises(ValueError, match="robot carrier"):
        episode.replay(scene.cell.joints.start)


def test_record_reports_the_first_covering_view(scene: PartScene) -> None:
    episode = Episode(scene, np.eye(3))
    for request in _requests(episode):
        episode.request(request)
    record = episode.record()
    for index, view in enumerate(record.views):
        reached = (record.first_covered_by >= 0) & (record.first_covered_by <= index)
        assert reached.mean() == pytest.approx(view.coverage)
    assert record.approach == record.views[0].travel
    assert record.travel_sum == sum((view.travel for view in record.views[1:]),
                                    start=type(record.travel_sum)())


def test_spec_round_trip_and_clear_errors() -> None:
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 4)
    assert spec.part == "test/motor_000.stl" and spec.part_path == DEFAULT_MOTOR
    assert EpisodeSpec.from_dict(spec.as_dict()) == spec
    # Lists written before any object was called a part name it `motor`.
    former = {("motor" if key == "part" else key): value for key, value in spec.as_dict().items()}
    assert "motor" in former and EpisodeSpec.from_dict(former) == spec
    assert seeded_episode(CONFIG.env, DEFAULT_MOTOR, 5) != spec
    bad = {**spec.as_dict(), "initial_views": [[1.0]]}
    with pytest.raises(ValueError, match="initial_views"):
        EpisodeSpec.from_dict(bad)
    with pytest.raises(ValueError, match="unknown episode spec key 'pose'"):
        EpisodeSpec.from_dict({**spec.as_dict(), "pose": 1})
    with pytest.raises(ValueError, match="seed"):
        EpisodeSpec.from_dict({**spec.as_dict(), "seed": -1})


def test_the_cycle_time_is_the_sum_of_the_steps_and_the_return_home(scene: PartScene) -> None:
    """The cycle (docs/motion.md#cycle-time) timed as a whole equals what the steps' `cycle_time`
    costs add up to (each move timed alone plus its acquisition) plus the return, timed alone;
    the return closes the loop at the start."""
    episode = Episode(scene, np.eye(3))
    for request in _requests(episode):
        episode.request(request)
    record = episode.record()
    acquired = [view for view in record.views if view.acquired]
    assert len(acquired) >= 2
    np.testing.assert_array_equal(record.return_waypoints[0], acquired[-1].joints)
    np.testing.assert_array_equal(record.return_waypoints[-1], record.start_joints)
    timed = record.timed
    acquisition = scene.cell.config.sensor.acquisition_time_s
    back = scene.arm.move_time(record.return_waypoints)
    assert timed.cycle.total_s == pytest.approx(
        record.approach.cycle_time + record.travel_sum.cycle_time + back, rel=1e-12)
    assert timed.cycle.acquisitions_s == pytest.approx(len(acquired) * acquisition)
    assert timed.cycle.return_s == pytest.approx(back, rel=1e-12)
    # A move that stands still costs its acquisition alone.
    still = scene.arm.travel(record.start_joints, record.start_joints, episode.center)
    assert still.cycle_time == acquisition
    # No robot, no cycle.
    free = Episode(scene, np.eye(3), carrier="free")
    free.request(_requests(free)[0])
    assert free.record().return_waypoints is None and free.record().timed is None


def test_plans_summary_reports_the_cycle_time_and_its_parts(scene: PartScene) -> None:
    """`plan`'s summary gives the robot's cycle time (docs/motion.md#cycle-time) with its parts,
    each as the cycle timed whole has it: the approach and the return are the moves from and to
    the start alone, the acquisitions a stop per acquired view."""
    spec = seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0)
    result = run(CONFIG, scene, "hrec", spec, "robot")
    record, cycle = result.record, result.cycle
    acquired = [view for view in record.views if view.acquired]
    assert cycle.approach_s == pytest.approx(scene.arm.move_time(acquired[0].waypoints))
    assert cycle.return_s == pytest.approx(scene.arm.move_time(record.return_waypoints))
    assert cycle.acquisitions_s == pytest.approx(
        len(acquired) * CONFIG.sensor.acquisition_time_s)
    assert cycle.moves_s == pytest.approx(sum(scene.arm.move_time(view.waypoints)
                                              for view in acquired[1:]))
    line = (f"  cycle time {cycle.total_s:.2f} s: approach {cycle.approach_s:.2f} s, moves "
            f"{cycle.moves_s:.2f} s, acquisitions {cycle.acquisitions_s:.2f} s, return "
            f"{cycle.return_s:.2f} s")
    assert line in summary(result, CONFIG).splitlines()
    # Without a path home there is no cycle, and the summary says why; a free sensor has none.
    stranded = dataclasses.replace(record, return_waypoints=None, timed=None)
    assert stranded.cycle is None
    assert describe_cycle(stranded) == (
        "cycle time: none (no path back to the start was found)")
    free = run(CONFIG, scene, "hrec", spec, "free")
    assert free.cycle is None and "cycle time" not in summary(free, CONFIG)


def test_a_robot_that_misses_the_spec_initial_view_starts_from_the_nearest_it_reaches() -> None:
    """The UR5 does not reach the paper's fixed initial view around the default motor; the
    fallbacks after it are the band's directions nearest it, and the episode begins there."""
    config = replace(CONFIG, "cell", robot="ur5")
    scene = PartScene.load(config, DEFAULT_MOTOR, resolution=(107, 75))
    spec = seeded_episode(config.env, DEFAULT_MOTOR, 0)
    episode = Episode.from_spec(scene, spec)
    requests = spec.initial_requests(episode.center, config.sensor.working_distance_m)
    first, *fallbacks = requests
    assert len(fallbacks) == FALLBACK_INITIAL_VIEWS
    with pytest.raises(ValueError, match="none of the 1 initial views is reachable"):
        Episode.from_spec(scene, spec).begin([first])
    view = episode.begin(requests)
    # The views' look-at directions: the fallbacks by growing angle from the first.
    def direction(request: ViewRequest) -> np.ndarray:
        offset = request.target.pose.position - episode.center
        return offset / np.linalg.norm(offset)
    angles = [np.arccos(np.clip(direction(r) @ direction(first), -1, 1)) for r in fallbacks]
    assert angles == sorted(angles) and angles[0] > 0
    taken = next(r for r in fallbacks if np.allclose(r.target.pose.position,
                                                     view.requested.position))
    assert view.acquired and direction(taken) @ direction(first) > np.cos(np.radians(60))


def _travel_from_scratch(views: list) -> tuple[dict[str, float], dict[str, float]]:
    """The approach (the move to the first acquisition) and k_cum (every move after it), summed
    field by field over the views, as docs/states-actions-rewards.md#travel-costs defines them."""
    names = [field.name for field in dataclasses.fields(TravelCost)]
    approach = dict.fromkeys(names, 0.0)
    total = dict.fromkeys(names, 0.0)
    first = next((index for index, view in enumerate(views) if view.acquired), len(views))
    for index, view in enumerate(views):
        if index == first:
            approach = {name: getattr(view.travel, name) for name in names}
        elif index > first:
            for name in names:
                total[name] += getattr(view.travel, name)
    return approach, total


@pytest.mark.parametrize("carrier", ["robot", "free"])
def test_the_running_travel_sums_equal_the_sums_over_the_views_from_scratch(
        scene: PartScene, carrier: str) -> None:
    episode = Episode(scene, np.eye(3), carrier)
    requests = _requests(episode)
    # A request skipped before the first acquisition, and one skipped between acquisitions.
    episode.skip(requests[0].target.pose, "collision")
    seen = []
    for request in (*requests, requests[1]):
        episode.request(request)
        if len(episode.views) == 3:
            episode.skip(requests[2].target.pose, "collision")
        seen.append((episode.approach.as_dict(), episode.travel_sum.as_dict()))
        assert seen[-1] == _travel_from_scratch(episode.views)
    assert seen[-1][1]["cartesian"] > 0.0


def test_the_episodes_grid_after_each_view_and_its_features_are_those_integrated_from_scratch(
        scene: PartScene) -> None:
    """The episode integrates each frame once and reads the grid after any earlier view back
    from what each frame changed; the grid, the share of occupied voxels a frame added and the
    share of its voxels that were new are those of a grid integrated here frame by frame, and
    the coverage features read from it are those integrated afresh for each prefix."""
    config = replace(CONFIG, "sensor", resolution=(107, 75))  # the scene's frames
    episode = Episode(scene, np.eye(3), "free")
    requests = _requests(episode)
    episode.request(requests[0])
    episode.skip(requests[1].target.pose, "collision")
    for request in requests[1:]:
        episode.request(request)
    settings = GridSettings.of(config)
    grid = episode.occupancy(settings)
    assert episode.occupancy(settings) is grid
    rows = episode_features(config, episode.views, grid)
    sensor = SensorModel.from_config(config.sensor)
    reference = OccupancyGrid.for_cell(config)
    added, novel = [1.0, 1.0], 1.0
    for count, view in enumerate(episode.views, start=1):
        if view.acquired:
            hits = np.unique(reference.flat_index(view.points_world))
            hits = hits[hits >= 0]
            before = reference.counts()["occupied"]
            novel = (reference.state.reshape(-1)[hits] != OCCUPIED).sum() / max(len(hits), 1)
            reference.integrate(sensor, view.sensor_pose, view.points_world, view.pixels,
                                view.blocked_pixels)
            after = reference.counts()["occupied"]
            added = [added[1], (after - before) / max(after, 1)]
        np.testing.assert_array_equal(grid.after(count).state, reference.state)
        np.testing.assert_array_equal(grid.after(count).measured_from, reference.measured_from)
        row = dict(zip(FEATURES, rows[count - 1], strict=True))
        assert row["occupied"] == reference.counts()["occupied"] / reference.state.size
        assert (row["added_before"], row["added_last"], row["novel_last"]) == (*added, novel)
        np.testing.assert_array_equal(rows[count - 1],
                                      CoverageFeatures(config).update(episode.views[:count]))
    assert 0.0 < novel < 1.0 and 0.0 < added[1] < 1.0
    # Some voxel was measured from more than one direction, so the readback had bits to undo.
    bits = reference.measured_from
    assert (bits & (bits - 1) != 0).any()
    # The counts the episode's grid keeps frame by frame are those of a pass over the grid.
    assert grid.counts() == reference.counts() != OccupancyGrid.for_cell(config).counts()
