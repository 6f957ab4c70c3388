"""Compare planners on held-out motors (`vprobot evaluate`): a Markdown and a CSV table.

Every planner runs one episode per (motor, seed, mode); all planners see the same object pose
for a (motor, seed). Modes: `robot` (the robot must reach every view; joint-space travel and
reachability are measured) and `free` (a free-flying sensor as in the paper, for comparison
with its Table 9). Per planner and mode the table gives the mean coverage, the acquisitions
(views actually acquired, the initial view included), the success rate (coverage goal reached),
the mean travel per episode (`joint_time` s, `joint_path` rad, `cartesian` m, `paper` m), the
fraction of requested views the robot reached and the planning time per episode.
"""

from __future__ import annotations

import csv
import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from vprobot.config import Config
from vprobot.inspection import MotorScene
from vprobot.paths import MOTORS_DIR
from vprobot.planners.runner import EpisodeResult, Mode, parse_planner, run

MODES: tuple[Mode, ...] = ("robot", "free")
COLUMNS = ("planner", "mode", "episodes", "coverage_pct", "coverage_std_pct", "acquisitions",
           "requested", "success_pct", "joint_time_s", "joint_path_rad", "cartesian_m",
           "paper_m", "reachable_pct", "plan_s", "episode_s")
EPISODE_COLUMNS = ("planner", "mode", "motor", "seed", "coverage_pct", "acquisitions",
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


def test_motors() -> list[Path]:
    """The bundled held-out motors."""
    return sorted((MOTORS_DIR / "test").glob("*.stl"))


def episode_row(result: EpisodeResult) -> dict[str, Any]:
    """One CSV row of an episode (robot-only figures are None in free mode)."""
    travel, robot = result.travel, result.mode == "robot"
    return {
        "planner": result.planner,
        "mode": result.mode,
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
    """One row per (planner, mode), in the order they first appear (mode by mode, planners in
    the order given, as `evaluate` runs them)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["planner"], row["mode"]), []).append(row)
    table = []
    for (planner, mode), group in groups.items():
        coverage = [row["coverage_pct"] for row in group]
        table.append({
            "planner": planner,
            "mode": mode,
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


def markdown(table: list[dict[str, Any]], motors: Sequence[Path], seeds: Sequence[int],
             config: Config) -> str:
    """The Markdown report: settings, the table, and the paper's Table 9 for reference."""
    header = ("| planner | mode | episodes | coverage % | acquisitions | requested | success % "
              "| joint_time s | joint_path rad | cartesian m | paper m | reachable % "
              "| plan s |")
    lines = [
        "# Planner evaluation",
        "",
        f"Motors: {', '.join(path.name for path in motors)}; seeds: "
        f"{', '.join(map(str, seeds))} (one random object pose per motor and seed, the same "
        f"for every planner); robot {config.cell.robot}; coverage goal "
        f"{config.env.coverage_goal:.0%}; at most {config.env.max_acquisitions} requests after "
        f"the initial view for planners that stop at the goal. Mode `robot`: every view must be "
        f"reached by the robot; `free`: free-flying sensor as in the paper. Means per episode; "
        f"travel is summed over an episode; `plan s` is the time spent planning.",
        "",
        header,
        "|" + "---|" * (header.count("|") - 1),
    ]
    for row in table:
        coverage = f"{row['coverage_pct']:.2f} ± {row['coverage_std_pct']:.2f}"
        cells = [row["planner"], row["mode"], str(row["episodes"]), coverage,
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


def evaluate(config: Config, planners: Sequence[str], motors: Sequence[str | Path] | None,
             seeds: Sequence[int], out_dir: str | Path, progress: bool = True,
             modes: Sequence[Mode] = MODES) -> list[dict[str, Any]]:
    """Run every planner on every motor, seed and mode; write the tables into `out_dir`.

    Args:
        config: The configuration.
        planners: Planner names (`random1`, `random2`, `hrec`, `bscp`, `oracle`), or `bscp<N>`
            for B_SCP with N views.
        motors: Mesh files; the bundled test motors when None.
        seeds: Seeds of the object poses.
        out_dir: Folder for `evaluation.md`, `evaluation.csv` (one row per planner and mode)
            and `evaluation_episodes.csv` (one row per episode); created if missing.
        progress: Show a progress bar.
        modes: `robot` and/or `free`.

    Returns:
        The summary rows.

    Raises:
        ValueError: For an unknown planner or mode, or no planners, motors or seeds.
    """
    specs = [parse_planner(spec) for spec in planners]
    unknown = [mode for mode in modes if mode not in MODES]
    if unknown:
        raise ValueError(f"unknown mode {unknown[0]!r}; allowed: {', '.join(MODES)}")
    paths = [Path(path) for path in motors] if motors is not None else test_motors()
    if not specs or not paths or not seeds or not modes:
        raise ValueError("evaluate needs at least one planner, motor, seed and mode")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tqdm(total=len(paths) * len(seeds) * len(modes) * len(specs), desc="evaluate",
              disable=not progress) as bar:
        for path in paths:
            scene = MotorScene.load(config, path)
            for seed in seeds:
                for mode in modes:
                    for name, views in specs:
                        bar.set_postfix_str(f"{path.name} seed {seed} {mode} {name}")
                        rows.append(episode_row(run(config, scene, name, seed, mode, views)))
                        bar.update()
    table = summarize(rows)
    (out / "evaluation.md").write_text(markdown(table, paths, seeds, config))
    _write_csv(out / "evaluation.csv", COLUMNS, table)
    _write_csv(out / "evaluation_episodes.csv", EPISODE_COLUMNS, rows)
    return table
