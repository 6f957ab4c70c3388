"""Run a planner through an episode, and plan one part end to end (`vprobot plan`)."""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.cell.check import Clearance, check_cell, placed_part
from vprobot.config import Config
from vprobot.coverage.occupancy import GridSettings
from vprobot.episode import (
    CARRIERS,
    CarrierName,
    Episode,
    EpisodeRecord,
    EpisodeSpec,
    PartScene,
    SharedWork,
    describe_cycle,
    seeded_episode,
)
from vprobot.episode.clearances import episode_clearances
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import matrix_to_quat
from vprobot.kinematics import TravelCost
from vprobot.kinematics.trajectory import CycleTime
from vprobot.plan import episode_document
from vprobot.planners.base import (
    PLANNERS,
    Planner,
    check_views,
    counted_planners,
    planner_names,
)
from vprobot.planners.candidates import CandidateViews, ModelBasedPlanner
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.proof import ExactPlanner, Proof
from vprobot.planners.self_stopping import LearnedStop, SelfStopping, stop_subject
from vprobot.stopping.estimator import load_estimator
from vprobot.stopping.rules import StopRule, make_stop_rule
from vprobot.stopping.rules.confident import ConfidentStop
from vprobot.stopping.rules.estimate import view_estimates


def _match(name: str) -> tuple[type[Planner], dict[str, str]] | None:
    """The planner class a name (without a view count) selects and its pattern's groups."""
    for registered in PLANNERS:
        match = re.fullmatch(re.escape(registered) + PLANNERS.fact(registered, "pattern"), name)
        if match is not None:
            return PLANNERS[registered], {key: value for key, value
                                         in match.groupdict().items() if value is not None}
    return None


def make_planner(name: str, config: Config, views: int | None = None) -> Planner:
    """A planner by name; `views` fixes the number of views of a `counted` planner (`bscp`:
    B_SCP,n; an agent, the initial view included).

    Raises:
        ValueError: For an unknown name, `views` with a planner that has no view count or
            outside 1..MAX_VIEWS (`check_views`), or an agent that cannot be loaded.
    """
    found = _match(name)
    if found is None:
        raise ValueError(f"unknown planner {name!r}; allowed: {', '.join(planner_names())}")
    cls, params = found
    if views is not None and not cls.counted:
        raise ValueError(f"a fixed number of views applies to "
                         f"{', '.join(counted_planners())} only, not to {name!r}")
    return cls.from_name(config, views, **params)


def parse_planner(spec: str, counted: bool = True) -> tuple[str, int | None]:
    """`bscp5` -> ("bscp", 5), `agent6` -> ("agent", 6); a plain name or `agent:PATH` ->
    (spec, None).

    Args:
        spec: The planner as the user wrote it.
        counted: Whether a view count may follow the name (`evaluate --planners`); `plan` and
            `render` take it from `--views` instead, and their messages say so.

    Raises:
        ValueError: If the spec names no planner, or carries a view count that `counted`
            forbids; the message lists the accepted forms.
    """
    if _match(spec) is not None:
        return spec, None
    for name in counted_planners():
        match = re.fullmatch(re.escape(name) + r"(\d+)", spec)
        if match is not None and int(match[1]) >= 1:
            if counted:
                check_views(int(match[1]), f"the view count of {spec!r}")
                return name, int(match[1])
            raise ValueError(f"give the view count with --views, not in the name: "
                             f"--planner {name} --views {match[1]}")
    names = counted_planners()
    forms = (f", or {' / '.join(f'{name}<N>' for name in names)} for these planners with N "
             f"views (e.g. {names[0]}5)" if counted
             else f"; a fixed number of views ({', '.join(names)}) goes in --views")
    raise ValueError(f"unknown planner {spec!r}; allowed: {', '.join(planner_names())}{forms}")


@dataclasses.dataclass(frozen=True)
class EpisodeResult:
    """A finished episode of one planner.

    Attributes:
        planner: Planner label (`bscp5` for B_SCP with five views).
        carrier: `robot` (robot in the loop) or `free` (free-flying sensor).
        spec: The episode (part, object rotation, initial view; its seed seeds random
            planners).
        record: What happened, view by view.
        goal: The coverage goal.
        plan_seconds: Time spent inside the planner (reset and next-view calls).
        episode_seconds: Wall time of the whole episode (planning and executing views).
        candidates: The candidate views of a model-based planner (`ModelBasedPlanner`: bscp,
            oracle), else None.
        stop_reason: Why the episode ended (`goal reached`, `max views`, the stop rule's or the
            planner's own reason, e.g. `nbv@grid`'s).
        stop_rule: The stop rule (`--stop`: `goal`, `estimate:0.9`, ...).
        planner_stopped: Whether the planner ended the episode itself (its own reason, or a
            fixed plan that ran out) rather than the runner.
        estimates: The model-free coverage estimate (mean, std) after each view, when asked for
            or stopped by `confident` (NaN where it was refused); under `confident` a third
            column, the calibrated probability that the goal is reached
            (`ConfidentStop.goal_probabilities`).
        estimate_notes: Why the estimate was refused, widened or kept, each once.
        proof: What an exact planner (`ExactPlanner`: `optimum`) proved of its plan; None for
            the others.
        clearances: The least distance from the robot to each object of the cell over the
            moves it made (`episode_clearances`); None when it made none.
    """

    planner: str
    carrier: CarrierName
    spec: EpisodeSpec
    record: EpisodeRecord
    goal: float
    plan_seconds: float
    episode_seconds: float
    candidates: CandidateViews | None = None
    stop_reason: str | None = None
    stop_rule: str = "goal"
    planner_stopped: bool = False
    estimates: np.ndarray | None = None
    estimate_notes: tuple[str, ...] = ()
    proof: Proof | None = None
    clearances: tuple[Clearance, ...] | None = None

    @property
    def cycle(self) -> CycleTime | None:
        """The cell's cycle time of the part and its parts (docs/motion.md#cycle-time), as the
        episode timed it (`EpisodeRecord.cycle`): approach, moves, acquisitions, return; None
        without a robot, without an acquisition, or when no path back to the start was
        found."""
        return self.record.cycle

    @property
    def mesh(self) -> str:
        return str(self.spec.part_path)

    @property
    def seed(self) -> int:
        return self.spec.seed

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
        return sum(view.acquired for view in self.record.views)

    @property
    def reachability(self) -> float | None:
        """Fraction of the requested views the robot reached (None without the robot)."""
        if self.carrier == "free" or not self.record.views:
            return None
        return sum(view.reachable for view in self.record.views) / len(self.record.views)

    @property
    def success(self) -> bool:
        return self.coverage >= self.goal - 1e-12

    @property
    def travel_sum(self) -> TravelCost:
        """k_cum: the moves between acquisitions (the approach to the first one excluded)."""
        return self.record.travel_sum


@dataclasses.dataclass(frozen=True)
class Played:
    """What `run_episode` returns.

    Attributes:
        record: What happened, view by view.
        plan_seconds: Time spent inside the planner (reset and next-view calls).
        stop_reason: Why the episode ended.
        planner_stopped: Whether the planner ended it itself (else the runner did).
    """

    record: EpisodeRecord
    plan_seconds: float
    stop_reason: str
    planner_stopped: bool


PLAN_RAN_OUT = "plan ran out"
"""Why an episode ended when the planner had no further view and gave no reason."""
NO_INITIAL_VIEW = "no initial view"
"""How the reason starts when an episode ended before it began: the robot reached none of the
initial views (the rest of the reason says why)."""


def run_episode(planner: Planner, episode: Episode, spec: EpisodeSpec, config: Config,
                rng: np.random.Generator, stop: StopRule | None = None) -> Played:
    """Let `planner` choose views until it stops, the stop rule or the view budget says so.

    Planners that start from the environment's initial view (`InitialViewPlanner`) get the
    spec's.
    The stop rule (default `goal`: the coverage goal, for planners that stop there) is asked
    before each request; a planner the rule governs gets at most `env.max_acquisitions`
    requests after the initial view; fixed plans, and planners the rule leaves to stop
    themselves, run to their end.

    An episode whose initial view the robot reaches from none of the candidates ends at once,
    with nothing requested and the reason `NO_INITIAL_VIEW: ...` (an evaluation scores it as
    an episode that covered nothing, instead of stopping).

    Raises:
        ValueError: If the rule does not apply to the planner.
    """
    if stop is None:
        stop = make_stop_rule("goal", config)
    stop.bind(stop_subject(planner))
    if isinstance(planner, LearnedStop) and not stop.keeps_learned_stop:
        # The rule decides: a learned stop action is no longer used.
        planner.decides_stop = False
    governed = stop.governs(stop_subject(planner))
    stop.reset()
    env = config.env
    planning = 0.0
    start = time.perf_counter()
    planner.reset(episode, rng)
    planning += time.perf_counter() - start
    if isinstance(planner, InitialViewPlanner):
        try:
            episode.begin(spec.initial_requests(episode.center,
                                                config.sensor.working_distance_m))
        except ValueError as error:
            return Played(episode.record(), planning, f"{NO_INITIAL_VIEW}: {error}", False)
    first = len(episode.views)
    while True:
        if governed:
            reason = stop.check(episode)
            if reason is None and len(episode.views) - first >= env.max_acquisitions:
                reason = "max views"
            if reason is not None:
                return Played(episode.record(), planning, reason, False)
        start = time.perf_counter()
        view = planner.next_view(episode)
        planning += time.perf_counter() - start
        if view is None:
            own = planner.stop_reason if isinstance(planner, SelfStopping) else None
            return Played(episode.record(), planning, own or PLAN_RAN_OUT, True)
        episode.request(view)


def run(config: Config, scene: PartScene, planner: str, spec: EpisodeSpec,
        carrier: CarrierName = "robot", views: int | None = None, stop: str = "goal",
        estimator: str | Path | None = None, estimates: bool = False,
        shared: SharedWork | None = None,
        built: tuple[Planner, StopRule] | None = None) -> EpisodeResult:
    """One episode of a planner on a loaded part, as the spec fixes it.

    Args:
        config: The configuration.
        scene: The loaded part.
        planner: A planner name (`planner_names`).
        spec: The episode.
        carrier: `robot` or `free`.
        views: Fixed number of views of a `counted` planner.
        stop: A stop rule (`vprobot.stopping.rules`: `goal`, `estimate:0.9`, `views:5`, ...).
        estimator: The coverage estimator file (None: the bundled one), for `estimate` and
            `estimates`.
        estimates: Also estimate the coverage after each view, model-free, as `estimate`
            does (`EpisodeResult.estimates`).
        shared: The work shared with the other planners of this spec and carrier
            (`SharedWork`); the episode's own when omitted.
        built: The planner and stop rule that `planner`, `views` and `stop` name, already
            built (an evaluation runs one per planner through its episodes: each episode
            resets them); built here when omitted.

    Raises:
        ValueError: For an unknown planner, carrier or stop rule, a rule that does not apply
            to the planner, an estimator that cannot be read, or `shared` of another episode.
    """
    if carrier not in CARRIERS:
        raise ValueError(f"carrier must be one of {list(CARRIERS)}, got {carrier!r}")
    chosen, rule = built or (make_planner(planner, config, views),
                             make_stop_rule(stop, config, estimator))
    estimate = (load_estimator(estimator, config.sensor)
                if estimates or isinstance(rule, ConfidentStop) else None)
    episode = Episode.from_spec(scene, spec, carrier, config.env.unreachable, shared)
    start = time.perf_counter()
    played = run_episode(chosen, episode, spec, config, np.random.default_rng(spec.seed), rule)
    seconds = time.perf_counter() - start
    # The estimate reads the episode's grid, which the planner and the rule may have filled.
    estimated, notes = (view_estimates(config, played.record.views, estimate, chosen.name,
                                       episode.occupancy(GridSettings.of(config)))
                        if estimate is not None else (None, []))
    if isinstance(rule, ConfidentStop) and estimated is not None:
        estimated = np.column_stack([estimated, rule.goal_probabilities(estimated)])
    return EpisodeResult(planner=planner if views is None else f"{planner}{views}",
                         carrier=carrier, spec=spec, record=played.record,
                         goal=config.env.coverage_goal, plan_seconds=played.plan_seconds,
                         episode_seconds=seconds,
                         candidates=(chosen.candidates if isinstance(chosen, ModelBasedPlanner)
                                     else None),
                         stop_reason=played.stop_reason,
                         stop_rule=stop, planner_stopped=played.planner_stopped,
                         estimates=estimated, estimate_notes=tuple(notes),
                         proof=chosen.proof if isinstance(chosen, ExactPlanner) else None,
                         clearances=episode_clearances(played.record, scene.cell))


def summary(result: EpisodeResult, config: Config) -> str:
    """A short human-readable report of an episode."""
    record, travel = result.record, result.travel_sum
    robot = result.carrier == "robot"
    where = (f"robot {config.cell.robot} in the loop" if robot
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
    approach = record.approach
    if robot:
        lines.append(f"  {describe_cycle(record)}")
        lines.append(f"  approach from the start {approach.joint_time:.2f} s joint time")
        lines.append(f"  travel {travel.joint_time:.2f} s joint time, {travel.joint_path:.2f} rad "
                     f"joint path, {travel.cartesian:.2f} m sensor path, {travel.paper:.2f} m "
                     f"paper approximation (between views)")
    else:
        lines.append(f"  travel {travel.paper:.2f} m paper approximation, {travel.cartesian:.2f} m "
                     f"sensor path (between views)")
    if result.planner_stopped:
        lines.append(f"  stopped by the planner: {result.stop_reason} (--stop "
                     f"{result.stop_rule})")
    else:
        lines.append(f"  stopped: {result.stop_reason} (--stop {result.stop_rule})")
    lines.append(f"  planning {result.plan_seconds:.2f} s, episode {result.episode_seconds:.2f} s")
    candidates = result.candidates
    if candidates is not None:
        reach = (f", {int(candidates.usable.sum())} reachable (screened in "
                 f"{candidates.reach_seconds:.2f} s)" if robot else "")
        lines.append(f"  candidates {len(candidates)}{reach}, visibility of the GT points "
                     f"{candidates.visibility_seconds:.2f} s")
    estimates = result.estimates
    # The model-free estimate beside the true coverage, when there is one.
    heading = "" if estimates is None else "  estimate (model-free)"
    if robot:
        lines.append(f"  view  coverage  joint time  reached{heading}")
    else:
        lines.append(f"  view  coverage  paper travel{heading}")
    for index, view in enumerate(record.views, start=1):
        if robot:
            state = "yes" if view.reachable else f"no ({view.reason})"
            line = (f"  {index:4d}  {view.coverage:8.1%}  {view.travel.joint_time:8.2f} s  "
                    f"{state:7s}")
        else:
            line = f"  {index:4d}  {view.coverage:8.1%}  {view.travel.paper:10.2f} m"
        if estimates is not None:
            mean, std, *probability = estimates[index - 1]
            line += ("  refused" if np.isnan(mean) else f"  {100 * mean:5.1f} ± {100 * std:4.1f} %")
            if probability and not np.isnan(mean):
                line += f"  P(goal) {probability[0]:.3f}"
        lines.append(line.rstrip())
    lines += [f"  estimate {note}" for note in result.estimate_notes]
    return "\n".join(lines)


def result_document(scene: PartScene, result: EpisodeResult,
                    ground_truth: bool = True) -> dict[str, Any]:
    """The plan JSON of a finished episode (`episode_document`, with the cycle the episode
    timed), with the planner, seed, goal, why it stopped and how long planning took; without
    the ground-truth block unless `ground_truth`."""
    return episode_document(scene, result.record, metadata={
        "planner": result.planner, "seed": result.seed, "goal": result.goal,
        "stop_rule": result.stop_rule, "stop_reason": result.stop_reason,
        # Wall-clock figures in a block of their own, which `plan --no-timing` leaves out.
        "timing": {"plan_s": result.plan_seconds, "episode_s": result.episode_seconds},
    }, estimates=result.estimates, ground_truth=ground_truth)


def plan_part(config: Config, mesh_path: str | Path | None = None, scale: float = 1.0,
               planner: str = "bscp", views: int | None = None,
               carrier: CarrierName = "robot", seed: int = 0, stop: str = "goal",
               estimator: str | Path | None = None
               ) -> tuple[PartScene, EpisodeRecord, dict[str, Any], str]:
    """Plan the inspection of one part (`vprobot plan`).

    Args:
        config: The configuration (cell, sensor, kinematics, env goal and budget).
        mesh_path: Mesh file; the cell's part (`cell.part`, at its pose), else the bundled
            default motor, when omitted.
        scale: Factor from the file's units to metres (0.001 for millimetres).
        planner: A planner name (`planner_names`).
        views: Fixed number of views for bscp; None plans until the coverage goal.
        carrier: `robot` (robot in the loop) or `free` (free-flying sensor).
        seed: Seed of the episode (object pose, initial view).
        stop: The stop rule (`vprobot.stopping.rules`).
        estimator: The coverage estimator file (None: the bundled one) of `estimate` and of
            the estimate after each view.

    Returns:
        The part's scene (for rendering), the episode record, the plan JSON document
        (docs/plan-format.md) and a summary text.

    Raises:
        FileNotFoundError, ValueError: For a missing or unusable mesh, an unknown planner, or
            `views` with a planner other than bscp, a bad stop rule or estimator.
    """
    part = config.cell.part
    if part is not None:
        if mesh_path is not None:
            raise ValueError(f"--mesh {mesh_path} and the cell's part {part.mesh}: the cell "
                             f"places its part, so give one or the other")
        config, mesh = placed_part(config)
        mesh_path, scale = part.mesh, part.scale
        scene = PartScene.build(config, mesh, scale_option="cell.part.scale")
        spec = dataclasses.replace(seeded_episode(config.env, mesh_path, seed, scale),
                                   object_quaternion=tuple(matrix_to_quat(part.rotation)))
    else:
        mesh_path = mesh_path if mesh_path is not None else DEFAULT_MOTOR
        scene = PartScene.load(config, mesh_path, scale, scale_option="--scale")
        spec = seeded_episode(config.env, mesh_path, seed, scale)
    # Nothing is planned in a cell that fails its own check.
    data = scene.cell.make_data()
    scene.cell.place_object(data, spec.rotation)
    check_cell(scene.cell, data)
    result = run(config, scene, planner, spec, carrier, views, stop, estimator, estimates=True)
    if result.stop_reason is not None and result.stop_reason.startswith(NO_INITIAL_VIEW):
        raise ValueError(result.stop_reason.removeprefix(f"{NO_INITIAL_VIEW}: "))
    document = result_document(scene, result)
    text = summary(result, config)
    if scene.mesh.simplification is not None:
        text += f"\n  mesh {scene.mesh.simplification.describe()}"
    return scene, result.record, document, text
