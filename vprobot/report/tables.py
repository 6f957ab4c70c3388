"""The README's result tables, from the evaluation folders of one cell (`vprobot report tables`).

For each test list (motors `test-v1`, held-out families `families-test-v1`, shapes `shapes-v1`)
it reads the cell's `vprobot evaluate` folder and, for agents trained with `vprobot train
--seeds`, each seed's scoring of that list (`seed-<n>/test/LIST/`). An agent's episodes are
compared with the folder's `optimum` rows of the same episodes (the episode lists must be the
same, which is checked), then summarised per seed (`vprobot.evaluation.summarize`) and given as
mean (min-max) over the seeds.
"""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any

from vprobot.episode import read_episode_list
from vprobot.evaluation import EPISODES_NAME, OPTIMUM, finished_rows, summarize

LISTS = (("motors", "test-v1", "motors"), ("families", "families-test-v1", "families-test"),
         ("shapes", "shapes-v1", "shapes"))
"""Each test list: its column label, its name and its folder in the cell's folder."""
COLUMNS = (("success_pct", "at goal %", "{:.0f}"), ("acquisitions", "views", "{:.2f}"),
           ("views_to_goal", "to goal", "{:.2f}"), ("failed_requests", "failed", "{:.2f}"),
           ("cycle_time_s", "cycle s", "{:.2f}"),
           ("views_above_optimum", "above optimum", "{:+.2f}"))
"""The figures shown per list: key in the summary, header, format. "to goal" is the views
(requests) to the goal over the episodes that reach it, the score of a cell whose view budget
the parts do not meet (`configs/cell_real.yaml`)."""
FREE_COLUMNS = (COLUMNS[0], COLUMNS[1], COLUMNS[2], COLUMNS[5])
"""Without the robot nothing fails and there is no cycle."""
CARRIERS = ("robot", "free")


def _episodes(folder: Path) -> list[dict[str, Any]]:
    path = folder / EPISODES_NAME
    if not path.is_file():
        raise ValueError(f"{path} does not exist; run the folder's command first")
    return finished_rows(path)


def _cell(values: list[float | None], form: str, seeds: bool) -> str:
    present = [value for value in values if value is not None]
    if not present:
        return "-"
    text = form.format(statistics.fmean(present))
    if seeds:
        text += f" ({form.format(min(present))}-{form.format(max(present))})".replace("+", "")
    return text


def table(folders: Path, carrier: str, agents: dict[str, Path],
          planners: list[str] | None = None, after: str = "nbv@grid") -> str:
    """The Markdown table of the planners of a cell's folders and of agents over seeds, on the
    three test lists, for one carrier.

    Args:
        folders: The folder holding `motors/`, `families-test/` and `shapes/`.
        carrier: `robot` or `free`.
        agents: Label and folder (holding `seed-<n>/test/LIST/`) of each agent.
        planners: The folders' planners shown, in this order; None: all, in the folders' order.
        after: The row after which the agents' rows go (the end if it is not shown).

    Raises:
        ValueError: For a missing folder or planner, a list without rows of `carrier`, or an
            agent without seeds or scored on other episodes than the folder's.
    """
    columns = COLUMNS if carrier == "robot" else FREE_COLUMNS
    cells: dict[str, dict[str, str]] = {}
    agent_rows: dict[str, None] = {}
    for label, name, sub in LISTS:
        folder = folders / sub
        rows = [row for row in _episodes(folder) if row["carrier"] == carrier]
        if not rows:
            raise ValueError(f"{folder} has no {carrier} rows")
        optimum = [row for row in rows if row["planner"] == OPTIMUM]
        for summary in summarize(rows):
            cells.setdefault(summary["planner"], {})[label] = " | ".join(
                _cell([summary[key]], form, False) for key, _, form in columns)
        for agent, root in agents.items():
            per_seed = []
            for seed_dir in sorted(root.glob("seed-*")):
                scored = seed_dir / "test" / name
                if (read_episode_list(scored / "episodes.json")
                        != read_episode_list(folder / "episodes.json")):
                    raise ValueError(f"{scored} was scored on other episodes than {folder}")
                own = [{**row, "planner": agent} for row in _episodes(scored)
                       if row["carrier"] == carrier]
                per_seed.append(next(summary for summary in summarize(own + optimum)
                                     if summary["planner"] == agent))
            if not per_seed:
                raise ValueError(f"{root} holds no seed-<n>/test/{name}")
            agent_rows.setdefault(f"{agent} ({len(per_seed)} seeds)", None)
            cells.setdefault(f"{agent} ({len(per_seed)} seeds)", {})[label] = " | ".join(
                _cell([summary[key] for summary in per_seed], form, True)
                for key, _, form in columns)
    folder_rows = [name for name in cells if name in set(planners or cells)
                   and name not in agent_rows]
    if planners is not None:
        unknown = sorted(set(planners) - set(folder_rows))
        if unknown:
            raise ValueError(f"no rows of planner(s) {', '.join(unknown)} in {folders}")
        folder_rows = list(planners)
    order = list(folder_rows)
    where = order.index(after) + 1 if after in order else len(order)
    order[where:where] = agent_rows
    header = "| planner | " + " | ".join(f"{label}: {title}" if index == 0 else title
                                          for label, _, _ in LISTS
                                          for index, (_, title, _) in enumerate(columns)) + " |"
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    empty = " | ".join("-" for _ in columns)
    for planner in order:
        by_list = cells[planner]
        lines.append(f"| {planner} | " + " | ".join(by_list.get(label, empty)
                                                   for label, _, _ in LISTS) + " |")
    return "\n".join(lines) + "\n"
