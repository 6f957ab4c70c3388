"""Work shared by the planners of one episode: the candidate views, their screening and
visibility, the simulated confirmations, the robot's moves and frames and the loaded motor
(docs/evaluation.md#shared-work)."""

from __future__ import annotations

import csv
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import vprobot.evaluation as evaluation
from vprobot.cell.sensor import DepthSensor
from vprobot.config import Config
from vprobot.episode import Episode, PartScene, SharedWork, ViewRequest, episode_list
from vprobot.evaluation import evaluate
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import rotation_about_z
from vprobot.kinematics import ReachResult, SensorTarget
from vprobot.kinematics.arm import RobotArm
from vprobot.parts import loading as mesh_loading
from vprobot.planners import candidates
from vprobot.planners.candidates import CandidateViews, candidate_views
from vprobot.planners.visibility import VisibilityRenderer
from vprobot.report.compare import EPISODE_KEY, moved_cells

CONFIG = Config()
MODEL_BASED = ("bscp", "bscp4", "oracle")


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """Counts reachability screenings, visibility predictions, simulated confirmations and
    mesh file reads."""
    counts: Counter[str] = Counter()

    def counting(owner: object, name: str) -> None:
        original = getattr(owner, name)

        def counted(*args: object, **kwargs: object) -> object:
            counts[name] += 1
            return original(*args, **kwargs)

        monkeypatch.setattr(owner, name, counted)

    counting(candidates, "screen_reachability")
    counting(VisibilityRenderer, "visible")
    counting(Episode, "preview")
    counting(mesh_loading, "_read_mesh")
    counting(RobotArm, "plan")
    counting(DepthSensor, "acquire_at")
    return counts


def _moved_cells(old: list[dict[str, str]], new: list[dict[str, str]]
                 ) -> tuple[list[str], int]:
    """`vprobot report compare`'s cell-by-cell comparison (timing columns left out) of episode
    rows."""
    return moved_cells(old, new, EPISODE_KEY)


def _rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "evaluation_episodes.csv").open(newline="") as stream:
        return list(csv.DictReader(stream))


def test_sharing_the_candidates_leaves_every_row_as_each_planner_alone_and_screens_once(
        tmp_path: Path, calls: Counter[str]) -> None:
    specs = episode_list(CONFIG, [DEFAULT_MOTOR], [1])
    evaluation._scene.cache_clear()
    evaluate(CONFIG, list(MODEL_BASED), specs, tmp_path / "shared", progress=False,
             carriers=["robot"])
    # Once for all three planners, and the motor read once.
    assert calls["screen_reachability"] == calls["visible"] == len(specs)
    assert calls["_read_mesh"] == 1
    shared_previews = calls["preview"]
    calls.clear()
    # The reference: each planner in an evaluation of its own, sharing with nobody.
    alone = []
    for planner in MODEL_BASED:
        evaluate(CONFIG, [planner], specs, tmp_path / planner, progress=False,
                 carriers=["robot"])
        alone += _rows(tmp_path / planner)
    assert calls["screen_reachability"] == len(MODEL_BASED) * len(specs)
    # Confirmations simulated by one planner are not simulated again for the next.
    assert shared_previews < calls["preview"]
    shared = _rows(tmp_path / "shared")
    moved, compared = _moved_cells(alone, shared)
    assert len(shared) == len(alone) == len(MODEL_BASED) * len(specs)
    assert compared > 10 * len(shared)
    assert moved == []


@pytest.fixture(scope="module")
def motor() -> PartScene:
    return PartScene.load(CONFIG, DEFAULT_MOTOR)


def test_candidates_are_built_once_per_episode_and_robot_configuration(
        motor: PartScene, calls: Counter[str]) -> None:
    shared = SharedWork()
    first = Episode(motor, np.eye(3), shared=shared)
    views = candidate_views(first, 30, (24, 18))
    again = candidate_views(Episode(motor, np.eye(3), shared=shared), 30, (24, 18))
    assert calls["screen_reachability"] == 1
    assert again is not views and again.visibility is views.visibility
    assert not views.visibility.flags.writeable
    # Another count, or the robot elsewhere, is other work.
    candidate_views(first, 31, (24, 18))
    assert calls["screen_reachability"] == 2
    first.request(views.request(int(np.flatnonzero(views.usable)[0])))
    assert not np.array_equal(first.q, first.start_joints)
    candidate_views(first, 30, (24, 18))
    assert calls["screen_reachability"] == 3
    # Another episode has its own.
    candidate_views(Episode(motor, np.eye(3)), 30, (24, 18))
    assert calls["screen_reachability"] == 4


def test_shared_work_refuses_an_episode_that_starts_otherwise(motor: PartScene) -> None:
    shared = SharedWork()
    Episode(motor, np.eye(3), shared=shared)
    turned = rotation_about_z(0.5)
    for other in ({"object_rotation": turned}, {"carrier": "free"},
                  {"start_joints": motor.cell.joints.start + 0.1}):
        with pytest.raises(ValueError, match="starts otherwise"):
            Episode(motor, **{"object_rotation": np.eye(3), "shared": shared, **other})


class _Previews:
    """An episode that only previews: row i covers point i."""

    def __init__(self) -> None:
        self.previews = 0

    def preview(self, request: ViewRequest) -> np.ndarray:
        self.previews += 1
        row = np.zeros(4, dtype=bool)
        row[int(request.target.pose.position[0])] = True
        return row


def test_a_copys_confirmations_are_its_own_and_simulated_once_for_all() -> None:
    targets = tuple(SensorTarget.look_at(np.array([float(i), 0.0, 1.0]), np.zeros(3))
                    for i in range(4))
    views = CandidateViews(targets=targets, usable=np.ones(4, dtype=bool), poses=(None,) * 4,
                           joints=np.full((4, 6), np.nan), reasons=(None,) * 4,
                           visibility=np.zeros((4, 4), dtype=bool), reach_seconds=0.0,
                           visibility_seconds=0.0)
    other = views.own_copy()
    episode = _Previews()
    assert views.measured(2, episode).tolist() == [False, False, True, False]
    assert views.known_visibility()[2, 2] and not other.known_visibility().any()
    assert other.measured(2, episode) is views.measured(2, episode)
    assert episode.previews == 1
    assert other.known_visibility()[2, 2]


def test_a_move_is_planned_and_a_frame_taken_once_for_the_episodes_that_start_alike(
        motor: PartScene, calls: Counter[str]) -> None:
    shared = SharedWork()
    first, second = (Episode(motor, np.eye(3), shared=shared) for _ in range(2))
    views = candidate_views(first, 30, (24, 18))
    request = views.request(int(np.flatnonzero(views.usable)[0]))
    calls.clear()
    preview = first.preview(request)
    assert (calls["plan"], calls["acquire_at"]) == (0, 1)
    # Executing the previewed view takes no second frame; the move to it is planned once.
    taken = first.request(request)
    assert (calls["plan"], calls["acquire_at"]) == (1, 1)
    again = second.request(request)
    assert (calls["plan"], calls["acquire_at"]) == (1, 1)
    np.testing.assert_array_equal(again.points_world, taken.points_world)
    np.testing.assert_array_equal(again.path, taken.path)
    assert int(preview.sum()) > 0 and second.coverage == first.coverage > 0
    # The frames are read-only: a later user cannot change what another episode measured.
    assert not taken.points_world.flags.writeable
    # An episode of its own plans and measures again, and gets the same.
    alone = Episode(motor, np.eye(3)).request(request)
    assert (calls["plan"], calls["acquire_at"]) == (2, 2)
    np.testing.assert_array_equal(alone.points_world, taken.points_world)


def test_a_target_is_reached_once_for_the_episodes_that_start_alike_as_alone(
        motor: PartScene, calls: Counter[str], monkeypatch: pytest.MonkeyPatch) -> None:
    reaches: Counter[str] = Counter()
    original = RobotArm.reach

    def counted(*args: Any, **kwargs: Any) -> ReachResult:
        reaches["reach"] += 1
        return original(*args, **kwargs)

    monkeypatch.setattr(RobotArm, "reach", counted)
    shared = SharedWork()
    first, second = (Episode(motor, np.eye(3), shared=shared) for _ in range(2))
    center = first.center
    target = SensorTarget.look_at(center + np.array([0.0, -0.3, 0.2]), center)
    result = first.robot.reach(target, first.q)
    assert result.reachable and result.motion is not None
    # The other episode gets the same result, reached and planned once; its `q` is read-only.
    assert second.robot.reach(target, second.q) is result
    assert (reaches["reach"], calls["plan"]) == (1, 1)
    assert not result.q.flags.writeable
    # Executing the view drives the move the IK planned.
    taken = second.request(ViewRequest(target, result.q))
    assert (reaches["reach"], calls["plan"]) == (1, 1)
    np.testing.assert_array_equal(taken.joints, result.q)
    # From elsewhere it is reached anew; an episode of its own reaches it again, alike.
    first.robot.reach(target, second.q)
    assert (reaches["reach"], calls["plan"]) == (2, 2)
    alone = Episode(motor, np.eye(3)).robot.reach(target, first.start_joints)
    assert (reaches["reach"], calls["plan"]) == (3, 3)
    assert alone is not result and alone.motion is not None
    np.testing.assert_array_equal(alone.q, result.q)
    np.testing.assert_array_equal(alone.motion.waypoints, result.motion.waypoints)
    assert (alone.reason, alone.iterations) == (result.reason, result.iterations)
