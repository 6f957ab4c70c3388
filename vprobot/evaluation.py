"""Compare planners on held-out motors (`vprobot evaluate`): a Markdown and a CSV table.

Every planner runs every episode of one fixed, versioned episode list (`vprobot.episode.specs`;
by default the bundled list over the test motors) with each carrier, so all planners (and
agents) are scored on identical episodes; the list is written beside the tables. Carriers:
`robot` (the robot must reach every view; joint-space travel and reachability are measured)
and `free` (a free-flying sensor as in the paper, for comparison with its Table 9). Per planner
and carrier the table gives the mean coverage, the acquisitions (views actually acquired, the
initial view included), the success rate (coverage goal reached), the mean travel between the
views of an episode (`joint_time` s, `joint_path` rad, `cartesian` m, `paper` m; the approach
from the start to the first view is not counted, SPEC section 8), the fraction of requested
views the robot reached and the planning time per episode.
"""

from __future__ import annotations

import csv
import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from vprobot.config import Config
from vprobot.episode import (
    BUNDLED_TEST_EPISODES,
    CARRIERS,
    CarrierName,
    EpisodeSpec,
    MotorScene,
    episode_list,
    read_episode_list,
    write_episode_list,
)
from vprobot.paths import MOTORS_DIR
from vprobot.planners.runner import EpisodeResult, parse_planner, run

COLUMNS = ("planner", "carrier", "episodes", "coverage_pct", "coverage_std_pct", "acquisitions",
           "requested", "success_pct", "joint_time_s", "joint_path_rad", "cartesian_m",
           "paper_m", "reachable_pct", "plan_s", "episode_s")
EPISODE_COLUMNS = ("planner", "carrier", "motor", "seed", "coverage_pct", "acquisitions",
                   "requested", "success", "joint_time_s", "joint_path_rad", "cartesian_m",
                   "paper_m", "reachable_pct", "plan_s", "episode_s")
PAPER_TABLE_9 = (
    ("agent 8 (A_2S0R)", 92.20, 5.26, 0.0521),
    ("agent 9 (A_3S0R)", 92.16, 4.63, 0.0538),
    ("B_SCP,4", 96.20, 4, 506.29),
    ("B_SCP,5", 98.17, 5, 506.29),
    ("H_rec", 97.47, 6, 0.0021),
)
"""The paper's Table 9 (free-flying sensor, synthetic motors): coverage %, acquisitions, s."""


def held_out_motors() -> list[Path]:
    """The bundled held-out motors."""
    return sorted((MOTORS_DIR / "test").glob("*.stl"))


def episode_row(result: EpisodeResult) -> dict[str, Any]:
    """One CSV row of an episode (robot-only figures are None for the free sensor)."""
    travel, robot = result.travel, result.carrier == "robot"
    return {
        "planner": result.planner,
        "carrier": result.carrier,
        "motor": Path(result.mesh).name,
        "seed": result.seed,
        "coverage_pct": 100.0 * result.coverage,
        "acquisitions": result.acquisitions,
        "requested": result.requested,
        "success": result.success,
        "joint_time_s": travel.joint_time if robot else None,
        "joint_path_rad": travel.joint_path if robot else None,
        "cartesian_m": travel.cartesian if robot else None,
        "paper_m": travel.paper,
        "reachable_pct": 100.0 * result.reachability if robot else None,
        "plan_s": result.plan_seconds,
        "episode_s": result.episode_seconds,
    }


def _mean(rows: list[dict[str, Any]], key: str) -> float | None:
    values = [row[key] for row in rows if row[key] is not None]
    return statistics.fmean(values) if values else None


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (planner, carrier), in the order they first appear (carrier by carrier,
    planners in the order given, as `evaluate` runs them)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["planner"], row["carrier"]), []).append(row)
    table = []
    for (planner, carrier), group in groups.items():
        coverage = [row["coverage_pct"] for row in group]
        table.append({
            "planner": planner,
            "carrier": carrier,
            "episodes": len(group),
            "coverage_pct": statistics.fmean(coverage),
            "coverage_std_pct": statistics.pstdev(coverage),
            "acquisitions": _mean(group, "acquisitions"),
            "requested": _mean(group, "requested"),
            "success_pct": 100.0 * statistics.fmean(row["success"] for row in group),
            **{key: _mean(group, key) for key in ("joint_time_s", "joint_path_rad",
                                                  "cartesian_m", "paper_m", "reachable_pct",
                                                  "plan_s", "episode_s")},
        })
    return table


def _cell(value: Any, digits: int) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def markdown(table: list[dict[str, Any]], specs: Sequence[EpisodeSpec], config: Config) -> str:
    """The Markdown report: settings, the table, and the paper's Table 9 for reference."""
    motors = sorted({Path(spec.motor).name for spec in specs})
    seeds = sorted({spec.seed for spec in specs})
    header = ("| planner | carrier | episodes | coverage % | acquisitions | requested | success % "
              "| joint_time s | joint_path rad | cartesian m | paper m | reachable % "
              "| plan s |")
    lines = [
        "# Planner evaluation",
        "",
        f"Episodes: {len(specs)} from `episodes.json` (motors {', '.join(motors)}; seeds "
        f"{', '.join(map(str, seeds))}: one object pose and initial view per motor and seed, "
        f"the same for every planner); robot {config.cell.robot}; coverage goal "
        f"{config.env.coverage_goal:.0%}; at most {config.env.max_acquisitions} requests after "
        f"the initial view for planners that stop at the goal. Carrier `robot`: every view must "
        f"be reached by the robot; `free`: free-flying sensor as in the paper. Means per "
        f"episode; travel is summed over the moves between an episode's views (the approach "
        f"to the first view is not counted); `plan s` is the time spent planning.",
        "",
        header,
        "|" + "---|" * (header.count("|") - 1),
    ]
    for row in table:
        coverage = f"{row['coverage_pct']:.2f} ± {row['coverage_std_pct']:.2f}"
        cells = [row["planner"], row["carrier"], str(row["episodes"]), coverage,
                 _cell(row["acquisitions"], 2), _cell(row["requested"], 2),
                 _cell(row["success_pct"], 0), _cell(row["joint_time_s"], 2),
                 _cell(row["joint_path_rad"], 2), _cell(row["cartesian_m"], 2),
                 _cell(row["paper_m"], 2), _cell(row["reachable_pct"], 1),
                 _cell(row["plan_s"], 3)]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Paper, Table 9 (free-flying sensor, 100 synthetic motors):", "",
              "| agent | coverage % | acquisitions | calculation time s |", "|---|---|---|---|"]
    lines += [f"| {name} | {coverage:.2f} | {views} | {seconds} |"
              for name, coverage, views, seconds in PAPER_TABLE_9]
    return "\n".join(lines) + "\n"


def _write_csv(path: Path, columns: Sequence[str], rows: list[dict[str, Any]]) -> None:
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(columns))
        writer.writeheader()
        for row in rows:
            writer.writerow({key: "" if row[key] is None else row[key] for key in columns})


def evaluation_episodes(config: Config, motors: Sequence[str | Path] | None = None,
                        seeds: Sequence[int] | None = None,
                        episodes: str | Path | None = None) -> list[EpisodeSpec]:
    """The episode list of an evaluation: a list file, the episodes of motors x seeds, or the
    bundled list over the test motors.

    Raises:
        ValueError: For a list file together with motors or seeds, or a bad list.
    """
    if episodes is not None:
        if motors is not None or seeds is not None:
            raise ValueError("give either an episode list or motors and seeds, not both")
        return read_episode_list(episodes)
    if motors is None and seeds is None:
        return read_episode_list(BUNDLED_TEST_EPISODES)
    return episode_list(config, [Path(path) for path in motors] if motors is not None
                        else held_out_motors(), seeds if seeds is not None else (0, 1, 2))


def evaluate(config: Config, planners: Sequence[str], specs: Sequence[EpisodeSpec],
             out_dir: str | Path, progress: bool = True,
             carriers: Sequence[CarrierName] = CARRIERS) -> list[dict[str, Any]]:
    """Run every planner on every episode with every carrier; write the tables into `out_dir`.

    Args:
        config: The configuration.
        planners: Planner names (`random1`, `random2`, `hrec`, `bscp`, `oracle`), or `bscp<N>`
            for B_SCP with N views.
        specs: The episodes (`evaluation_episodes`).
        out_dir: Folder for `evaluation.md`, `evaluation.csv` (one row per planner and
            carrier), `evaluation_episodes.csv` (one row per episode) and `episodes.json` (the
            episode list); created if missing.
        progress: Show a progress bar.
        carriers: `robot` and/or `free`.

    Returns:
        The summary rows.

    Raises:
        ValueError: For an unknown planner or carrier, or no planners, episodes or carriers.
    """
    parsed = [parse_planner(spec) for spec in planners]
    unknown = [carrier for carrier in carriers if carrier not in CARRIERS]
    if unknown:
        raise ValueError(f"unknown carrier {unknown[0]!r}; allowed: {', '.join(CARRIERS)}")
    if not parsed or not specs or not carriers:
        raise ValueError("evaluate needs at least one planner, episode and carrier")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    scenes: dict[tuple[Path, float], MotorScene] = {}
    with tqdm(total=len(specs) * len(carriers) * len(parsed), desc="evaluate",
              disable=not progress) as bar:
        for spec in specs:
            key = (spec.motor_path, spec.scale)
            if key not in scenes:
                scenes.clear()
                scenes[key] = MotorScene.load(config, spec.motor_path, spec.scale)
            for carrier in carriers:
                for name, views in parsed:
                    bar.set_postfix_str(f"{Path(spec.motor).name} seed {spec.seed} {carrier} "
                                        f"{name}")
                    rows.append(episode_row(run(config, scenes[key], name, spec, carrier,
                                                views)))
                    bar.update()
    table = summarize(rows)
    write_episode_list(out / "episodes.json", specs)
    (out / "evaluation.md").write_text(markdown(table, specs, config))
    _write_csv(out / "evaluation.csv", COLUMNS, table)
    _write_csv(out / "evaluation_episodes.csv", EPISODE_COLUMNS, rows)
    return table
