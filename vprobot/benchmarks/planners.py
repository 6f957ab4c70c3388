"""Planner benchmark: B_SCP speed with the robot in the loop, coverage next to the paper's Table 9.

Per test motor and seed (one episode spec each), it runs B_SCP until the coverage goal with the
robot in the loop (planning time includes the reachability of all 900 candidates), B_SCP,4 and
B_SCP,5 with the free-flying sensor, H_rec with both carriers, and the bundled agent with the
robot (coverage, acquisitions, reachable share of its requests, policy time per view; and that
time split into its decision per view, from the acquired frames and the network, and its
reachability screening, once per episode), and the
model-free baselines: uniform4 with both carriers and nbv (goal-stopped) with both carriers, whose
planning time per view free-flying is the occupancy grid's own cost (integrating the frame,
scoring every candidate) and with the robot adds the IK of the candidates it tries.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from tqdm import tqdm

from vprobot.config import Config
from vprobot.env.grid_state import GridState
from vprobot.episode import CarrierName, Episode, PartScene, seeded_episode
from vprobot.evaluation import PAPER_TABLE_9, held_out_motors
from vprobot.planners.runner import EpisodeResult, run

RUNS: tuple[tuple[str, str, int | None, CarrierName], ...] = (
    ("bscp_robot", "bscp", None, "robot"),
    ("bscp_free", "bscp", None, "free"),
    ("bscp4_free", "bscp", 4, "free"),
    ("bscp5_free", "bscp", 5, "free"),
    ("hrec_free", "hrec", None, "free"),
    ("hrec_robot", "hrec", None, "robot"),
    ("agent_robot", "agent", None, "robot"),
    ("uniform4_free", "uniform4", None, "free"),
    ("uniform4_robot", "uniform4", None, "robot"),
    ("nbv_free", "nbv", None, "free"),
    ("nbv_robot", "nbv", None, "robot"),
)
"""(key, planner, fixed views, carrier) of every benchmarked run."""


@contextmanager
def _timed_screenings() -> Iterator[list[float]]:
    """The seconds of each reachability screening of the agent's state (`GridState.screening`'s
    first call in an episode; later calls reuse it), recorded while the context lasts."""
    seconds: list[float] = []
    screening = GridState.screening

    def timed(state: GridState, episode: Episode) -> tuple[Any, ...]:
        first = state._screening is None
        start = time.perf_counter()
        screened = screening(state, episode)
        if first:
            seconds.append(time.perf_counter() - start)
        return screened

    # The screening runs inside the planner's own calls; only wrapping it separates it there.
    GridState.screening = timed  # type: ignore[method-assign,assignment]
    try:
        yield seconds
    finally:
        GridState.screening = screening  # type: ignore[method-assign]


def run_planners_benchmark(config: Config, motors: Sequence[str | Path] | None = None,
                           seeds: Sequence[int] = (0, 1), progress: bool = True) -> dict[str, Any]:
    """Measure the planner targets on the test motors.

    Args:
        config: The configuration.
        motors: Mesh files; the bundled test motors when None.
        seeds: Seeds of the object poses (one episode per motor, seed and run).
        progress: Show a progress bar.

    Returns:
        `bscp_plan_s_median` / `_max` (B_SCP until the goal with the robot: planning time,
        including the reachability of all candidates), `bscp_episode_s_median` (planning and
        executing), `bscp_reach_s_median`, `bscp_visibility_s_median`,
        `bscp_candidates_reachable_pct`, `bscp_robot_coverage_pct`, `bscp_robot_views`,
        `bscp_free_coverage_pct`, `bscp4_free_coverage_pct`, `bscp5_free_coverage_pct`,
        `hrec_free_coverage_pct`, `hrec_robot_coverage_pct`, `hrec_robot_reachable_pct`,
        `agent_robot_coverage_pct`, `agent_robot_acquisitions`, `agent_reachable_share`,
        `agent_ms_per_view` (median), `agent_decision_ms_per_view_median` / `_max` (the same
        with the screening left out), `agent_screening_s_median` / `_max` (the reachability
        screening, once per episode), `agent_plan_s_median` / `_max` (all of an episode's
        planning), `uniform4_free_coverage_pct`,
        `uniform4_robot_coverage_pct`, `nbv_free_coverage_pct`, `nbv_robot_coverage_pct`,
        `nbv_free_views`, `nbv_robot_views` (requests, the initial view included),
        `nbv_free_ms_per_view` and `nbv_robot_ms_per_view` (median planning time per view it
        chose), `episodes` (per run) and the paper's figures (`paper_*`).

    Raises:
        ValueError: If there are no motors or seeds.
    """
    paths = [Path(path) for path in motors] if motors is not None else held_out_motors()
    if not paths or not seeds:
        raise ValueError("the planner benchmark needs at least one motor and one seed")
    results: dict[str, list[EpisodeResult]] = {key: [] for key, *_ in RUNS}
    agent_screening_s: list[float] = []
    with tqdm(total=len(paths) * len(seeds) * len(RUNS), desc="planners",
              disable=not progress) as bar, _timed_screenings() as screenings:
        for path in paths:
            scene = PartScene.load(config, path)
            for seed in seeds:
                spec = seeded_episode(config.env, path, seed)
                for key, planner, views, carrier in RUNS:
                    before = len(screenings)
                    results[key].append(run(config, scene, planner, spec, carrier, views))
                    if key == "agent_robot":
                        agent_screening_s.append(sum(screenings[before:]))
                    bar.update()

    def coverage_pct(key: str) -> float:
        return 100.0 * statistics.fmean(result.coverage for result in results[key])

    def reachable_share(key: str) -> float:
        # The runs are the robot's, which have a share once they requested a view.
        return statistics.fmean(share for result in results[key]
                                if (share := result.reachability) is not None)

    def ms_per_chosen_view(key: str) -> float:
        # Next-best-view planners choose every view but the initial one.
        return 1e3 * statistics.median(result.plan_seconds / max(result.requested - 1, 1)
                                       for result in results[key])

    agent = results["agent_robot"]
    decision_ms = [1e3 * (result.plan_seconds - screened) / max(result.requested - 1, 1)
                   for result, screened in zip(agent, agent_screening_s, strict=True)]
    bscp = results["bscp_robot"]
    candidates = [result.candidates for result in bscp if result.candidates is not None]
    paper = {name: (coverage, seconds) for name, coverage, _, seconds in PAPER_TABLE_9}
    return {
        "bscp_plan_s_median": statistics.median(result.plan_seconds for result in bscp),
        "bscp_plan_s_max": max(result.plan_seconds for result in bscp),
        "bscp_episode_s_median": statistics.median(result.episode_seconds for result in bscp),
        "bscp_reach_s_median": statistics.median(c.reach_seconds for c in candidates),
        "bscp_visibility_s_median": statistics.median(c.visibility_seconds for c in candidates),
        "bscp_candidates_reachable_pct": 100.0 * statistics.fmean(
            float(c.usable.mean()) for c in candidates),
        "bscp_robot_coverage_pct": coverage_pct("bscp_robot"),
        "bscp_robot_views": statistics.fmean(result.acquisitions for result in bscp),
        "bscp_free_coverage_pct": coverage_pct("bscp_free"),
        "bscp_free_views": statistics.fmean(r.acquisitions for r in results["bscp_free"]),
        "bscp4_free_coverage_pct": coverage_pct("bscp4_free"),
        "bscp5_free_coverage_pct": coverage_pct("bscp5_free"),
        "hrec_free_coverage_pct": coverage_pct("hrec_free"),
        "hrec_robot_coverage_pct": coverage_pct("hrec_robot"),
        "hrec_robot_reachable_pct": 100.0 * reachable_share("hrec_robot"),
        "agent_robot_coverage_pct": coverage_pct("agent_robot"),
        "agent_robot_acquisitions": statistics.fmean(
            result.acquisitions for result in results["agent_robot"]),
        "agent_reachable_share": reachable_share("agent_robot"),
        # The agent chooses every view but the initial one.
        "agent_ms_per_view": ms_per_chosen_view("agent_robot"),
        "agent_decision_ms_per_view_median": statistics.median(decision_ms),
        "agent_decision_ms_per_view_max": max(decision_ms),
        "agent_screening_s_median": statistics.median(agent_screening_s),
        "agent_screening_s_max": max(agent_screening_s),
        "agent_plan_s_median": statistics.median(result.plan_seconds for result in agent),
        "agent_plan_s_max": max(result.plan_seconds for result in agent),
        "uniform4_free_coverage_pct": coverage_pct("uniform4_free"),
        "uniform4_robot_coverage_pct": coverage_pct("uniform4_robot"),
        "nbv_free_coverage_pct": coverage_pct("nbv_free"),
        "nbv_robot_coverage_pct": coverage_pct("nbv_robot"),
        "nbv_free_views": statistics.fmean(r.requested for r in results["nbv_free"]),
        "nbv_robot_views": statistics.fmean(r.requested for r in results["nbv_robot"]),
        "nbv_free_ms_per_view": ms_per_chosen_view("nbv_free"),
        "nbv_robot_ms_per_view": ms_per_chosen_view("nbv_robot"),
        "episodes": len(bscp),
        "paper_bscp4_coverage_pct": paper["B_SCP,4"][0],
        "paper_bscp5_coverage_pct": paper["B_SCP,5"][0],
        "paper_hrec_coverage_pct": paper["H_rec"][0],
        "paper_bscp_plan_s": paper["B_SCP,5"][1],
    }


def print_table(results: dict[str, Any]) -> None:
    """Print ours next to the paper's Table 9 (coverage %, views, planning time)."""
    rows = [
        ("B_SCP,4", "free", results["bscp4_free_coverage_pct"], "4",
         results["paper_bscp4_coverage_pct"]),
        ("B_SCP,5", "free", results["bscp5_free_coverage_pct"], "5",
         results["paper_bscp5_coverage_pct"]),
        ("B_SCP (90 %)", "free", results["bscp_free_coverage_pct"],
         f"{results['bscp_free_views']:.2f}", None),
        ("B_SCP (90 %)", "robot", results["bscp_robot_coverage_pct"],
         f"{results['bscp_robot_views']:.2f}", None),
        ("H_rec", "free", results["hrec_free_coverage_pct"], "6",
         results["paper_hrec_coverage_pct"]),
        ("H_rec", "robot", results["hrec_robot_coverage_pct"],
         f"6 ({results['hrec_robot_reachable_pct']:.0f} % reachable)", None),
        ("agent", "robot", results["agent_robot_coverage_pct"],
         f"{results['agent_robot_acquisitions']:.2f} "
         f"({100 * results['agent_reachable_share']:.0f} % reachable, "
         f"{results['agent_ms_per_view']:.1f} ms per view)", None),
        ("uniform4", "free", results["uniform4_free_coverage_pct"], "4", None),
        ("uniform4", "robot", results["uniform4_robot_coverage_pct"], "4", None),
        ("nbv (90 %)", "free", results["nbv_free_coverage_pct"],
         f"{results['nbv_free_views']:.2f} ({results['nbv_free_ms_per_view']:.0f} ms per view)",
         None),
        ("nbv (90 %)", "robot", results["nbv_robot_coverage_pct"],
         f"{results['nbv_robot_views']:.2f} ({results['nbv_robot_ms_per_view']:.0f} ms per "
         f"view)", None),
    ]
    print(f"{'planner':<14}{'carrier':<8}{'coverage %':>11}  {'paper %':>8}  views")
    for name, carrier, coverage, views, paper in rows:
        shown = f"{paper:8.2f}" if paper is not None else f"{'-':>8}"
        print(f"{name:<14}{carrier:<8}{coverage:11.2f}  {shown}  {views}")
    print(f"B_SCP with the robot: {results['bscp_plan_s_median']:.2f} s per plan (median; max "
          f"{results['bscp_plan_s_max']:.2f} s; paper, free-flying: "
          f"{results['paper_bscp_plan_s']:.0f} s)")
    print(f"agent with the robot: {results['agent_decision_ms_per_view_median']:.1f} ms a "
          f"decision per view, screening left out (median; max "
          f"{results['agent_decision_ms_per_view_max']:.1f} ms); reachability screening "
          f"{results['agent_screening_s_median']:.3f} s once per episode (max "
          f"{results['agent_screening_s_max']:.3f} s); {results['agent_plan_s_median']:.3f} s "
          f"planning per episode (max {results['agent_plan_s_max']:.3f} s)")
