"""Time a trained candidate-view agent as a planner: the reachability screening once per
episode, and the decision of every view without it (state from the acquired frames, network).

Usage:
    python scripts/time_agent.py --agent agent --episodes test-v1 --out results/generalist/timing.md
    python scripts/time_agent.py --config configs/cell_real.yaml --episodes test-v1 \
        --out results/generalist/real/timing.md

Run it with nothing else on the machine: the figures are wall-clock times.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from vprobot.config import load_config
from vprobot.env.grid_state import GridState
from vprobot.episode import Episode, MotorScene
from vprobot.evaluation import evaluation_episodes
from vprobot.planners.runner import make_planner, run_episode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", default="agent", help="an agent planner (default: the bundled)")
    parser.add_argument("--episodes", default="test-v1", help="an episode list")
    parser.add_argument("--config", help="YAML config of the cell (default: configs/default.yaml)")
    parser.add_argument("--out", type=Path, required=True, help="the markdown file to write")
    args = parser.parse_args()
    config = load_config(args.config)
    screening_s: list[float] = []
    original = GridState.screening

    def timed(self: GridState, episode: Episode):  # type: ignore[no-untyped-def]
        first = self._screening is None
        start = time.perf_counter()
        result = original(self, episode)
        if first:
            screening_s.append(time.perf_counter() - start)
        return result

    GridState.screening = timed  # type: ignore[method-assign]
    planner = make_planner(args.agent, config)
    decisions_ms, plans_s = [], []
    for spec in evaluation_episodes(config, episodes=args.episodes):
        scene = MotorScene.load(config, spec.motor_path, spec.scale)
        episode = Episode.from_spec(scene, spec, "robot", config.env.unreachable)
        before = len(screening_s)
        played = run_episode(planner, episode, spec, config, np.random.default_rng(spec.seed))
        requests = len(played.record.views) - 1  # after the initial view
        screened = sum(screening_s[before:])
        plans_s.append(played.plan_seconds)
        decisions_ms.append(1e3 * (played.plan_seconds - screened) / max(requests, 1))
    given = f"--config {args.config} " if args.config else ""
    lines = [f"# Planning time of `{args.agent}` on `{args.episodes}`", "",
             f"`python scripts/time_agent.py {given}--agent {args.agent} --episodes "
             f"{args.episodes} --out {args.out}`; {len(plans_s)} episodes, robot in the loop, "
             "full sensor resolution, wall clock.", "",
             "| figure | median | max |", "|---|---|---|",
             f"| decision per view, screening left out (ms) | {statistics.median(decisions_ms):.1f}"
             f" | {max(decisions_ms):.1f} |",
             f"| reachability screening, once per episode (s) | "
             f"{statistics.median(screening_s):.3f} | {max(screening_s):.3f} |",
             f"| planning per episode, all included (s) | {statistics.median(plans_s):.3f} | "
             f"{max(plans_s):.3f} |", ""]
    args.out.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
