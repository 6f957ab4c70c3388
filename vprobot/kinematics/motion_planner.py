"""Collision-free joint-space moves: the straight line when it is free, else OMPL's RRT-Connect.

The planner never trusts a library's verdict: every path it returns has been sampled at
`path_max_joint_step_rad` and checked against the cell's own MuJoCo collision model, the same
check the straight line gets (docs/cell-and-robots.md#motion-planning).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import time
from typing import Literal

import numpy as np
import ompl.base as ob
import ompl.geometric as og
import ompl.util as ou

from vprobot.cell.scene import JointSpace
from vprobot.config import KinematicsConfig
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.path import joint_path

PlanMethod = Literal["line", "rrt_connect", "given"]

ou.setLogLevel(ou.LOG_NONE)  # OMPL logs every query (and each reseed) to the console

SEARCHES = 3
"""RRT-Connect searches at most per move. OMPL checks a motion at other samples than the dense
check does, so a path it found may graze an obstacle between them; the next search checks
twice as finely (and draws other numbers), within what is left of the budget."""


@dataclasses.dataclass(frozen=True)
class MotionPlan:
    """A collision-free move between two configurations.

    Attributes:
        waypoints: The path's corners (m, dof), m >= 2, from the start to the goal; consecutive
            corners are joined by straight joint-space segments, each collision-free.
            `[q_from, q_to]` for a free straight line.
        path: The corners joined and sampled at `path_max_joint_step_rad` (n, dof): the
            configurations the collision check passed.
        method: `line` (the straight line was free), `rrt_connect` (planned by OMPL) or `given`
            (corners handed in, e.g. a stored plan's, and checked: `MotionPlanner.follow`).
        planning_time_s: Wall time of the whole query (checks included).
    """

    waypoints: np.ndarray
    path: np.ndarray
    method: PlanMethod
    planning_time_s: float


def densify(waypoints: np.ndarray, max_joint_step_rad: float) -> np.ndarray:
    """The straight segments between consecutive `waypoints` (m, dof) sampled so that no joint
    moves more than `max_joint_step_rad` between samples; each corner appears once."""
    segments = [joint_path(a, b, max_joint_step_rad)[1:]
                for a, b in itertools.pairwise(waypoints)]
    return np.vstack([waypoints[:1], *segments])


@dataclasses.dataclass
class SearchBudget:
    """What is left of a move's budget for its searches.

    Attributes:
        checks: Collision checks left: they end a search at the same point on every machine.
        deadline: `time.thread_time()` past which a (slower) machine stops anyway. The
            planning thread's CPU time, not the wall clock: on a loaded machine the searches
            wait for a core without spending it, so other processes do not change the plans.
    """

    checks: int
    deadline: float

    def spent(self) -> bool:
        return self.checks <= 0 or time.thread_time() > self.deadline


def query_seed(q_from: np.ndarray, q_to: np.ndarray) -> int:
    """A positive 32-bit seed from the query alone: the same move gets the same path, in
    whatever order the moves of a run are planned."""
    digest = hashlib.sha256(np.concatenate([q_from, q_to]).astype("<f8").tobytes()).digest()
    return int.from_bytes(digest[:4], "little") % (2**31 - SEARCHES) + 1


class MotionPlanner:
    """Plans collision-free joint-space moves within the joint limits.

    Args:
        collisions: The checker (with the episode's object placement) that decides validity.
        joints: The robot's joints; their limits bound the search.
        settings: `path_planner`, `path_planning_time_s` and `path_max_joint_step_rad`.
    """

    def __init__(self, collisions: CollisionChecker, joints: JointSpace,
                 settings: KinematicsConfig):
        self.collisions = collisions
        self.joints = joints
        self.settings = settings

    def is_free(self, path: np.ndarray) -> bool:
        """Whether every configuration of a sampled path is within the limits and free."""
        return (self.joints.within_limits(path)
                and self.collisions.first_collision(path) is None)

    def follow(self, waypoints: np.ndarray) -> MotionPlan | None:
        """The move along given corners (m, dof), m >= 2, checked as densely as a planned one;
        None when a configuration on it is outside the limits or in collision.

        Raises:
            ValueError: If `waypoints` is not an (m >= 2, dof) array of finite values.
        """
        start = time.perf_counter()
        corners = np.asarray(waypoints, dtype=float)
        if corners.ndim != 2 or len(corners) < 2 or corners.shape[1] != self.joints.dof:
            raise ValueError(f"waypoints must be an (m >= 2, {self.joints.dof}) array, got shape "
                             f"{corners.shape}")
        corners = np.array([self.joints.check(q, "waypoint") for q in corners])
        path = densify(corners, self.settings.path_max_joint_step_rad)
        if not self.is_free(path):
            return None
        return MotionPlan(corners, path, "given", time.perf_counter() - start)

    def plan(self, q_from: np.ndarray, q_to: np.ndarray) -> MotionPlan | None:
        """A collision-free move from `q_from` to `q_to`, or None when none was found.

        The straight line first; when it collides and `path_planner` is `rrt_connect`,
        RRT-Connect searches the joint-limit box, OMPL's simplifier shortens the result, and the
        simplified corners are checked again densely; a path that fails that check is searched
        for again (`SEARCHES`), all within `path_planning_checks` collision checks and
        `path_planning_time_s`. Ends in collision or outside the limits fail at once.
        """
        start = time.perf_counter()
        q_from = self.joints.check(q_from, "q_from")
        q_to = self.joints.check(q_to, "q_to")
        step = self.settings.path_max_joint_step_rad
        line = np.array([q_from, q_to])
        path = densify(line, step)
        if self.is_free(path):
            return MotionPlan(line, path, "line", time.perf_counter() - start)
        if self.settings.path_planner == "line" or not self.is_free(line):
            return None
        budget = SearchBudget(self.settings.path_planning_checks,
                              time.thread_time() + self.settings.path_planning_time_s)
        for search in range(SEARCHES):
            if budget.spent():
                break
            waypoints = self._rrt_connect(q_from, q_to, budget, search)
            if waypoints is None:
                break
            path = densify(waypoints, step)
            if self.is_free(path):
                return MotionPlan(waypoints, path, "rrt_connect", time.perf_counter() - start)
        return None

    def _rrt_connect(self, q_from: np.ndarray, q_to: np.ndarray, budget: SearchBudget,
                     search: int) -> np.ndarray | None:
        """OMPL's RRT-Connect between two free configurations, simplified; None when the
        budget ran out first (its checks are counted off).

        Search `search` (from 0) checks motions 2**search times finer than the dense check's
        step and draws its own numbers.
        """
        dof = self.joints.dof
        # Reseeded before any sampler exists: the samplers this query creates draw their seeds
        # from it, so the path depends on the query only.
        ou.RNG.setSeed(query_seed(q_from, q_to) + search)
        space = ob.RealVectorStateSpace(dof)
        bounds = ob.RealVectorBounds(dof)
        for index in range(dof):
            bounds.setLow(index, float(self.joints.lower[index]))
            bounds.setHigh(index, float(self.joints.upper[index]))
        space.setBounds(bounds)
        setup = og.SimpleSetup(space)
        in_collision = self.collisions.in_collision
        axes = range(dof)

        def valid(state: ob.State) -> bool:
            budget.checks -= 1
            # A list, not an array: this runs for every state the search checks, and a list
            # comprehension costs a fraction of an array built from a generator.
            return not in_collision([state[i] for i in axes])

        setup.setStateValidityChecker(valid)
        information = setup.getSpaceInformation()
        # OMPL checks motions at a fraction of the space's extent (Euclidean): that fraction of
        # the extent is the dense check's joint step, so no joint skips more than it.
        information.setStateValidityCheckingResolution(
            self.settings.path_max_joint_step_rad / 2**search / space.getMaximumExtent())
        setup.setPlanner(og.RRTConnect(information))
        start, goal = space.allocState(), space.allocState()
        for index in range(dof):
            start[index], goal[index] = float(q_from[index]), float(q_to[index])
        setup.setStartAndGoalStates(start, goal)
        # Asked once per iteration: the checks so far decide, the same on every machine.
        if (not setup.solve(ob.PlannerTerminationCondition(budget.spent))
                or not setup.haveExactSolutionPath()):
            return None
        # Without a time limit the simplifier runs to its fixed point, deterministically.
        setup.simplifySolution()
        states = setup.getSolutionPath().getStates()
        waypoints = np.array([[state[i] for i in range(dof)] for state in states])
        # The ends are the requested configurations exactly, not OMPL's copies of them.
        waypoints[0], waypoints[-1] = q_from, q_to
        return waypoints
