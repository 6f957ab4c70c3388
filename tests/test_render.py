"""Offscreen rendering: frames, overlays, videos, summary stills, plan replay, output paths.

The renderer makes its own OpenGL context from MUJOCO_GL (EGL by default), so these tests run
headless whatever imported mujoco first.
"""

import dataclasses
import json

import imageio.v2 as imageio
import numpy as np
import pytest
from matplotlib.colors import rgb_to_hsv

from vprobot.cell.sensor import LOSS_CAUSES, DepthSensor
from vprobot.config import load_config, with_sensor
from vprobot.episode import Episode, EpisodeRecord, PartScene, ViewRequest
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.kinematics import SensorTarget
from vprobot.plan import plan_document, planned_views, write_json
from vprobot.render import EpisodeRenderer, episode_from_plan, render_episode
from vprobot.render.lost import LOST_RGB
from vprobot.render.markers import LOST_RGBA
from vprobot.render.output import VideoWriter
from vprobot.render.overlay import OverlayStatus, draw_status, inset
from vprobot.render.summary import OVERVIEW_FRACTION, render_summary
from vprobot.render.timeline import (
    TimingSettings,
    along_path,
    episode_timeline,
    move_frames,
)
from vprobot.sensing import IDEAL

WIDTH, HEIGHT = 96, 72
FAST = {"fps": 8.0, "hold_seconds": 0.25, "max_seconds_per_move": 0.5}


@pytest.fixture(scope="module")
def config():
    return load_config()


@pytest.fixture(scope="module")
def scene(config):
    return PartScene.load(config, DEFAULT_MOTOR, resolution=(86, 60))


def _direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    azimuth, elevation = np.deg2rad([azimuth_deg, elevation_deg])
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                     np.sin(elevation)])


@pytest.fixture(scope="module")
def record(scene) -> EpisodeRecord:
    """Two reachable views, then a request far out of reach."""
    episode = Episode(scene, np.eye(3))
    center = episode.center
    for azimuth in (0.0, 70.0):
        target = SensorTarget.look_at(center + 0.47 * _direction(azimuth, 35.0), center)
        assert episode.request(ViewRequest(target)).reachable
    far = SensorTarget.look_at(center + 3.0 * _direction(180.0, 10.0), center)
    assert not episode.request(ViewRequest(far)).reachable
    return episode.record()


def _acquisition_states(record, settings):
    return [state for state in episode_timeline(record, settings)
            if state.phase in ("acquire", "unreachable")]


def test_frames_have_the_size_are_not_empty_and_differ_between_views(scene, record):
    settings = TimingSettings(**FAST)
    with EpisodeRenderer(scene, record, WIDTH, HEIGHT, sensor_panel="depth") as renderer:
        first, second, unreachable = (renderer.frame(state)
                                      for state in _acquisition_states(record, settings))
    for frame in (first, second, unreachable):
        assert frame.shape == (HEIGHT, WIDTH, 3) and frame.dtype == np.uint8
        assert frame.std() > 10.0
    assert np.abs(first.astype(int) - second.astype(int)).mean() > 2.0
    # The unreachable request adds a red ghost frustum while the arm stays put.
    assert np.any(second != unreachable)


def test_the_arm_moves_along_the_path_between_views(record):
    settings = TimingSettings(fps=30.0, max_seconds_per_move=10.0)
    states = episode_timeline(record, settings)
    moves = [state for state in states if state.phase == "move" and state.view == 1]
    path = record.views[1].path
    assert len(moves) > 2
    np.testing.assert_allclose(moves[-1].joints, path[-1])
    # Not a jump: every step is a small part of the whole move.
    steps = np.linalg.norm(np.diff([state.joints for state in moves], axis=0), axis=1)
    assert steps.max() < 0.5 * np.linalg.norm(path[-1] - path[0])
    capped = TimingSettings(fps=30.0, max_seconds_per_move=0.1)
    assert sum(state.phase == "move" and state.view == 1
               for state in episode_timeline(record, capped)) == 3


def test_the_video_keeps_the_cells_clock(scene, record):
    """With the robot's timed cycle each move takes its duration under the robot's limits (the
    arm on the timed trajectory), the clock stands at the end of each acquisition while it is
    shown and at the cycle time once the arm is back home; `time_scale` and the cap change the
    frames, not the clock."""
    timed = record.timed
    settings = TimingSettings(fps=30.0, max_seconds_per_move=100.0)
    states = episode_timeline(record, settings, timed)
    clocks = [state.clock_s for state in states]
    assert clocks == sorted(clocks) and clocks[0] == 0.0
    acquired = [index for index, view in enumerate(record.views) if view.acquired]
    ends = [0.0]
    for stop, index in zip(timed.acquisitions, acquired, strict=True):
        view = record.views[index]
        moves = [state for state in states if state.phase == "move" and state.view == index]
        # The move's duration by the robot's own timing of its corners.
        duration = scene.arm.move_time(view.waypoints)
        assert len(moves) == move_frames(duration, settings) == np.ceil(30.0 * duration)
        assert moves[-1].clock_s == pytest.approx(ends[-1] + duration)
        np.testing.assert_allclose(moves[-1].joints, view.joints, atol=1e-12)
        (shown,) = [state for state in states if state.phase == "acquire" and state.view == index]
        assert shown.clock_s == pytest.approx(
            moves[-1].clock_s + scene.cell.config.sensor.acquisition_time_s)
        ends.append(stop.end_s)
    # The unreachable request: the robot stays, and so does the clock.
    (missed,) = [state for state in states if state.phase == "unreachable"]
    assert missed.clock_s == ends[-1]
    back = [state for state in states if state.phase == "return"]
    assert len(back) == move_frames(scene.arm.move_time(record.return_waypoints), settings)
    home = states[-1]
    assert home.phase == "home" and home.clock_s == pytest.approx(timed.cycle.total_s)
    np.testing.assert_allclose(home.joints, record.start_joints, atol=1e-12)
    half = episode_timeline(record, TimingSettings(fps=30.0, time_scale=0.5,
                                                   max_seconds_per_move=100.0), timed)
    capped = episode_timeline(record, TimingSettings(fps=30.0, max_seconds_per_move=0.1), timed)
    for other in (half, capped):
        assert other[-1].clock_s == home.clock_s
    assert sum(state.phase == "move" for state in capped) == 3 * len(acquired)
    assert sum(state.phase == "move" for state in half) == sum(
        np.ceil(15.0 * scene.arm.move_time(record.views[index].waypoints)) for index in acquired)


def test_the_overlay_shows_the_cells_clock_and_a_free_sensor_keeps_the_untimed_video(scene,
                                                                                     record):
    with EpisodeRenderer(scene, record, WIDTH, HEIGHT, sensor_panel=None) as renderer:
        states = renderer.timeline(TimingSettings(**FAST))
        assert [state.clock_s for state in states] == [
            state.clock_s for state in episode_timeline(record, TimingSettings(**FAST),
                                                        record.timed)]
        status = renderer.status(states[-1])
    assert status.caption == "done" and status.cycle_s == status.clock_s == pytest.approx(
        record.timed.cycle.total_s)
    frame = np.full((HEIGHT, WIDTH, 3), 90, dtype=np.uint8)
    assert np.any(draw_status(frame, status) != draw_status(
        frame, dataclasses.replace(status, clock_s=status.clock_s / 2)))
    free = Episode(scene, np.eye(3), carrier="free")
    center = free.center
    free.request(ViewRequest(SensorTarget.look_at(center + 0.47 * _direction(0.0, 35.0),
                                                  center)))
    with EpisodeRenderer(scene, free.record(), WIDTH, HEIGHT, sensor_panel=None) as renderer:
        assert renderer.record.timed is None
        states = renderer.timeline(TimingSettings(**FAST))
    assert [state.phase for state in states] == ["start", "acquire", "end"]
    assert all(state.clock_s is None for state in states)


def test_along_path_interpolates_by_arc_length():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 3.0]])
    np.testing.assert_allclose(along_path(path, np.array([0.0, 0.25, 1.0])),
                               [[0.0, 0.0], [1.0, 0.0], [1.0, 3.0]])


def test_overlays_change_the_image():
    frame = np.full((HEIGHT, WIDTH, 3), 90, dtype=np.uint8)
    status = OverlayStatus(step=2, steps=3, caption="moving", coverage=0.42, joint_time_s=1.5,
                           sensor_path_m=0.8, unreachable=((1, "joint_limits"),))
    annotated = draw_status(frame, status)
    assert annotated.shape == frame.shape and np.any(annotated != frame)
    other = draw_status(frame, dataclasses.replace(status, coverage=0.9))
    assert np.any(other != annotated)
    panel = np.zeros((20, 30, 3), dtype=np.uint8)
    assert np.any(inset(frame, panel, "sensor") != frame)


def test_render_episode_writes_mp4_and_gif(scene, record, tmp_path):
    video = render_episode(scene, record, tmp_path / "rollout.mp4", width=WIDTH, height=HEIGHT,
                           sensor_panel="color", **FAST)
    frames = imageio.mimread(video.path, memtest=False)
    assert len(frames) == video.frames and frames[0].shape == (HEIGHT, WIDTH, 3)
    gif = render_episode(scene, record, tmp_path / "rollout.gif", width=WIDTH, height=HEIGHT,
                         sensor_panel=None, **FAST)
    assert gif.path.stat().st_size > 0
    assert sorted(path.name for path in tmp_path.iterdir()) == ["rollout.gif", "rollout.mp4"]


@pytest.mark.parametrize("video, still, message", [
    ("missing/rollout.mp4", "missing/summary.png", "does not exist"),
    ("rollout.avi", "summary.jpg", "must end in"),
    ("folder.mp4", "folder.png", "is a folder"),
])
def test_bad_output_paths_are_refused(scene, record, tmp_path, video, still, message):
    for folder in ("folder.mp4", "folder.png"):
        (tmp_path / folder).mkdir()
    with pytest.raises(ValueError, match=message):
        render_episode(scene, record, tmp_path / video, width=WIDTH, height=HEIGHT, **FAST)
    with pytest.raises(ValueError, match=message):
        render_summary(scene, record, tmp_path / still)
    assert sorted(path.name for path in tmp_path.iterdir()) == ["folder.mp4", "folder.png"]


def test_a_failed_video_leaves_nothing_behind(tmp_path):
    with pytest.raises(ValueError, match="frame shape"), \
            VideoWriter(tmp_path / "out.mp4", 10.0, 32, 24) as writer:
        writer.append(np.zeros((24, 32, 3), dtype=np.uint8))
        writer.append(np.zeros((10, 10, 3), dtype=np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_odd_sizes_are_refused_for_mp4(scene, record, tmp_path):
    with pytest.raises(ValueError, match="even frame size"):
        render_episode(scene, record, tmp_path / "odd.mp4", width=95, height=72)


def test_summary_png(scene, record, tmp_path):
    path = render_summary(scene, record, tmp_path / "summary.png", width=160, height=120)
    image = imageio.imread(path)
    assert image.shape[:2] == (120, 160) and image.std() > 10.0


def test_episode_from_plan_replays_the_views(config, scene, record, tmp_path):
    document = plan_document(scene.cell, planned_views(record),
                             scene.object_block(record.object_pose),
                             record.coverage)
    plan = write_json(tmp_path / "plan.json", document)
    replayed_scene, replayed = episode_from_plan(config, plan, resolution=(86, 60))
    assert [view.reachable for view in replayed.views] == [True, True, False]
    assert replayed.views[2].reason == record.views[2].reason
    np.testing.assert_allclose([view.coverage for view in replayed.views],
                               [view.coverage for view in record.views])
    np.testing.assert_allclose(replayed.object_pose.position, record.object_pose.position,
                               atol=1e-9)
    assert replayed_scene.cell.robot == scene.cell.robot


def test_a_plans_views_are_replayed_along_its_stored_paths(config, scene, record, tmp_path):
    """The replay follows each move's stored corners (a detour through a free corner is kept,
    not planned away), and a stored path that runs into the cell is refused, naming the view."""
    document = plan_document(scene.cell, planned_views(record),
                             scene.object_block(record.object_pose), record.coverage)
    second = document["views"][1]
    start, end = np.array(second["waypoints"][0]), np.array(second["waypoints"][-1])
    detour = (start + end) / 2.0
    detour[1] += 0.05  # the shoulder lifted a little halfway
    second["waypoints"] = [start.tolist(), detour.tolist(), end.tolist()]
    plan = write_json(tmp_path / "plan.json", document)
    _, replayed = episode_from_plan(config, plan, resolution=(86, 60))
    np.testing.assert_array_equal(replayed.views[1].waypoints, [start, detour, end])
    assert replayed.views[1].coverage == pytest.approx(record.views[1].coverage)
    # Through the floor: the shoulder lifted the other way, far down.
    detour[1] = 1.2
    second["waypoints"] = [start.tolist(), detour.tolist(), end.tolist()]
    plan = write_json(tmp_path / "through.json", document)
    with pytest.raises(ValueError, match=r"plan views\[1\]: the path along the waypoints"):
        episode_from_plan(config, plan, resolution=(86, 60))


def test_episode_from_plan_names_what_is_wrong(config, tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"object": None, "views": []}))
    with pytest.raises(ValueError, match="no object block"):
        episode_from_plan(config, plan)
    plan.write_text("{not json")
    with pytest.raises(ValueError, match="cannot read plan"):
        episode_from_plan(config, plan)
    with pytest.raises(ValueError, match="does not exist"):
        episode_from_plan(config, tmp_path / "missing.json")


@pytest.fixture(scope="module")
def structured_light(config):
    """The motor under the Zivid preset (structured light, its default) at 96 x 80 rays, three
    views from the side the robot reaches; and the same scene with its sensor measuring
    ideally."""
    config = with_sensor(config, "zivid2plus_mr60")
    scene = PartScene.load(config, DEFAULT_MOTOR, resolution=(96, 80))
    episode = Episode(scene, np.eye(3))
    center = episode.center
    for azimuth in (70.0, 110.0, 150.0):
        target = SensorTarget.look_at(
            center + config.sensor.working_distance_m * _direction(azimuth, 35.0), center)
        assert episode.request(ViewRequest(target)).reachable
    ideal = dataclasses.replace(scene, sensor=DepthSensor(scene.cell, resolution=(96, 80),
                                                          sensing=IDEAL))
    return scene, ideal, episode.record()


def _inset_count(frame: np.ndarray, cause: str) -> int:
    """Pixels of the cause's colour in the frame's inset (its right third, lower half)."""
    inset_part = frame[frame.shape[0] // 2:, 2 * frame.shape[1] // 3:]
    return int(np.all(inset_part == LOST_RGB[cause], axis=-1).sum())


def test_inset_paints_the_points_the_frame_lost_by_cause_the_ideal_sensor_none(structured_light):
    scene, ideal, record = structured_light
    timeline = episode_timeline(record, TimingSettings(**FAST))
    start = next(state for state in timeline if state.phase == "start")
    shown = next(state for state in timeline if state.phase == "acquire")
    with EpisodeRenderer(scene, record, 320, 240) as renderer:
        counts = renderer.losses[shown.view].counts()
        acquired, start = renderer.frame(shown), renderer.frame(start)
    with EpisodeRenderer(ideal, record, 320, 240) as renderer:
        assert renderer.losses == []
        ideal_acquired = renderer.frame(shown)
    for cause in LOSS_CAUSES:
        assert counts[cause] > 0
        # The legend's swatch in every frame; the lost points while the view is shown.
        assert 0 < _inset_count(start, cause) < _inset_count(acquired, cause)
        assert _inset_count(ideal_acquired, cause) == 0
    # Where the robot does not stand in the way the two frames differ only in the inset.
    assert np.array_equal(acquired[:, : 2 * acquired.shape[1] // 3],
                          ideal_acquired[:, : 2 * acquired.shape[1] // 3])


def test_summary_draws_the_lost_points_in_their_colours_the_ideal_sensor_none(structured_light,
                                                                               tmp_path):
    """The close-ups (below the caption) hold the shadowed points' purple and the grazing
    points' cyan, as MuJoCo shades them, only under structured light."""
    scene, ideal, record = structured_light
    width, height = 640, 360
    found = {}
    for name, shown in (("structured_light", scene), ("ideal", ideal)):
        image = imageio.imread(render_summary(shown, record, tmp_path / f"{name}.png",
                                              width=width, height=height))
        close_ups = image[height // 4:, round(OVERVIEW_FRACTION * width):, :3] / 255.0
        hsv = rgb_to_hsv(close_ups)
        found[name] = {}
        for cause in ("shadowed", "grazing"):
            hue = rgb_to_hsv(LOST_RGBA[cause][:3])[0]
            near = np.abs((hsv[..., 0] - hue + 0.5) % 1.0 - 0.5) < 0.05
            found[name][cause] = int(np.sum(near & (hsv[..., 1] > 0.4) & (hsv[..., 2] > 0.3)))
    assert found["structured_light"]["shadowed"] > 10
    assert found["structured_light"]["grazing"] > 10
    assert found["ideal"] == {"shadowed": 0, "grazing": 0}
