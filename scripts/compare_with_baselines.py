"""One table per test list: seed-averaged agent rows (`vprobot train --seeds`) beside baselines.

The agents' `seeds.csv` give mean and min-max over seeds; the baselines come from a
`vprobot evaluate` folder of the repository on the same episode list (checked: its
`episodes.json` must equal the bundled list, so agents and baselines are scored on the same
episodes). An agent row over fewer of the agent's seeds than it has (those in its `seeds.csv` and
its `seed-<n>` folders: a partial `seeds.csv`) says so: `0 2 (2 of 3 seeds)`. Exit 2 with one
line on stderr for a bad argument or an unreadable input.

Usage:
    python scripts/compare_with_baselines.py --agents motors=results/families/motors \
        mix=results/families/mix --out results/families/comparison.md
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

from vprobot.episode.specs import bundled_episode_list
from vprobot.files import write_text
from vprobot.outputs import check_output_file

ROOT = Path(__file__).resolve().parents[1]
"""The repository, which holds the baselines (so the script runs from any folder)."""
BASELINES = {"test-v1": "results/motors", "families-test-v1": "results/families-test",
             "shapes-v1": "results/shapes"}
"""The committed baseline evaluation of each test list (in `ROOT`)."""
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


class Agent:
    """An agent's `seeds.csv` rows by episode list, and all its seeds."""

    def __init__(self, folder: Path) -> None:
        """Read `folder/seeds.csv`.

        Raises:
            ValueError: If the file is not a seeds table.
        """
        path = folder / "seeds.csv"
        rows = read_csv(path)
        if rows and not {"evaluation", "seeds", *(key for key, _ in METRICS)} <= set(rows[0]):
            raise ValueError(f"{path} is not the seeds.csv of `vprobot train --seeds`")
        self.rows = {row["evaluation"]: row for row in rows}
        # A seed still training has its folder but no row yet.
        folders = {path.name.removeprefix("seed-") for path in folder.glob("seed-*")
                   if path.is_dir()}
        self.seeds = sorted({seed for row in rows for seed in row["seeds"].split()}
                            | {seed for seed in folders if seed.isdigit()}, key=int)

    def scored(self, name: str) -> dict[str, str] | None:
        """The row of the episode list `name`, None if no seed has scored it."""
        row = self.rows.get(name)
        return row if row is not None and row["seeds"].split() else None

    def shortfall(self, name: str) -> str:
        """`k of n seeds` (`none of n seeds`) when the row of `name` is over fewer than the
        agent's n seeds; empty when it is over all of them."""
        row = self.scored(name)
        if row is None:
            return f"none of {len(self.seeds)} seeds"
        scored = len(row["seeds"].split())
        return "" if scored == len(self.seeds) else f"{scored} of {len(self.seeds)} seeds"

    def seeds_cell(self, name: str) -> str:
        """The seeds the row of `name` is over, and its shortfall."""
        row, shortfall = self.scored(name), self.shortfall(name)
        if row is None:
            return shortfall
        return f"{row['seeds']} ({shortfall})" if shortfall else row["seeds"]


def agent_cell(row: dict[str, str], key: str, fmt: str) -> str:
    if not row[key]:
        return "-"
    return (f"{fmt.format(float(row[key]))} ({fmt.format(float(row[key + '_min']))}-"
            f"{fmt.format(float(row[key + '_max']))})")


def baselines(name: str) -> list[dict[str, str]]:
    """The shown baselines' rows (robot in the loop) on the episode list `name`.

    Raises:
        ValueError: If the baseline folder ran another episode list.
    """
    baseline_dir = ROOT / BASELINES[name]
    listed = json.loads(bundled_episode_list(name).read_text())["episodes"]
    if json.loads((baseline_dir / "episodes.json").read_text())["episodes"] != listed:
        raise ValueError(f"{baseline_dir}/episodes.json is not the episode list {name}")
    return [row for row in read_csv(baseline_dir / "evaluation.csv")
            if row["carrier"] == "robot" and row["planner"] in PLANNERS]


def table(name: str, agents: dict[str, Agent]) -> list[str]:
    lines = [f"### {name}", "", "| planner | seeds | coverage % | acquisitions | at goal % |",
             "|---|---|---|---|---|"]
    for label, agent in agents.items():
        row = agent.scored(name)
        cells = [agent_cell(row, key, fmt) if row else "-" for key, fmt in METRICS]
        lines.append(f"| agent ({label}) | {agent.seeds_cell(name)} | {' | '.join(cells)} |")
    for row in baselines(name):
        cells = [fmt.format(float(row[key])) for key, fmt in METRICS]
        lines.append(f"| {row['planner']} | - | {' | '.join(cells)} |")
    return [*lines, ""]


def targets(agents: dict[str, Agent]) -> list[str]:
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
        for label, agent in agents.items():
            row, shortfall = agent.scored(name), agent.shortfall(name)
            if row is None:
                lines.append(f"| {name} | {label} ({shortfall}) | - | - | - | - | - | - |")
                continue
            if shortfall:
                label = f"{label} ({shortfall})"
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agents", nargs="+", required=True, metavar="LABEL=DIR",
                        help="folders holding a seeds.csv, each with a label")
    parser.add_argument("--out", type=Path, required=True, help="the markdown file to write")
    parser.add_argument("--targets", action="store_true",
                        help="add issue 21's targets, met or missed by how much")
    args = parser.parse_args(argv)
    try:
        compare(args)
    except (ValueError, OSError) as error:
        print(f"{parser.prog}: error: {str(error).splitlines()[0]}", file=sys.stderr)
        return 2
    return 0


def compare(args: argparse.Namespace) -> None:
    """Write the comparison of `args` (parsed by `main`).

    Raises:
        ValueError, OSError: For a bad `--agents` or `--out`, or an unreadable input.
    """
    check_output_file(args.out, "--out", (".md",))
    agents = {}
    for item in args.agents:
        label, sep, folder = item.partition("=")
        if not sep or not (Path(folder) / "seeds.csv").is_file():
            raise ValueError(f"--agents {item}: expected LABEL=DIR with DIR/seeds.csv")
        agents[label] = Agent(Path(folder))
    lines = ["# Agents (mean, min-max over seeds) beside the baselines, robot in the loop", "",
             "Written by `python scripts/compare_with_baselines.py "
             f"--agents {' '.join(args.agents)} --out {args.out}"
             f"{' --targets' if args.targets else ''}`; agents from their "
             "`seeds.csv`, baselines from `results/motors`, `results/families-test` and "
             "`results/shapes` (the same episodes); `k of n seeds`: a row over only k of "
             "the agent's n seeds.", ""]
    for name in BASELINES:
        lines += table(name, agents)
    if args.targets:
        lines += targets(agents)
    write_text(args.out, "\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    sys.exit(main())
