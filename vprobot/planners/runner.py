"""Run a planner through an episode, and plan one motor end to end (`vprobot plan`)."""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np

from vprobot.config import Config
from vprobot.episode import EpisodeRecord
from vprobot.inspection import MotorScene, initial_view_target, random_object_rotation
from vprobot.kinematics import TravelCost
from vprobot.paths import DEFAULT_MOTOR
from vprobot.plan_export import episode_document
from vprobot.planners.base import Episode, Planner, ViewRequest
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.candidates import CandidateViews
from vprobot.planners.episode import RobotEpisode, episode_rng
from vprobot.planners.free_flying import FreeFlyingEpisode
from vprobot.planners.hrec import BoxFacesPlanner
from vprobot.planners.oracle import OraclePlanner
from vprobot.planners.random_views import Random1Planner, Random2Planner

PLANNER_NAMES = ("random1", "random2", "hrec", "bscp", "oracle")
Mode = Literal["robot", "free"]
_FIXED_BSCP = re.compile(r"^bscp(\d+)$")


def make_planner(name: str, config: Config, views: int | None = None) -> Planner:
    """A planner by name; `views` fixes the number of views of `bscp` (B_SCP,n).

    Raises:
        ValueError: For an unknown name, or `views` with a planner other than bscp.
    """
    if name not in PLANNER_NAMES:
        raise ValueError(f"unknown planner {name!r}; allowed: {', '.join(PLANNER_NAMES)}")
    if views is not None and name != "bscp":
        raise ValueError(f"a fixed number of views applies to bscp only, not to {name!r}")
    if name == "bscp":
        return SetCoverPlanner(views, goal=config.env.coverage_goal,
                               max_views=config.env.max_acquisitions)
    if name == "oracle":
        return OraclePlanner()
    if name == "hrec":
        return BoxFacesPlanner()
    return Random1Planner(config) if name == "random1" else Random2Planner(config)


def parse_planner(spec: str) -> tuple[str, int | None]:
    """`bscp5` -> ("bscp", 5); a plain name -> (name, None).

    Raises:
        ValueError: If the spec names no planner.
    """
    if spec in PLANNER_NAMES:
        return spec, None
    match = _FIXED_BSCP.match(spec)
    if match is None or int(match[1]) < 1:
        raise ValueError(f"unknown planner {spec!r}; allowed: {', '.join(PLANNER_NAMES)}, or "
                         f"bscp<N> for B_SCP with N views (e.g. bscp5)")
    return "bscp", int(match[1])


@dataclasses.dataclass(frozen=True)
class EpisodeResult:
    """A finished episode of one planner.

    Attributes:
        planner: Planner label (`bscp5` for B_SCP with five views).
        mode: `robot` (robot in the loop) or `free` (free-flying sensor).
        mesh: The mesh file.
        seed: Seed of the object pose (and of random planners).
        record: What happened, view by view.
        goal: The coverage goal.
        plan_seconds: Time spent inside the planner (reset and next-view calls).
        episode_seconds: Wall time of the whole episode (planning and executing views).
        candidates: The candidate views of a model-based planner (bscp, oracle), else None.
    """

    planner: str
    mode: Mode
    mesh: str
    seed: int
    record: EpisodeRecord
    goal: float
    plan_seconds: float
    episode_seconds: float
    candidates: CandidateViews | None = None

    @property
    def coverage(self) -> float:
        return self.record.coverage

    @property
    def requested(self) -> int:
        """Views requested, the initial view included."""
        return len(self.record.views)

    @property
    def acquisitions(self) -> int:
        """Views actually acquired (never an unreached one)."""
        return sum(view.sensor_pose is not None for view in self.record.views)

    @property
    def reachability(self) -> float | None:
        """Fraction of the requested views the robot reached (None without the robot)."""
        if self.mode == "free" or not self.record.views:
            return None
        return sum(view.reachable for view in self.record.views) / len(self.record.views)

    @property
    def success(self) -> bool:
        return self.coverage >= self.goal - 1e-12

    @property
    def travel(self) -> TravelCost:
        return self.record.travel


def run_episode(planner: Planner, episode: Episode, config: Config,
                rng: np.random.Generator) -> tuple[EpisodeRecord, float]:
    """Let `planner` choose views until it stops, the goal or the view budget is reached.

    Planners that stop at the goal (`stops_at_goal`) get at most `env.max_acquisitions`
    requests after the initial view; fixed plans run to their end.

    Returns:
        The record and the time spent inside the planner (s).
    """
    env = config.env
    planning = 0.0
    start = time.perf_counter()
    planner.reset(episode, rng)
    planning += time.perf_counter() - start
    if planner.initial_view:
        episode.execute(ViewRequest(initial_view_target(config, episode.center)))
    first = len(episode.views)
    while True:
        if planner.stops_at_goal and (episode.coverage >= env.coverage_goal
                                      or len(episode.views) - first >= env.max_acquisitions):
            break
        start = time.perf_counter()
        view = planner.next_view(episode)
        planning += time.perf_counter() - start
        if view is None:
            break
        episode.execute(view)
    return episode.record(), planning


def run(config: Config, scene: MotorScene, planner: str, seed: int, mode: Mode = "robot",
        views: int | None = None) -> EpisodeResult:
    """One episode of a planner on a loaded motor, in the object pose of (motor, seed).

    Raises:
        ValueError: For an unknown planner or mode.
    """
    if mode not in ("robot", "free"):
        raise ValueError(f"mode must be 'robot' or 'free', got {mode!r}")
    rng = episode_rng(seed, scene)
    rotation = random_object_rotation(config.env, rng)
    episode = RobotEpisode(scene, rotation) if mode == "robot" else FreeFlyingEpisode(scene,
                                                                                      rotation)
    chosen = make_planner(planner, config, views)
    start = time.perf_counter()
    record, planning = run_episode(chosen, episode, config, rng)
    return EpisodeResult(planner=planner if views is None else f"{planner}{views}", mode=mode,
                         mesh=str(scene.mesh.path), seed=seed, record=record,
                         goal=config.env.coverage_goal, plan_seconds=planning,
                         episode_seconds=time.perf_counter() - start,
                         candidates=chosen.candidates)


def summary(result: EpisodeResult, config: Config) -> str:
    """A short human-readable report of an episode."""
    record, travel = result.record, result.travel
    where = (f"robot {config.cell.robot} in the loop" if result.mode == "robot"
             else "free-flying sensor (no robot)")
    quaternion = np.round(record.object_pose.quaternion, 4).tolist()
    reached = ("" if result.reachability is None
               else f", {result.reachability:.0%} of requests reachable")
    verdict = "reached" if result.success else "not reached"
    lines = [
        f"{result.planner} on {Path(result.mesh).name} (seed {result.seed}), {where}",
        f"  object quaternion (w, x, y, z) {quaternion}",
        f"  {result.requested} views requested, {result.acquisitions} acquired{reached}",
        f"  coverage {result.coverage:.1%} (goal {result.goal:.0%} {verdict})",
    ]
    if result.mode == "robot":
        lines.append(f"  travel {travel.joint_time:.2f} s joint time, {travel.joint_path:.2f} rad "
                     f"joint path, {travel.cartesian:.2f} m sensor path, {travel.paper:.2f} m "
                     f"paper approximation")
    else:
        lines.append(f"  travel {travel.paper:.2f} m (paper approximation)")
    lines.append(f"  planning {result.plan_seconds:.2f} s, episode {result.episode_seconds:.2f} s")
    candidates = result.candidates
    if candidates is not None:
        reach = (f", {int(candidates.usable.sum())} reachable (screened in "
                 f"{candidates.reach_seconds:.2f} s)" if result.mode == "robot" else "")
        lines.append(f"  candidates {len(candidates)}{reach}, visibility of the GT points "
                     f"{candidates.visibility_seconds:.2f} s")
    if result.mode == "robot":
        lines.append("  view  coverage  joint time  reached")
    else:
        lines.append("  view  coverage  paper travel")
    for index, view in enumerate(record.views, start=1):
        if result.mode == "robot":
            state = "yes" if view.reachable else f"no ({view.reason})"
            lines.append(f"  {index:4d}  {view.coverage:8.1%}  {view.travel.joint_time:8.2f} s  "
                         f"{state}")
        else:
            lines.append(f"  {index:4d}  {view.coverage:8.1%}  {view.travel.paper:10.2f} m")
    return "\n".join(lines)


def plan_motor(config: Config, mesh_path: str | Path | None = None, scale: float = 1.0,
               planner: str = "bscp", views: int | None = None, free: bool = False,
               seed: int = 0) -> tuple[MotorScene, EpisodeRecord, dict[str, Any], str]:
    """Plan the inspection of one motor (`vprobot plan`).

    Args:
        config: The configuration (cell, sensor, kinematics, env goal and budget).
        mesh_path: Mesh file; the bundled default motor when omitted.
        scale: Factor from the file's units to metres (0.001 for millimetres).
        planner: One of `PLANNER_NAMES`.
        views: Fixed number of views for bscp; None plans until the coverage goal.
        free: Free-flying sensor (no robot) instead of the robot in the loop.
        seed: Seed of the object pose.

    Returns:
        The motor scene (for rendering), the episode record, the plan JSON document (SPEC
        section 12) and a summary text.

    Raises:
        FileNotFoundError, ValueError: For a missing or unusable mesh, an unknown planner, or
            `views` with a planner other than bscp.
    """
    scene = MotorScene.load(config, mesh_path if mesh_path is not None else DEFAULT_MOTOR, scale)
    result = run(config, scene, planner, seed, "free" if free else "robot", views)
    document = episode_document(scene, result.record, robot=not free, metadata={
        "planner": result.planner, "mode": result.mode, "seed": seed,
        "goal": result.goal, "plan_seconds": result.plan_seconds,
    })
    return scene, result.record, document, summary(result, config)
