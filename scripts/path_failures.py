"""Requests failing for their path, per planner, with the straight line only and with RRT-Connect.

Runs each planner on episodes of a list with the robot, once per `kinematics.path_planner`
(`line`: the straight line only, the behaviour before motion planning; `rrt_connect`), and counts
the requests by outcome; every motion-planning query is timed by the method that answered it.
One JSON line per (path planner, planner, episode) goes into OUT/path_failures.jsonl as it
finishes, so a rerun resumes; OUT/path_failures.md is the summary. Timings run under whatever
else the machine runs.

    python scripts/path_failures.py --planners random2 nbv bscp uniform8 agent \\
        --select 0 3 6 9 12 --out results/motion
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config, load_config, replace
from vprobot.episode import PartScene
from vprobot.evaluation import evaluation_episodes
from vprobot.files.atomic import append_line, folder_lock, write_text
from vprobot.kinematics.motion_planner import MotionPlan, MotionPlanner
from vprobot.planners.runner import parse_planner, run

PATH_PLANNERS = ("line", "rrt_connect")
PATH_REASONS = ("path_not_found",)
"""Failures caused by the path (the others: no collision-free IK solution)."""


@contextmanager
def timed_queries() -> Iterator[dict[str, list[float]]]:
    """Time every `MotionPlanner.plan` call in the block, by the method that answered it
    (`failed`: no path)."""
    times: dict[str, list[float]] = {"line": [], "rrt_connect": [], "failed": []}
    original: Callable[..., MotionPlan | None] = MotionPlanner.plan

    def plan(self: MotionPlanner, q_from: np.ndarray, q_to: np.ndarray) -> MotionPlan | None:
        start = time.perf_counter()
        result = original(self, q_from, q_to)
        times["failed" if result is None else result.method].append(time.perf_counter() - start)
        return result

    MotionPlanner.plan = plan  # type: ignore[method-assign]
    try:
        yield times
    finally:
        MotionPlanner.plan = original  # type: ignore[method-assign]


def episode_line(config: Config, path_planner: str, planner: str, index: int,
                 scene: PartScene, spec: Any) -> dict[str, Any]:
    """Run one episode and count its requests by outcome."""
    name, views = parse_planner(planner)
    with timed_queries() as times:
        result = run(config, scene, name, spec, "robot", views)
    reasons: dict[str, int] = {}
    for view in result.record.views:
        key = "reached" if view.reachable else str(view.reason)
        reasons[key] = reasons.get(key, 0) + 1
    return {"path_planner": path_planner, "planner": planner, "episode": index,
            "requests": len(result.record.views), "outcomes": reasons,
            "coverage_pct": 100.0 * result.coverage, "query_s": times}


def summary(lines: list[dict[str, Any]], planners: list[str]) -> str:
    """The markdown table: per planner and path planner, requests by outcome and query times."""
    rows = ["| planner | path planner | episodes | requests | failed for the path | failed, "
            "pose unreachable | mean coverage | line queries: median ms | RRT-Connect queries: "
            "n, median ms | no path: n, median ms |", "|---|---|---|---|---|---|---|---|---|---|"]
    for planner in planners:
        for path_planner in PATH_PLANNERS:
            chosen = [line for line in lines
                      if line["planner"] == planner and line["path_planner"] == path_planner]
            if not chosen:
                continue
            requests = sum(line["requests"] for line in chosen)
            path = sum(count for line in chosen for reason, count in line["outcomes"].items()
                       if reason in PATH_REASONS)
            other = sum(count for line in chosen for reason, count in line["outcomes"].items()
                        if reason not in PATH_REASONS and reason != "reached")
            times = {method: [t for line in chosen for t in line["query_s"][method]]
                     for method in ("line", "rrt_connect", "failed")}

            def median_ms(values: list[float]) -> str:
                return f"{1e3 * statistics.median(values):.2f}" if values else "-"

            rows.append(
                f"| {planner} | {path_planner} | {len(chosen)} | {requests} | {path} "
                f"({100.0 * path / requests:.1f} %) | {other} ({100.0 * other / requests:.1f} %) "
                f"| {statistics.fmean(line['coverage_pct'] for line in chosen):.1f} % "
                f"| {median_ms(times['line'])} | {len(times['rrt_connect'])}, "
                f"{median_ms(times['rrt_connect'])} | {len(times['failed'])}, "
                f"{median_ms(times['failed'])} |")
    return "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=None, help="YAML config (default: the default)")
    parser.add_argument("--planners", nargs="+", default=["random2", "nbv", "bscp", "uniform8",
                                                          "agent"])
    parser.add_argument("--episodes", default="test-v1", help="episode list (default: test-v1)")
    parser.add_argument("--select", type=int, nargs="+", default=None,
                        help="indices into the list (default: all)")
    parser.add_argument("--out", type=Path, default=Path("results/motion"))
    args = parser.parse_args()
    base = load_config(args.config)
    specs = evaluation_episodes(base, episodes=args.episodes)
    indices = args.select if args.select is not None else list(range(len(specs)))
    with folder_lock(args.out, str(args.out)):
        lines_path = args.out / "path_failures.jsonl"
        lines = ([json.loads(text) for text in lines_path.read_text().splitlines()
                  if text.endswith("}")] if lines_path.exists() else [])
        done = {(line["path_planner"], line["planner"], line["episode"]) for line in lines}
        for path_planner in PATH_PLANNERS:
            config = replace(base, "kinematics", path_planner=path_planner)
            for index in indices:
                spec = specs[index]
                todo = [planner for planner in args.planners
                        if (path_planner, planner, index) not in done]
                if not todo:
                    continue
                scene = PartScene.load(config, spec.part_path, spec.scale)
                for planner in todo:
                    line = episode_line(config, path_planner, planner, index, scene, spec)
                    append_line(lines_path, json.dumps(line) + "\n")
                    lines.append(line)
                    print(path_planner, planner, index, line["outcomes"], flush=True)
        write_text(args.out / "path_failures.md", summary(lines, args.planners))
    print(summary(lines, args.planners))


if __name__ == "__main__":
    main()
