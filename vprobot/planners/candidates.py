"""Candidate views of the model-based planners: the view sphere, its reachable part and
visibility (the model-free band and the screening live in `vprobot.episode.views`).

The candidates are `count` positions spread evenly (Fibonacci lattice) over the sphere of the
working distance around the object's centre, looking at the centre, from the top down to the
polar angle of the ground-truth views (`ground_truth.MAX_POLAR_DEG`, 30 degrees below the
equator): the surface that counts was defined from that cap, and lower views mostly see the
fixture. The paper used 900 such positions (B_SCP).

With the robot, every candidate is reached by the IK for the episode's object pose, neighbour
after neighbour (`vprobot.episode.views.screen_reachability`). A candidate is usable
when its configuration is within the limits and collision-free (the path to it is checked when
a view is executed); it then acquires from the FK pose of that configuration, roll included.
Without the robot every candidate is usable at its look-at pose.

The candidates, their screening and predicted visibility depend on the episode's start only:
they are built once per episode and start configuration (`Episode.shared`) and every planner
that asks gets its own copy (`CandidateViews.own_copy`), sharing the simulated acquisitions
that confirm candidates too; which candidates a planner has confirmed stays its own.

Visibility of the ground-truth points from every usable candidate is predicted by
`VisibilityRenderer` (all candidates in a few numpy passes), within the sensing model's
deterministic limits (projector shadow, incidence limits); planners confirm the candidates they
are about to take with a simulated acquisition (`measured`). A planner that chooses among them is
a `ModelBasedPlanner`, which keeps them for the runner's report.
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np

from vprobot.coverage.ground_truth import MAX_POLAR_DEG
from vprobot.coverage.tracker import EPSILON_PER_SPACING
from vprobot.episode import Episode, ViewRequest
from vprobot.episode.views import look_at_targets, screen_reachability
from vprobot.geometry.poses import Pose
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.planners.base import Planner
from vprobot.planners.greedy import greedy_cover
from vprobot.planners.visibility import DEFAULT_RESOLUTION, VisibilityRenderer

CANDIDATE_COUNT = 900
CONFIRMATIONS_PER_PICK = 6
"""Simulated acquisitions per greedy pick at most. On the test motors (3 poses each), B_SCP,5
covers 96.2 % with none, 97.9 % with 4, 98.4 % with 8 and 99.3 % unlimited, which takes 63
acquisitions a plan on average and up to 150."""
SIGHT_OFFSETS_M = np.array([[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [-0.04, 0.0, 0.0],
                            [0.0, 0.04, 0.0], [0.0, -0.04, 0.0]])
"""Points about the centre, across the image (sensor frame), that the arm must not hide."""


@dataclasses.dataclass
class CandidateViews:
    """The candidate views of one episode.

    Attributes:
        targets: Look-at targets at the working distance (world), one per candidate.
        usable: Whether the candidate can be taken (reachable and collision-free with the robot).
        poses: Sensor pose each usable candidate acquires from (None where not usable).
        joints: Robot configuration of each candidate (count, dof); NaN rows where not usable or
            without the robot.
        reasons: Why a candidate is not usable (the IK's verdict), else None.
        visibility: Predicted visibility of the GT points (count, n_GT); all False where not
            usable.
        reach_seconds: Time spent screening reachability.
        visibility_seconds: Time spent predicting visibility.
        previews: The GT points each candidate simulated so far covers (`measured`), shared
            by every copy (`own_copy`).
    """

    targets: tuple[SensorTarget, ...]
    usable: np.ndarray
    poses: tuple[Pose | None, ...]
    joints: np.ndarray
    reasons: tuple[str | None, ...]
    visibility: np.ndarray
    reach_seconds: float
    visibility_seconds: float
    previews: dict[int, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)
    _measured: set[int] = dataclasses.field(default_factory=set, init=False, repr=False)

    def __len__(self) -> int:
        return len(self.targets)

    def request(self, index: int) -> ViewRequest:
        """The view request of a usable candidate.

        Raises:
            ValueError: If the candidate is not usable.
        """
        if not self.usable[index]:
            raise ValueError(f"candidate {index} is not usable ({self.reasons[index]})")
        joints = self.joints[index]
        return ViewRequest(self.targets[index],
                           None if np.isnan(joints).any() else joints.copy())

    def own_copy(self) -> CandidateViews:
        """The same candidates for another planner: the arrays and the simulated acquisitions
        shared, none of them measured by this copy yet (`known_visibility`)."""
        return dataclasses.replace(self)

    def measured(self, index: int, episode: Episode) -> np.ndarray:
        """The GT points the candidate's acquisition covers (read-only), simulated by the
        episode once for every copy; this copy knows the candidate's visibility from now on."""
        if index not in self.previews:
            row = episode.preview(self.request(index))
            row.flags.writeable = False
            self.previews[index] = row
        self._measured.add(index)
        return self.previews[index]

    def known_visibility(self) -> np.ndarray:
        """The predicted visibility with the rows of the candidates this copy measured
        replaced (a copy)."""
        known = self.visibility.copy()
        for index in self._measured:
            known[index] = self.previews[index]
        return known

    def next_best(self, episode: Episode, taken: set[int]) -> int | None:
        """The candidate outside `taken` adding the most to the episode's coverage (confirmed by
        a simulated acquisition); None if none adds anything.

        With the robot, only candidates joined to the current configuration by a collision-free
        path (`RobotCarrier.path_is_free`) are offered (the others would fail when executed).
        """
        q = episode.q

        def allowed(index: int) -> bool:
            return index not in taken and (not episode.uses_robot or
                                           episode.robot.path_is_free(q, self.joints[index]))

        picks, _ = greedy_cover(self.known_visibility(), episode.covered, 1,
                                confirm=lambda index: self.measured(index, episode),
                                allowed=allowed, confirmations=CONFIRMATIONS_PER_PICK)
        return picks[0] if picks else None


class ModelBasedPlanner(Planner):
    """A planner that chooses among the episode's candidate views (`bscp`, `optimum`,
    `oracle`): the runner reports them with the episode (`EpisodeResult.candidates`, the
    summary's reachability and timing line).

    Attributes:
        candidates: The candidate views it chose from in its last episode; None before its
            first.
    """

    candidates: CandidateViews | None = None


def candidate_views(episode: Episode, count: int = CANDIDATE_COUNT,
                    resolution: tuple[int, int] = DEFAULT_RESOLUTION,
                    screened: tuple[np.ndarray, Sequence[str | None]] | None = None
                    ) -> CandidateViews:
    """The candidates of an episode: targets, reachability (robot) and visibility.

    Built once per episode and configuration the robot is in (`Episode.shared`); each call gets
    its own copy (`CandidateViews.own_copy`). With `screened`, built anew from that screening.

    Args:
        episode: The episode (its object pose; its robot when it uses one).
        count: Candidate positions on the view sphere.
        resolution: Grid of the visibility renderer.
        screened: With the robot, the episode's screening of these candidates already done
            (`screen_reachability`'s configurations and reasons), not to be done again.

    Raises:
        ValueError: If count < 1, or `screened` holds another number of candidates or joints.
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    if screened is not None:
        return _build_candidates(episode, count, resolution, screened)

    def build() -> CandidateViews:
        views = _build_candidates(episode, count, resolution, None)
        for array in (views.usable, views.joints, views.visibility):
            array.flags.writeable = False  # every planner of the episode reads them
        return views

    key = ("candidate views", count, tuple(resolution), episode.q.tobytes())
    return episode.shared.get(key, build).own_copy()


def _build_candidates(episode: Episode, count: int, resolution: tuple[int, int],
                      screened: tuple[np.ndarray, Sequence[str | None]] | None
                      ) -> CandidateViews:
    """Build the candidates of an episode (see `candidate_views`)."""
    scene = episode.scene
    center = episode.center
    radius = scene.sensor.sensor.working_distance_m
    directions = sphere_directions(count, np.deg2rad(MAX_POLAR_DEG))
    targets = look_at_targets(center, radius, directions)
    dof = scene.cell.joints.dof
    start = time.perf_counter()
    if episode.uses_robot:
        if screened is None:
            joints, reasons = screen_reachability(scene.arm, episode.robot.collisions,
                                                  episode.q, directions, targets)
        else:
            joints, reasons = screened[0], tuple(screened[1])
            if joints.shape != (count, dof) or len(reasons) != count:
                raise ValueError(f"screened holds {joints.shape} joints and {len(reasons)} "
                                 f"reasons, expected ({count}, {dof}) and {count}")
        usable = ~np.isnan(joints).any(axis=1)
        arm = scene.arm
        poses = tuple(arm.fk(q) if ok else None for q, ok in zip(joints, usable, strict=True))
    else:
        joints = np.full((count, dof), np.nan)
        reasons = (None,) * count
        usable = np.ones(count, dtype=bool)
        poses = tuple(target.pose for target in targets)
    reach_seconds = time.perf_counter() - start

    start = time.perf_counter()
    ground_truth = scene.ground_truth
    renderer = VisibilityRenderer(scene.mesh.mesh, scene.sensor.sensor, resolution,
                                  tolerance_m=EPSILON_PER_SPACING * ground_truth.spacing_m,
                                  sensing=scene.sensor.sensing)
    to_mesh = episode.object_pose.inverse()
    indices = np.flatnonzero(usable)
    visibility = np.zeros((count, len(ground_truth.points)), dtype=bool)
    if len(indices):
        # The usable candidates are those with a pose.
        visibility[indices] = renderer.visible(
            [to_mesh.compose(pose) for pose in poses if pose is not None], ground_truth.points)
    return CandidateViews(targets=targets, usable=usable, poses=poses, joints=joints,
                          reasons=reasons, visibility=visibility, reach_seconds=reach_seconds,
                          visibility_seconds=time.perf_counter() - start)


def arm_hides_view(arm: RobotArm, q: np.ndarray, center: np.ndarray) -> bool:
    """Whether the arm at `q` hides the middle of its sensor's view of `center` (the centre
    and four points 4 cm across the image from it)."""
    return arm.hides(q, center + SIGHT_OFFSETS_M @ arm.fk(q).rotation.T)


