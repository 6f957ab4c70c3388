"""One table per test list: seed-averaged agent rows (`vprobot train --seeds`) beside baselines.

The agents' `seeds.csv` give mean and min-max over seeds; the baselines come from a
`vprobot evaluate` folder on the same episode list (checked: its `episodes.json` must equal the
bundled list, so agents and baselines are scored on the same episodes).

Usage:
    python scripts/compare_with_baselines.py --agents motors=results/families/motors \
        mix=results/families/mix --out results/families/comparison.md
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

from vprobot.episode.specs import bundled_episode_list

BASELINES = {"test-v1": "results/motors", "families-test-v1": "results/families-test",
             "shapes-v1": "results/shapes"}
"""The committed baseline evaluation of each test list."""
PLANNERS = ("uniform4", "uniform5", "uniform6", "nbv", "nbv@grid", "bscp", "oracle")
"""The baseline rows shown: the model-free ones, then the two that use the model."""
MODEL_BASED = ("bscp", "oracle")
GOAL_PCT = 95.0
"""Issue 21's targets: the goal reached in this share of episodes, with fewer acquisitions than
the best model-free baseline (the highest goal rate, then the fewest acquisitions) at an equal
or higher goal rate, and within B_SCP + `BSCP_MARGIN` acquisitions."""
BSCP_MARGIN = 0.8
METRICS = (("coverage_pct", "{:.1f}"), ("acquisitions", "{:.2f}"), ("success_pct", "{:.0f}"))


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def agent_cell(row: dict[str, str], key: str, fmt: str) -> str:
    return (f"{fmt.format(float(row[key]))} ({fmt.format(float(row[key + '_min']))}-"
            f"{fmt.format(float(row[key + '_max']))})")


def baselines(name: str) -> list[dict[str, str]]:
    """The shown baselines' rows (robot in the loop) on the episode list `name`."""
    baseline_dir = Path(BASELINES[name])
    listed = json.loads(bundled_episode_list(name).read_text())["episodes"]
    if json.loads((baseline_dir / "episodes.json").read_text())["episodes"] != listed:
        raise SystemExit(f"{baseline_dir}/episodes.json is not the episode list {name}")
    return [row for row in read_csv(baseline_dir / "evaluation.csv")
            if row["carrier"] == "robot" and row["planner"] in PLANNERS]


def agent_rows(name: str, agents: dict[str, Path]) -> dict[str, dict[str, str]]:
    """Each agent's seeds row on the episode list `name`."""
    return {label: row for label, folder in agents.items()
            for row in read_csv(folder / "seeds.csv") if row["evaluation"] == name}


def table(name: str, agents: dict[str, Path]) -> list[str]:
    lines = [f"### {name}", "", "| planner | seeds | coverage % | acquisitions | at goal % |",
             "|---|---|---|---|---|"]
    for label, row in agent_rows(name, agents).items():
        cells = [agent_cell(row, key, fmt) for key, fmt in METRICS]
        lines.append(f"| agent ({label}) | {row['seeds']} | {' | '.join(cells)} |")
    for row in baselines(name):
        cells = [fmt.format(float(row[key])) for key, fmt in METRICS]
        lines.append(f"| {row['planner']} | - | {' | '.join(cells)} |")
    return [*lines, ""]


def targets(agents: dict[str, Path]) -> list[str]:
    """Issue 21's targets per list and agent (seed means), met or missed by how much."""
    lines = ["## Issue 21's targets (seed means; a miss says by how much)", "",
             f"| list | agent | at goal % (>= {GOAL_PCT:.0f}) | acquisitions | best model-free "
             f"baseline | fewer than it | B_SCP + {BSCP_MARGIN} | within it |",
             "|---|---|---|---|---|---|---|---|"]
    for name in BASELINES:
        rows = baselines(name)
        free = max((row for row in rows if row["planner"] not in MODEL_BASED),
                   key=lambda row: (float(row["success_pct"]), -float(row["acquisitions"])))
        limit = next(float(row["acquisitions"]) for row in rows
                     if row["planner"] == "bscp") + BSCP_MARGIN
        for label, row in agent_rows(name, agents).items():
            goal, views = float(row["success_pct"]), float(row["acquisitions"])
            best = float(free["acquisitions"])
            at_goal = "met" if goal >= GOAL_PCT else f"missed by {GOAL_PCT - goal:.0f} pp"
            fewer = ("met" if views < best and goal >= float(free["success_pct"]) else
                     f"missed: {views - best:+.2f} views, {goal - float(free['success_pct']):+.0f}"
                     f" pp at goal")
            within = "met" if views <= limit else f"missed by {views - limit:.2f} views"
            lines.append(f"| {name} | {label} | {goal:.0f}: {at_goal} | {views:.2f} | "
                         f"{free['planner']} ({best:.2f}, {float(free['success_pct']):.0f} %) | "
                         f"{fewer} | {limit:.2f} | {within} |")
    return [*lines, ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agents", nargs="+", required=True, metavar="LABEL=DIR",
                        help="folders holding a seeds.csv, each with a label")
    parser.add_argument("--out", type=Path, required=True, help="the markdown file to write")
    parser.add_argument("--targets", action="store_true",
                        help="add issue 21's targets, met or missed by how much")
    args = parser.parse_args()
    agents = {}
    for item in args.agents:
        label, sep, folder = item.partition("=")
        if not sep or not (Path(folder) / "seeds.csv").is_file():
            raise SystemExit(f"--agents {item}: expected LABEL=DIR with DIR/seeds.csv")
        agents[label] = Path(folder)
    lines = ["# Agents (mean, min-max over seeds) beside the baselines, robot in the loop", "",
             "Written by `python scripts/compare_with_baselines.py "
             f"--agents {' '.join(args.agents)} --out {args.out}"
             f"{' --targets' if args.targets else ''}`; agents from their "
             "`seeds.csv`, baselines from `results/motors`, `results/families-test` and "
             "`results/shapes` (the same episodes).", ""]
    for name in BASELINES:
        lines += table(name, agents)
    if args.targets:
        lines += targets(agents)
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
