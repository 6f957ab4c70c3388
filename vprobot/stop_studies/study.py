"""The stop study (`vprobot stop study`): how each stop rule stops each planner, robot in the loop.

Per episode list, every stop rule runs with every planner it applies to (`goal` with every
planner that does not decide its own stop: a fixed plan runs to its end under it, and the
request after which it reached the goal is its reference; `agent` only with an agent that has a
stop action),
as an ordinary evaluation in `OUT/LIST/RULE/` (`vprobot.evaluation.evaluate`: resumable,
its own tables). The study table then gives per list, rule and planner: the share of episodes
stopped at or above the coverage goal, the coverage at the stop, the views requested and
acquired, the views wasted beyond the goal (requests after the one that reached it) and the
views requested beyond the same planner stopped at the goal (`study.csv`, `study.md`,
`study.png`).
"""

from __future__ import annotations

import json
import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vprobot.config import Config
from vprobot.evaluation import (
    CURVE_COLUMNS,
    evaluate,
    evaluation_episodes,
    finished_rows,
    plan_path,
    stop_label,
)
from vprobot.files.atomic import csv_text, folder_lock, save_figure, write_text
from vprobot.files.paths import PACKAGE_DIR
from vprobot.planners.runner import make_planner, parse_planner
from vprobot.planners.self_stopping import stop_subject
from vprobot.stopping.confidence import PLATEAU, plateau_view
from vprobot.stopping.rules import StopSubject, make_stop_rule

DEFAULT_LISTS = ("test-v1", "families-test-v1", "shapes-v1")
DEFAULT_RULES = ("goal", "estimate", "confident", "grid", "views:5", "agent")
DEFAULT_PLANNERS = ("agent", "nbv", "agent:cpu-stop")
"""The bundled default agent, volumetric next-best view, and the bundled agent with a stop
action."""
COLUMNS = ("episodes", "planner", "stop", "count", "at_goal_pct", "coverage_pct", "requested",
           "acquisitions", "wasted", "extra_vs_goal", "stopped", "false_stops",
           "median_extra_vs_goal", "out_of_reach_stops", "plateau_gap_median", "plateau_gap_min",
           "plateau_gap_max")


def list_names(lists: Sequence[str]) -> list[str]:
    """Each episode list's name in the outputs: its file stem (`test-v1`, `one` of `a/one.json`).

    Raises:
        ValueError: If two lists have one name (their outputs would be one).
    """
    names = [Path(entry).stem for entry in lists]
    for index, name in enumerate(names):
        first = names.index(name)
        if first < index:
            raise ValueError(f"--episodes {lists[first]} and {lists[index]} are both named "
                             f"{name!r} in the outputs; give each list a file name of its own")
    return names


def planner_subjects(config: Config, planners: Sequence[str]) -> dict[str, StopSubject]:
    """What a stop rule sees of each planner (`stop_subject`), each planner built once (an
    agent's is loaded from disk).

    Raises:
        ValueError: For an unknown planner.
    """
    subjects = {}
    for planner in planners:
        name, views = parse_planner(planner)
        subjects[planner] = stop_subject(make_planner(name, config, views))
    return subjects


def combinations(config: Config, planners: Sequence[str], rules: Sequence[str],
                 estimator: str | Path | None = None,
                 subjects: dict[str, StopSubject] | None = None) -> list[tuple[str, list[str]]]:
    """Per rule, the planners it applies to (`goal`: those that do not decide their own stop);
    `subjects`: the planners' `planner_subjects`, if already at hand.

    Raises:
        ValueError: For an unknown planner or rule, or an estimator that cannot be read.
    """
    subjects = subjects if subjects is not None else planner_subjects(config, planners)
    chosen = []
    for rule in rules:
        stop = make_stop_rule(rule, config, estimator)
        applies = [planner for planner in planners
                   if stop.applies_to(subjects[planner])
                   and (rule != "goal" or not subjects[planner].decides_stop)]
        if applies:
            chosen.append((rule, applies))
    return chosen


def request_budget(config: Config, subject: StopSubject) -> int | None:
    """The most requests an episode of a planner (its `stop_subject`) makes, the initial
    view's included: the view budget's; None for a fixed plan, which ends where its plan does
    (its run at `goal`)."""
    if not subject.stops_at_goal and not subject.decides_stop:
        return None
    return config.env.max_acquisitions + 1


def _folder(rule: str) -> str:
    return rule.replace(":", "-")


def _shown(planner: str) -> str:
    """A planner as the study table shows it: a bundled agent's path relative to the package."""
    return planner.replace(str(PACKAGE_DIR.parent) + "/", "")


def _curve(row: dict[str, Any], folder: Path | None) -> list[float] | None:
    """An episode row's coverage after each request (fractions): the curve's columns, and the
    coverage at the end for one request more; beyond that, the views of the row's plan JSON in
    its evaluation `folder` (`plan_path`), where there is one."""
    curve = [row[key] / 100.0 for key in CURVE_COLUMNS]
    if row["requested"] <= len(curve):
        return curve[:row["requested"]]
    if row["requested"] == len(curve) + 1:
        return curve + [row["coverage_pct"] / 100.0]
    plan = (None if folder is None
            else plan_path(folder, row["episode"], row["carrier"], row["planner"]))
    if plan is None or not plan.is_file():
        return None
    return [float(view["coverage"]) for view in json.loads(plan.read_text())["views"]]


def study_row(rows: Sequence[dict[str, Any]], episodes: str, planner: str, stop: str,
              budget: int | None, folder: Path | None = None) -> dict[str, Any]:
    """The study's row of one list, planner and rule from its evaluation's episode rows;
    `budget` is the most requests an episode makes (the initial view's included), None for a
    fixed plan: under `goal` it runs to its end, under a rule its stops are counted against
    that run, episode by episode (`_write_study`; unknown without it). `folder` is the
    evaluation's, whose plans hold the curves longer than its table does."""
    early: set[int] | None = (
        {row["episode"] for row in rows if row["requested"] < budget} if budget is not None
        else set() if stop == "goal" else None)
    missed = {row["episode"] for row in rows if not row["success"]}
    return {
        "episodes": episodes, "planner": _shown(planner), "stop": stop, "count": len(rows),
        "at_goal_pct": 100.0 * statistics.fmean(row["success"] for row in rows),
        "coverage_pct": statistics.fmean(row["coverage_pct"] for row in rows),
        "requested": statistics.fmean(row["requested"] for row in rows),
        "acquisitions": statistics.fmean(row["acquisitions"] for row in rows),
        # Requests after the one that reached the goal; none for an episode that missed it.
        "wasted": statistics.fmean(row["requested"] - row["views_to_goal"] if row["success"]
                                   else 0 for row in rows),
        "extra_vs_goal": None,
        # Ended before the view budget (by the rule, or the planner itself), and of those,
        # below the goal: the false stops (`_write_study` takes out those whose goal was out
        # of reach).
        "stopped": None if early is None else len(early),
        "false_stops": None if early is None else len(early & missed),
        "median_extra_vs_goal": None,
        "out_of_reach_stops": None,
        "plateau_gap_median": None,
        "plateau_gap_min": None,
        "plateau_gap_max": None,
        "by_episode": {row["episode"]: row["requested"] for row in rows},
        # The request after which the goal was reached, else the last (the reference of the
        # other rules: a run stopped at the goal ends there, a fixed plan goes on).
        "to_goal": {row["episode"]: row["views_to_goal"] if row["success"] else row["requested"]
                    for row in rows},
        "curves": {row["episode"]: _curve(row, folder) for row in rows},
        "below_goal": set() if early is None else early & missed,
        "missed": missed,
        "fixed_plan": budget is None,
    }


def stop_study(config: Config, out_dir: str | Path, episodes: Sequence[str] = DEFAULT_LISTS,
               planners: Sequence[str] = DEFAULT_PLANNERS, rules: Sequence[str] = DEFAULT_RULES,
               estimator: str | Path | None = None, workers: int = 1,
               progress: bool = True) -> list[dict[str, Any]]:
    """Run the study into `out_dir` (resumable: a rerun goes on where it stopped).

    Args:
        config: The configuration (robot, sensor, coverage goal, view budget).
        out_dir: The folder (created if missing).
        episodes: Episode lists: bundled names or list files (`evaluation_episodes`).
        planners: Planner names (`vprobot.planners.runner.planner_names`).
        rules: Stop rules (`vprobot.stopping.rules`).
        estimator: The coverage estimator file of `estimate` (None: the bundled one).
        workers: Episodes at once on a local Ray (1: in this process).
        progress: Show progress bars.

    Returns:
        The study rows (`COLUMNS`).

    Raises:
        ValueError: For a bad list, two lists of one name, a bad planner or rule, no
            combination that applies, a folder holding another evaluation or in use by another
            process.
    """
    names = list_names(episodes)
    subjects = planner_subjects(config, planners)
    chosen = combinations(config, planners, rules, estimator, subjects)
    if not chosen or not episodes:
        raise ValueError(f"no stop rule of {list(rules)} applies to a planner of "
                         f"{list(planners)}, or no episode list given")
    lists = [(name, evaluation_episodes(config, episodes=entry))
             for name, entry in zip(names, episodes, strict=True)]
    out = Path(out_dir)
    with folder_lock(out, str(out)):
        table = []
        for name, specs in lists:
            for rule, applies in chosen:
                folder = out / name / _folder(rule)
                evaluate(config, applies, specs, folder, progress=progress,
                         carriers=("robot",), workers=workers, stops=(rule,),
                         estimator=estimator)
                rows = finished_rows(folder / "evaluation_episodes.csv")
                # Only the runs at `goal` are read for their curves (the plateau's reference).
                table += [study_row([row for row in rows
                                     if row["planner"] == stop_label(planner, rule)],
                                    name, planner, rule,
                                    request_budget(config, subjects[planner]),
                                    folder if rule == "goal" else None)
                          for planner in applies]
        _write_study(out, table, config)
    return table


def _write_study(out: Path, table: list[dict[str, Any]], config: Config) -> None:
    """The study's tables and plot from its rows (`extra_vs_goal`, `median_extra_vs_goal`
    and `out_of_reach_stops` filled in here, against the same planner's episodes stopped at the
    goal: a stop below the goal of an episode that planner misses even there, within the view
    budget, is out of reach, not false)."""
    at_goal = {(row["episodes"], row["planner"]): row for row in table if row["stop"] == "goal"}
    for row in table:
        reference = at_goal.get((row["episodes"], row["planner"]))
        if row["stop"] != "goal" and reference is not None:
            if row["fixed_plan"]:
                # Stopped before the plan's end: that of the same episode's run at `goal`.
                ends = reference["by_episode"]
                early = {episode for episode, requested in row["by_episode"].items()
                         if episode in ends and requested < ends[episode]}
                row["stopped"] = len(early)
                row["below_goal"] = early & row["missed"]
            to_goal = reference["to_goal"]
            row["extra_vs_goal"] = row["requested"] - statistics.fmean(to_goal.values())
            extra = [requested - to_goal[episode]
                     for episode, requested in row["by_episode"].items() if episode in to_goal]
            row["median_extra_vs_goal"] = statistics.median(extra) if extra else None
            out_of_reach = row["below_goal"] & reference["missed"]
            row["out_of_reach_stops"] = len(out_of_reach)
            row["false_stops"] = len(row["below_goal"] - out_of_reach)
            # Where the goal is out of reach: the requests from the plateau of the same
            # planner's run at `goal` (to the budget) to this run's end.
            gaps = [row["by_episode"][episode] - 1 - plateau_view(curve)
                    for episode in reference["missed"] & row["by_episode"].keys()
                    if (curve := reference["curves"][episode]) is not None]
            if gaps:
                row["plateau_gap_median"] = statistics.median(gaps)
                row["plateau_gap_min"], row["plateau_gap_max"] = min(gaps), max(gaps)
    write_text(out / "study.csv", csv_text(COLUMNS, table))
    write_text(out / "study.md", markdown(table, config))
    plot_study(table, config, out / "study.png")


def _cell(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _gap(row: dict[str, Any]) -> str:
    if row["plateau_gap_median"] is None:
        return "-"
    return (f"{row['plateau_gap_median']:+g} ({row['plateau_gap_min']:+d} to "
            f"{row['plateau_gap_max']:+d})")


def markdown(table: Sequence[dict[str, Any]], config: Config) -> str:
    """The study's Markdown: one table per episode list."""
    goal = f"{config.env.coverage_goal:.0%}"
    lines = [
        "# Stop study",
        "",
        f"Robot {config.cell.robot} in the loop; coverage goal {goal}; at most "
        f"{config.env.max_acquisitions} requests after the initial view. Per episode list, "
        f"rule and planner: the episodes stopped at or above the goal, the mean coverage at "
        f"the stop, views requested and acquired, views wasted beyond the goal (requests after "
        f"the one that reached it, 0 for an episode that missed it) and views requested "
        f"beyond the same planner stopped at the goal (`goal`: the simulator's stop; a fixed "
        f"plan runs to its end under it and is counted to the request after which it reached "
        f"the goal; not run for a planner that decides its own stop), on the mean and per "
        f"episode on the median; the episodes "
        f"that ended before the view budget (by the rule, or the planner itself) and of those "
        f"the false stops (a fixed plan: those that ended before its plan did), below the goal "
        f"where the same planner reaches it at `goal`, and the "
        f"stops where the goal was out of reach (below it, and the same planner misses it at "
        f"`goal` too, within the budget), and for the episodes whose goal was out of reach the "
        f"requests from the plateau of that run (its first request within "
        f"{100 * PLATEAU:g} pp of its highest coverage) to this run's end, median (range), "
        f"where its episodes table or its plan JSON holds the whole curve. Each rule's "
        f"evaluation is in "
        f"`LIST/RULE/`.",
    ]
    for episodes in dict.fromkeys(row["episodes"] for row in table):
        lines += ["", f"## {episodes}", "",
                  f"| planner | stop | episodes | at or above {goal} % | coverage at stop % "
                  f"| views | acquisitions | wasted views | views vs goal | median vs goal "
                  f"| stopped before the budget | false stops | out of reach | from the plateau "
                  f"|",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {row['planner']} | {row['stop']} | {row['count']} | "
                  f"{row['at_goal_pct']:.0f} | {row['coverage_pct']:.2f} | "
                  f"{row['requested']:.2f} | {row['acquisitions']:.2f} | {row['wasted']:.2f} | "
                  f"{_cell(row['extra_vs_goal'], 2)} | "
                  f"{_cell(row['median_extra_vs_goal'], 1)} | {_cell(row['stopped'], 0)} | "
                  f"{_cell(row['false_stops'], 0)} | {_cell(row['out_of_reach_stops'], 0)} | "
                  f"{_gap(row)} |"
                  for row in table if row["episodes"] == episodes]
    return "\n".join(lines) + "\n"


def plot_study(table: Sequence[dict[str, Any]], config: Config, path: Path) -> Path:
    """One panel per episode list: views requested against the share stopped at or above the
    goal, a marker per rule, a colour per planner (into a PNG, atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lists = list(dict.fromkeys(row["episodes"] for row in table))
    planners = list(dict.fromkeys(row["planner"] for row in table))
    rules = list(dict.fromkeys(row["stop"] for row in table))
    markers = "osD^vP*Xh<>p"
    figure, axes = plt.subplots(1, len(lists), figsize=(5.0 * len(lists) + 2.5, 4.6),
                                sharey=True, squeeze=False)
    for axis, episodes in zip(axes[0], lists, strict=True):
        for row in (row for row in table if row["episodes"] == episodes):
            axis.scatter(row["requested"], row["at_goal_pct"],
                         color=f"C{planners.index(row['planner']) % 10}",
                         marker=markers[rules.index(row["stop"]) % len(markers)], s=50)
        axis.set_title(episodes)
        axis.set_xlabel("views requested (mean)")
        axis.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"episodes stopped at or above {config.env.coverage_goal:.0%} (%)")
    handles = ([plt.Line2D([], [], color=f"C{number % 10}", marker="o", linestyle="",
                           label=planner) for number, planner in enumerate(planners)]
               + [plt.Line2D([], [], color="grey", marker=markers[number % len(markers)],
                             linestyle="", label=f"--stop {rule}")
                  for number, rule in enumerate(rules)])
    axes[0][-1].legend(handles=handles, fontsize="small", loc="upper left",
                       bbox_to_anchor=(1.02, 1.0))
    return save_figure(figure, path, "Stop rules: views against episodes at the goal")
