"""Motion benchmark: path planning per move, timing and export of a 10-view plan, and the replay
check of B_SCP, nbv and agent plans on every bundled robot (docs/motion.md).

Path planning is timed on two sets of moves of the cell's robot: random sequences of reachable
view-sphere configurations around the bundled motor (upright), and the moves of every plan the
replay part makes with that robot, planned again in their episode's cell. Each move is the
straight line when it is free, else OMPL's RRT-Connect; the two are reported apart, with the
moves where no path was found.
"""

from __future__ import annotations

import itertools
import tempfile
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from vprobot.config import Config, replace
from vprobot.episode import PartScene
from vprobot.episode.cycle import episode_moves
from vprobot.episode.records import EpisodeRecord
from vprobot.evaluation import held_out_motors
from vprobot.export.check import check_plan
from vprobot.export.formats import FORMATS
from vprobot.export.program import export_plan
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.motion_planner import MotionPlanner
from vprobot.kinematics.survey import view_sphere_targets
from vprobot.plan import write_json
from vprobot.planners.runner import plan_part
from vprobot.robots import available_robots

PLANNERS: tuple[str, ...] = ("bscp", "nbv", "agent")
"""The planners whose plans the replay check is held to (issue 32)."""

EXPORT_VIEWS = 10
"""Views of the plan whose timing and export are measured."""

EXPORT_REPEATS = 5
"""Times the timing and export of that plan are measured (the median is reported)."""

TARGETS = {"line_median_ms": 1.0, "rrt_connect_median_ms": 50.0, "export_10_views_s": 1.0}
"""The issue's targets."""

Move = tuple[np.ndarray, np.ndarray]


def _random_view_moves(scene: PartScene, count: int, seed: int) -> list[Move]:
    """Consecutive configurations of `count` + 1 random reachable view-sphere targets, in the
    order drawn: moves between views as a next-best-view planner makes them."""
    arm = scene.arm
    targets = view_sphere_targets(scene.cell)
    configurations = []
    for index in np.random.default_rng(seed).permutation(len(targets)):
        result = arm.reach(targets[index], arm.joints.start)
        if result.reachable:
            configurations.append(result.q)
        if len(configurations) > count:
            break
    return list(itertools.pairwise(configurations))


def _record_moves(record: EpisodeRecord) -> list[Move]:
    """The (start, end) of every move of an episode's cycle (approach, views, return)."""
    return [(move[0], move[-1]) for move in episode_moves(record) or []]


METHODS = ("line", "rrt_connect", "path_not_found")
"""How a move ended: the straight line, a path OMPL found, or none found."""


def time_moves(planner: MotionPlanner, moves: Iterable[Move],
               times: dict[str, list[float]] | None = None) -> dict[str, list[float]]:
    """Plan every move; the planning times (ms) by how each ended (`METHODS`), added to
    `times` when given."""
    times = times if times is not None else {method: [] for method in METHODS}
    for q_from, q_to in moves:
        start = time.perf_counter()
        plan = planner.plan(q_from, q_to)
        elapsed_ms = (time.perf_counter() - start) * 1e3
        times["path_not_found" if plan is None else plan.method].append(elapsed_ms)
    return times


def summarise_times(times: dict[str, list[float]]) -> dict[str, Any]:
    """`moves` and per method (`METHODS`) `count`, `median_ms`, `p95_ms`, `max_ms` (None
    without moves)."""

    def figures(values: list[float]) -> dict[str, Any]:
        return {"count": len(values),
                "median_ms": float(np.median(values)) if values else None,
                "p95_ms": float(np.percentile(values, 95)) if values else None,
                "max_ms": max(values) if values else None}

    return {"moves": sum(len(values) for values in times.values()),
            **{method: figures(times[method]) for method in METHODS}}


def time_export(document: dict[str, Any], repeats: int = EXPORT_REPEATS) -> dict[str, Any]:
    """Time the timing (`time_plan`, inside `export_plan`) and export of a plan in every format.

    Returns:
        `s_median` / `s_max` (all formats together, over `repeats` runs) and `format_s` (format
        -> median seconds of that format alone).
    """
    totals: list[float] = []
    per_format: dict[str, list[float]] = {name: [] for name in FORMATS}
    for _ in range(repeats):
        begin = time.perf_counter()
        for name in FORMATS:
            start = time.perf_counter()
            export_plan(document, name)
            per_format[name].append(time.perf_counter() - start)
        totals.append(time.perf_counter() - begin)
    return {"s_median": float(np.median(totals)), "s_max": max(totals),
            "format_s": {name: float(np.median(values)) for name, values in per_format.items()}}


def replay_one(config: Config, motor: Path, planner: str, folder: Path
               ) -> tuple[dict[str, Any], PartScene | None, EpisodeRecord | None]:
    """Plan one motor, write its plan JSON and run the replay check on it.

    Returns:
        The row (`robot`, `planner`, `motor`, `planned`, `holds`, `views` acquired, `cycle_s`,
        `plan_s`, `check_s`, `failures`: the planner's error or the check's failures), and the
        scene and record (None when the planner failed).
    """
    row: dict[str, Any] = {"robot": config.cell.robot, "planner": planner, "motor": motor.stem}
    start = time.perf_counter()
    try:
        scene, record, document, _ = plan_part(config, motor, planner=planner)
    except ValueError as error:
        return {**row, "planned": False, "holds": False, "failures": [str(error)]}, None, None
    row.update(planned=True, plan_s=time.perf_counter() - start,
               views=sum(view.acquired for view in record.views))
    path = write_json(folder / f"{config.cell.robot}_{planner}_{motor.stem}.json", document)
    start = time.perf_counter()
    try:
        check = check_plan(config, path)
    except ValueError as error:  # e.g. a plan whose cycle could not be closed
        return {**row, "holds": False, "check_s": time.perf_counter() - start,
                "failures": [str(error)]}, scene, record
    return {**row, "holds": check.holds, "cycle_s": check.cycle_s,
            "check_s": time.perf_counter() - start, "failures": list(check.failures)}, scene, record


def run_motion_benchmark(config: Config, robots: Sequence[str] | None = None,
                         planners: Sequence[str] = PLANNERS,
                         motors: Sequence[str | Path] | None = None, samples: int = 200,
                         progress: bool = True) -> dict[str, Any]:
    """Measure the motion targets (issue 32).

    Args:
        config: The configuration; its robot's moves are timed.
        robots: Robots of the replay check; every bundled robot when None.
        planners: Planners of the replay check.
        motors: Meshes of the replay check; the bundled test motors when None.
        samples: Random view-to-view moves to time.
        progress: Show progress bars.

    Returns:
        `robot`, `path_planning` (`random_views` and `plan_moves`, each `summarise_times`'s),
        `export_10_views` (`time_export`'s, with `views` acquired; `error` when nbv made no
        plan), `replay` (one row per
        robot, planner and motor: `replay_one`'s), `replay_summary` (`plans`, `planned`,
        `held`, `check_failed`, `not_planned`) and `targets`.
    """
    robots = available_robots() if robots is None else robots
    paths = [Path(path) for path in motors] if motors is not None else held_out_motors()
    scene = PartScene.load(config, DEFAULT_MOTOR)
    arm = scene.arm
    random_moves = _random_view_moves(scene, samples, seed=32)
    random_times = time_moves(MotionPlanner(arm.collisions, arm.joints, arm.settings),
                              tqdm(random_moves, desc="random moves", disable=not progress,
                                   leave=False))

    try:
        _, record, document, _ = plan_part(config, DEFAULT_MOTOR, planner="nbv",
                                            stop=f"views:{EXPORT_VIEWS}")
        export = {"views": sum(view.acquired for view in record.views), **time_export(document)}
    except ValueError as error:  # e.g. the UR5 reaches no fixed initial view
        export = {"error": str(error)}

    rows: list[dict[str, Any]] = []
    plan_times: dict[str, list[float]] = {method: [] for method in METHODS}
    runs = [(robot, planner, motor) for robot in robots for planner in planners for motor in paths]
    with tempfile.TemporaryDirectory() as folder:
        for robot, planner, motor in tqdm(runs, desc="replay", disable=not progress):
            row, plan_scene, plan_record = replay_one(replace(config, "cell", robot=robot), motor,
                                                      planner, Path(folder))
            rows.append(row)
            if robot == config.cell.robot and plan_scene and plan_record:
                # Planned again in the episode's cell: the object as the episode placed it.
                checker = CollisionChecker(plan_scene.cell, plan_record.object_pose.rotation)
                time_moves(MotionPlanner(checker, plan_scene.arm.joints, plan_scene.arm.settings),
                           _record_moves(plan_record), plan_times)
    planned = [row for row in rows if row["planned"]]
    return {
        "robot": config.cell.robot,
        "path_planning": {"random_views": summarise_times(random_times),
                          "plan_moves": summarise_times(plan_times)},
        "export_10_views": export,
        "replay": rows,
        "replay_summary": {"plans": len(rows), "planned": len(planned),
                           "held": sum(row["holds"] for row in planned),
                           "check_failed": sum(not row["holds"] for row in planned),
                           "not_planned": len(rows) - len(planned)},
        "targets": TARGETS,
    }


def print_table(results: dict[str, Any]) -> None:
    """Print the path planning times, the export time and the replay check per plan."""
    targets = results["targets"]
    print(f"path planning ({results['robot']}): moves  line median / p95 ms (n)  "
          f"rrt_connect median / p95 ms (n)  path not found (n)")
    for name, figures in results["path_planning"].items():
        shown = [f"{figures[method]['median_ms']:.2f} / {figures[method]['p95_ms']:.2f} "
                 f"({figures[method]['count']})" if figures[method]["count"] else "- (0)"
                 for method in ("line", "rrt_connect")]
        print(f"  {name:<14}{figures['moves']:>6}  {shown[0]:>24}  {shown[1]:>30}  "
              f"{figures['path_not_found']['count']:>18}")
    print(f"  targets: line <= {targets['line_median_ms']:g} ms, rrt_connect <= "
          f"{targets['rrt_connect_median_ms']:g} ms (medians)")
    export = results["export_10_views"]
    if "error" in export:
        print(f"no {EXPORT_VIEWS}-view nbv plan to time and export: {export['error']}")
    else:
        print(f"timing and export of a {export['views']}-view plan, every format: "
              f"{export['s_median']:.3f} s (median; max {export['s_max']:.3f} s; target <= "
              f"{targets['export_10_views_s']:g} s)")
    print(f"{'robot':<7}{'planner':<8}{'motor':<11}{'views':>6}{'cycle s':>9}  replay check")
    for row in results["replay"]:
        verdict = ("holds" if row["holds"] else
                   ("FAILED: " if row["planned"] else "no plan: ") + "; ".join(row["failures"]))
        cycle = f"{row['cycle_s']:9.2f}" if "cycle_s" in row else f"{'-':>9}"
        print(f"{row['robot']:<7}{row['planner']:<8}{row['motor']:<11}{row.get('views', 0):>6}"
              f"{cycle}  {verdict}")
    summary = results["replay_summary"]
    print(f"replay check: {summary['held']} of {summary['planned']} plans hold "
          f"({summary['not_planned']} of {summary['plans']} runs made no plan)")
