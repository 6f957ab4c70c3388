"""What the occupancy grid says is still measurable, against the coverage, view by view (issue 45,
item 4: a model-free bound).

Runs `nbv` (`--views` acquisitions, by default the cell's budget; the simulator's goal off) on
an episode list and, before every request, records the share of the known surface the reachable
band candidates would still measure (`MeasurableStop.left`: the bound of `ViewGains.revisits`,
unknown voxels and occupied ones seen from a new direction, in the box about the occupied
voxels), beside the episode's true coverage. Writes one row per view to `--out` (CSV) and, beside
it (`.md`), what the stop rule `measurable:S` would have done for several S: how often it stops
below the goal on an episode `nbv` brings to the goal later, how many views past the goal it
stops, and how many views before the budget it ends the episodes that never reach the goal.

    python scripts/measurable_surface.py --config configs/cell_real.yaml \\
        --episodes validation-v2 --out results/real/measurable_surface.csv
"""

from __future__ import annotations

import argparse
import csv
import statistics
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from vprobot.config import load_config
from vprobot.episode import PartScene
from vprobot.evaluation import evaluation_episodes
from vprobot.planners import nbv
from vprobot.planners.runner import run
from vprobot.stopping.rules.measurable import MeasurableStop

COLUMNS = ("episode", "object", "views", "coverage", "occupied", "left")
SHARES = (0.03, 0.04, 0.05, 0.06, 0.08, 0.1, 0.12, 0.15)


def summary(rows: Sequence[dict[str, object]], goal: float, budget: int) -> str:
    """A markdown table: per share S, what `measurable:S` would have done on these runs."""
    episodes: dict[object, list[dict[str, object]]] = {}
    for row in rows:
        episodes.setdefault(row["episode"], []).append(row)
    reaching = [views for views in episodes.values()
                if any(float(str(row["coverage"])) >= goal for row in views)]
    lines = [f"`nbv` on {len(episodes)} episodes, {len(reaching)} of them at the goal "
             f"({goal:.0%}) within its {budget} views; the rule asked before every view.", "",
             "| S | stops below the goal, of those | views past the goal, median (max) | "
             "episodes never at the goal: stopped before the budget | views before the budget, "
             "median |", "|---|---|---|---|---|"]
    for share in SHARES:
        false = 0
        past: list[int] = []
        early: list[int] = []
        for views in episodes.values():
            stop = next((row for row in views if row["left"] != ""
                         and float(str(row["left"])) <= share), None)
            at_goal = next((row for row in views if float(str(row["coverage"])) >= goal), None)
            if at_goal is not None:
                if stop is not None and float(str(stop["coverage"])) < goal:
                    false += 1
                else:
                    end = budget if stop is None else int(str(stop["views"]))
                    past.append(end - int(str(at_goal["views"])))
            elif stop is not None:
                early.append(budget - int(str(stop["views"])))
        never = len(episodes) - len(reaching)
        lines.append(f"| {share} | {false} of {len(reaching)} | {statistics.median(past):g} "
                     f"({max(past)}) | {len(early)} of {never} | "
                     f"{statistics.median(early) if early else '-'} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--episodes", required=True)
    parser.add_argument("--views", type=int, default=None,
                        help="acquisitions at most (default: the cell's budget, "
                             "env.max_acquisitions requests after the initial view)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    config = load_config(args.config)
    views = args.views or config.env.max_acquisitions + 1
    rows: list[dict[str, object]] = []
    step = nbv.VolumetricPlanner.next_view
    current: dict[str, object] = {}
    bound = MeasurableStop(config)

    def counted(planner: nbv.VolumetricPlanner, episode: nbv.Episode) -> object:
        rows.append({**current, "views": len(episode.views),
                     "coverage": round(float(episode.coverage), 4),
                     "occupied": episode.occupancy(bound.settings).counts()["occupied"],
                     "left": round(bound.left(episode), 4)})
        return step(planner, episode)

    nbv.VolumetricPlanner.next_view = counted  # type: ignore[method-assign]
    for index, spec in enumerate(tqdm(evaluation_episodes(config, episodes=args.episodes))):
        current.update(episode=index, object=str(spec.part))
        bound.reset()
        scene = PartScene.load(config, spec.part_path, spec.scale)
        record = run(config, scene, "nbv", spec, stop=f"views:{views}").record
        # The coverage after the last view, where the rule is not asked again.
        rows.append({**current, "views": len(record.views),
                     "coverage": round(float(record.views[-1].coverage), 4), "left": ""})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as file:
        writer = csv.DictWriter(file, COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    args.out.with_suffix(".md").write_text(summary(rows, config.env.coverage_goal, views))


if __name__ == "__main__":
    main()
