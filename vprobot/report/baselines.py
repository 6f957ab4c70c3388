"""Seed-averaged agents (`vprobot train --seeds`) beside the baselines, one table per test list
(`vprobot report baselines`).

The agents' `seeds.csv` give mean and min-max over seeds; the baselines come from the
repository's committed `vprobot evaluate` folder of the same episode list (checked: its
`episodes.json` must equal the bundled list, so agents and baselines are scored on the same
episodes). An agent row over fewer of the agent's seeds than it has (those in its `seeds.csv` and
its `seed-<n>` folders: a partial `seeds.csv`) says so: `0 2 (2 of 3 seeds)`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vprobot.episode.specs import bundled_episode_list, read_episode_list
from vprobot.files.paths import PACKAGE_DIR
from vprobot.report.compare import read_rows

ROOT = PACKAGE_DIR.parent
"""The repository, which holds the baselines (so the report runs from any folder)."""
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


class Agent:
    """An agent's `seeds.csv` rows by episode list, and all its seeds."""

    def __init__(self, folder: Path) -> None:
        """Read `folder/seeds.csv`.

        Raises:
            ValueError: If the folder holds no seeds table.
        """
        path = folder / "seeds.csv"
        if not path.is_file():
            raise ValueError(f"{folder} holds no seeds.csv (of `vprobot train --seeds`)")
        rows = read_rows(path)
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


def _agent_cell(row: dict[str, str], key: str, fmt: str) -> str:
    if not row[key]:
        return "-"
    return (f"{fmt.format(float(row[key]))} ({fmt.format(float(row[key + '_min']))}-"
            f"{fmt.format(float(row[key + '_max']))})")


def baselines(name: str) -> list[dict[str, str]]:
    """The shown baselines' rows (robot in the loop) on the episode list `name`.

    Raises:
        ValueError: If the baseline folder is missing or ran another episode list.
    """
    baseline_dir = ROOT / BASELINES[name]
    if not (baseline_dir / "episodes.json").is_file():
        raise ValueError(f"{baseline_dir} holds no evaluation: the baselines are the "
                         "repository's results/ (run from a clone)")
    # Read as specs: a list written before any object was called a part says `motor`.
    if read_episode_list(baseline_dir / "episodes.json") != read_episode_list(
            bundled_episode_list(name)):
        raise ValueError(f"{baseline_dir}/episodes.json is not the episode list {name}")
    return [row for row in read_rows(baseline_dir / "evaluation.csv")
            if row["carrier"] == "robot" and row["planner"] in PLANNERS]


def _table(name: str, agents: dict[str, Agent]) -> list[str]:
    lines = [f"### {name}", "", "| planner | seeds | coverage % | acquisitions | at goal % |",
             "|---|---|---|---|---|"]
    for label, agent in agents.items():
        row = agent.scored(name)
        cells = [_agent_cell(row, key, fmt) if row else "-" for key, fmt in METRICS]
        lines.append(f"| agent ({label}) | {agent.seeds_cell(name)} | {' | '.join(cells)} |")
    for row in baselines(name):
        cells = [fmt.format(float(row[key])) for key, fmt in METRICS]
        lines.append(f"| {row['planner']} | - | {' | '.join(cells)} |")
    return [*lines, ""]


def _targets(agents: dict[str, Agent]) -> list[str]:
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


def comparison(agents: Sequence[tuple[str, Path]], command: str, targets: bool) -> str:
    """The Markdown comparison of labelled agent folders with the baselines.

    Args:
        agents: Label and folder (holding `seeds.csv`) of each agent.
        command: The command that writes it, named in the text.
        targets: Add issue 21's targets, met or missed by how much.

    Raises:
        ValueError: For a folder without a seeds table, or a missing baseline.
    """
    read = {label: Agent(folder) for label, folder in agents}
    lines = ["# Agents (mean, min-max over seeds) beside the baselines, robot in the loop", "",
             f"Written by `{command}`; agents from their "
             "`seeds.csv`, baselines from `results/motors`, `results/families-test` and "
             "`results/shapes` (the same episodes); `k of n seeds`: a row over only k of "
             "the agent's n seeds.", ""]
    for name in BASELINES:
        lines += _table(name, read)
    if targets:
        lines += _targets(read)
    return "\n".join(lines)
