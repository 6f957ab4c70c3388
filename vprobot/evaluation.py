"""Compare planners on held-out objects (`vprobot evaluate`): Markdown and CSV tables, a plot.

Every planner runs every episode of one fixed, versioned episode list (`vprobot.episode.specs`;
by default the bundled list over the test motors, or `shapes-v1` over the non-motor objects)
with each carrier, so all planners (and agents) are scored on identical episodes; the list is
written beside the tables. Carriers:
`robot` (the robot must reach every view; joint-space travel and reachability are measured)
and `free` (a free-flying sensor as in the paper, for comparison with its Table 9). Per planner
and carrier the table gives the mean coverage, the acquisitions (views actually acquired, the
initial view included), the success rate (coverage goal reached), the mean travel between the
views of an episode (`joint_time` s, `joint_path` rad, `cartesian` m, `paper` m; the approach
from the start to the first view is not counted, docs/states-actions-rewards.md#travel-costs),
the fraction of requested views the robot reached, the cell's cycle time of the part (approach,
moves, acquisitions and return home, docs/motion.md#cycle-time; robot only) and the planning time
per episode; the episode rows add the robot's least clearance to the cell's objects over its
moves and whether every margin held. Beside the final figures, the coverage after each of the
first 10 requests (the initial view included; an unreached request counts, since it costs a
request) gives a curve per planner (`coverage_vs_views.png`), its area (the mean coverage over
those 10 requests) and the number of requests at which the goal was reached. An episode that
ended earlier keeps its final coverage for the remaining requests: the planner stopped there,
so that is what it delivers with that many requests. An evaluation that runs `optimum` (the
fewest views that reach the goal) beside the other planners compares each with it, episode by
episode: the views above the optimum, the share of episodes within one view of it and the ratio
of the cycle times (`versus_optimum`).
"""

from __future__ import annotations

import contextlib
import csv
import functools
import itertools
import json
import statistics
import sys
import uuid
import warnings
from collections.abc import Generator, Iterator, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

from tqdm import tqdm

from vprobot.compute.cluster import parallel_map, require_ray
from vprobot.config import Config, ConfigError, config_document
from vprobot.episode import (
    BUNDLED_TEST_EPISODES,
    CARRIERS,
    CarrierName,
    EpisodeSpec,
    PartScene,
    SharedWork,
    episode_list,
    read_episode_list,
    write_episode_list,
)
from vprobot.episode.specs import BUNDLED_EPISODE_LISTS
from vprobot.files.atomic import (
    append_line,
    csv_text,
    file_sha256,
    folder_lock,
    refuse_link,
    save_figure,
    truncate_output,
    write_text,
)
from vprobot.files.paths import MOTORS_DIR, bundled_or_path
from vprobot.files.progress import showing_progress
from vprobot.files.schema import from_mapping
from vprobot.parts.generated import is_generated
from vprobot.parts.loading import LoadedMesh, load_mesh
from vprobot.plan import write_json
from vprobot.planners.base import Planner
from vprobot.planners.runner import (
    EpisodeResult,
    make_planner,
    parse_planner,
    result_document,
    run,
)
from vprobot.planners.self_stopping import stop_subject
from vprobot.stopping.rules import StopRule, make_stop_rule

CURVE_VIEWS = 10
"""Requests (the initial view included) over which the coverage curve and its area run."""
CURVE_COLUMNS = tuple(f"cov_{n}_pct" for n in range(1, CURVE_VIEWS + 1))
OPTIMUM = "optimum"
"""The planner whose rows the others are compared with (`vprobot.planners.optimum`)."""
OPTIMUM_COLUMNS = ("views_above_optimum", "within_one_view_pct", "cycle_ratio")
"""The summary's comparison with `OPTIMUM` (`summarize`); empty without its rows."""
PROOF_COLUMNS = ("proven", "gap_views")
"""An exact planner's proof per episode (`vprobot.planners.proof.Proof`): empty for the other
planners."""
PROOF_SUMMARY_COLUMNS = ("proven_pct", "gap_views_max")
"""The summary of `PROOF_COLUMNS` over an exact planner's episodes (`summarize`)."""
COLUMNS = ("planner", "carrier", "episodes", "coverage_pct", "coverage_std_pct", "acquisitions",
           "requested", "failed_requests", "success_pct", "area_pct", "views_to_goal",
           "cycle_time_s", "joint_time_s", "joint_path_rad", "cartesian_m", "paper_m",
           "reachable_pct", "plan_s", "plan_ms_per_view", "episode_s", *CURVE_COLUMNS,
           *OPTIMUM_COLUMNS, *PROOF_SUMMARY_COLUMNS)
EPISODE_COLUMNS = ("episode", "planner", "carrier", "part", "seed", "coverage_pct", "acquisitions",
                   "requested", "failed_requests", "success", "views_to_goal", "cycle_time_s",
                   "joint_time_s", "joint_path_rad", "cartesian_m", "paper_m", "reachable_pct",
                   "min_clearance_mm", "clearance_held", "plan_s", "plan_ms_per_view",
                   "episode_s", *CURVE_COLUMNS, *PROOF_COLUMNS)
FORMER_COLUMNS = {"motor": "part"}
"""Former names of `EPISODE_COLUMNS`, still read in a table being resumed."""
VERSUS_COLUMNS = ("episode", "planner", "carrier", "views_above_optimum", "cycle_ratio")
"""The per-episode comparison with `OPTIMUM` (`versus_optimum`)."""
VERSUS_NAME = "evaluation_vs_optimum.csv"
"""An evaluation folder's table of `VERSUS_COLUMNS`, derived from its episode rows."""
PLOT_NAME = "coverage_vs_views.png"
EPISODES_NAME = "evaluation_episodes.csv"
"""An evaluation folder's table of episode rows (`EPISODE_COLUMNS`)."""
PLANS_FOLDER = "plans"
"""An evaluation folder's plan JSON of each episode row (`plan_path`), for `vprobot view`,
`export` and `check`; without the ground-truth block, which a replay computes again."""
PLAN_KEY = "_plan"
"""The key under which a finished job's row carries its plan document to the writer."""
SETTINGS_NAME = "evaluation_settings.json"
"""The settings an evaluation folder's rows were run with (the config and the estimator)."""
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


def coverage_curve(result: EpisodeResult) -> list[float]:
    """Coverage (%) after each of the first `CURVE_VIEWS` requests, unreached ones included;
    past the episode's end its final coverage, since the planner stopped there."""
    curve = [100.0 * view.coverage for view in result.record.views[:CURVE_VIEWS]]
    return curve + [100.0 * result.coverage] * (CURVE_VIEWS - len(curve))


def views_to_goal(result: EpisodeResult) -> int | None:
    """The 1-based request (the initial view is 1) after which the coverage first reached the
    goal; None if it never did."""
    if not result.success:
        return None
    # The goal test of `success`; coverage never drops, so a view passing it exists.
    return next(number for number, view in enumerate(result.record.views, start=1)
                if view.coverage >= result.goal - 1e-12)


def episode_row(index: int, result: EpisodeResult) -> dict[str, Any]:
    """One CSV row of an episode (`index` into the episode list; joint-space figures and
    reachability are None for the free sensor)."""
    travel, robot = result.travel_sum, result.carrier == "robot"
    return {
        "episode": index,
        "planner": result.planner,
        "carrier": result.carrier,
        "part": Path(result.mesh).name,
        "seed": result.seed,
        "coverage_pct": 100.0 * result.coverage,
        "acquisitions": result.acquisitions,
        "requested": result.requested,
        # A free-flying sensor takes every view: none fails.
        "failed_requests": sum(not view.reachable for view in result.record.views),
        "success": result.success,
        "views_to_goal": views_to_goal(result),
        "cycle_time_s": None if result.cycle is None else result.cycle.total_s,
        "joint_time_s": travel.joint_time if robot else None,
        "joint_path_rad": travel.joint_path if robot else None,
        "cartesian_m": travel.cartesian,
        "paper_m": travel.paper,
        "reachable_pct": (None if result.reachability is None
                          else 100.0 * result.reachability),
        # The least distance to any object; whether each object's own margin held.
        "min_clearance_mm": (None if not result.clearances
                             else 1e3 * min(item.distance_m for item in result.clearances)),
        "clearance_held": (None if not result.clearances
                           else all(item.holds for item in result.clearances)),
        "plan_s": result.plan_seconds,
        "plan_ms_per_view": 1e3 * result.plan_seconds / max(result.requested, 1),
        "episode_s": result.episode_seconds,
        **dict(zip(CURVE_COLUMNS, coverage_curve(result), strict=True)),
        "proven": None if result.proof is None else result.proof.proven,
        "gap_views": None if result.proof is None else result.proof.gap_views,
    }


def _mean(rows: list[dict[str, Any]], key: str) -> float | None:
    values = [row[key] for row in rows if row[key] is not None]
    return statistics.fmean(values) if values else None


def versus_optimum(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each episode row that has an `OPTIMUM` row of the same episode and carrier, compared
    with it (`VERSUS_COLUMNS`, the optimum's own row included): the acquisitions above the
    optimum's (below zero for a planner that stopped with fewer, short of the goal) and the
    ratio of the cycle times (None where either has no cycle).

    Joined when the tables are written, not when a row is: the optimum's row of an episode may
    come after the others', or in a resumed run."""
    optimum = {(row["episode"], row["carrier"]): row for row in rows if row["planner"] == OPTIMUM}
    table = []
    for row in rows:
        best = optimum.get((row["episode"], row["carrier"]))
        if best is None:
            continue
        cycle, floor = row["cycle_time_s"], best["cycle_time_s"]
        table.append({"episode": row["episode"], "planner": row["planner"],
                      "carrier": row["carrier"],
                      "views_above_optimum": row["acquisitions"] - best["acquisitions"],
                      "cycle_ratio": None if cycle is None or not floor else cycle / floor})
    return table


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (planner, carrier), in the order they first appear (carrier by carrier,
    planners in the order given, as `evaluate` runs them): means over its episodes, but
    `views_to_goal` over those that reached the goal only (None if none did), and the
    comparison with the optimum (`OPTIMUM_COLUMNS`, from `versus_optimum`) over those that
    have an optimum row (None if none has): the mean views above it, the share of episodes
    within one view of it (%) and the mean ratio of the cycle times; for an exact planner the
    share of its plans proven optimal (%) and the largest gap in views (None for the others)."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["planner"], row["carrier"]), []).append(row)
    versus: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in versus_optimum(rows):
        versus.setdefault((row["planner"], row["carrier"]), []).append(row)
    table = []
    for (planner, carrier), group in groups.items():
        coverage = [row["coverage_pct"] for row in group]
        curve = [statistics.fmean(row[key] for row in group) for key in CURVE_COLUMNS]
        compared = versus.get((planner, carrier), [])
        within = [row["views_above_optimum"] <= 1 for row in compared]
        proofs = [row for row in group if row["proven"] is not None]
        gaps = [row["gap_views"] for row in proofs if row["gap_views"] is not None]
        table.append({
            "planner": planner,
            "carrier": carrier,
            "episodes": len(group),
            "coverage_pct": statistics.fmean(coverage),
            "coverage_std_pct": statistics.pstdev(coverage),
            "acquisitions": _mean(group, "acquisitions"),
            "requested": _mean(group, "requested"),
            "failed_requests": _mean(group, "failed_requests"),
            "success_pct": 100.0 * statistics.fmean(row["success"] for row in group),
            "area_pct": statistics.fmean(curve),
            **{key: _mean(group, key) for key in ("views_to_goal", "cycle_time_s",
                                                  "joint_time_s", "joint_path_rad",
                                                  "cartesian_m", "paper_m", "reachable_pct",
                                                  "plan_s", "plan_ms_per_view", "episode_s")},
            **dict(zip(CURVE_COLUMNS, curve, strict=True)),
            "views_above_optimum": _mean(compared, "views_above_optimum"),
            "within_one_view_pct": 100.0 * statistics.fmean(within) if within else None,
            "cycle_ratio": _mean(compared, "cycle_ratio"),
            "proven_pct": (100.0 * statistics.fmean(row["proven"] for row in proofs)
                           if proofs else None),
            "gap_views_max": max(gaps) if gaps else None,
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
    parts = sorted({Path(spec.part).name for spec in specs})
    seeds = sorted({spec.seed for spec in specs})
    header = ("| planner | carrier | episodes | coverage % | acquisitions | requested | failed "
              "| success % | area % | views to goal | cycle s | joint_time s | joint_path rad "
              "| cartesian m | paper m | reachable % | plan s | ms per view | cov@5 % | cov@10 % "
              "| views above optimum | within +1 view % | cycle / optimum | proven % "
              "| gap views, max |")
    lines = [
        "# Planner evaluation",
        "",
        f"Episodes: {len(specs)} from `episodes.json` (objects {', '.join(parts)}; seeds "
        f"{', '.join(map(str, seeds))}: one pose and initial view per object and seed, "
        f"the same for every planner); robot {config.cell.robot}; coverage goal "
        f"{config.env.coverage_goal:.0%}; at most {config.env.max_acquisitions} requests after "
        f"the initial view for planners that stop at the goal. Carrier `robot`: every view must "
        f"be reached by the robot; `free`: free-flying sensor as in the paper. Means per "
        f"episode; `cycle s` is the cell's cycle time of the part (approach from home, moves, "
        f"a stop of {config.sensor.acquisition_time_s:g} s to acquire at each view, return "
        f"home; robot only, over the episodes whose robot found its way home); travel is "
        f"summed over the moves between an episode's views (the approach to the first view is "
        f"not counted); `plan s` is the time spent planning an episode, "
        f"`ms per view` that time per requested view (for an agent: its policy's compute). "
        f"`area %` is the mean coverage after requests 1 to {CURVE_VIEWS} (the initial view "
        f"is 1; an episode that ended earlier keeps its final coverage), `views to goal` the "
        f"mean request at which the goal was reached, over the episodes that reached it; the "
        f"curves are in `evaluation.csv` and `{PLOT_NAME}`; `cov@5 %` and `cov@10 %` are "
        f"the mean coverage after 5 and 10 requests. `failed` is the mean number of requests "
        f"the robot did not reach. Against `{OPTIMUM}` (the fewest candidate views that reach "
        f"the goal, on the same episode and carrier): the mean acquisitions above its own, the "
        f"share of episodes within one view of it, and the mean ratio of the cycle times "
        f"(per episode in `{VERSUS_NAME}`). `proven %` is the share of `{OPTIMUM}`'s plans "
        f"its solver proved optimal (on the measured visibility of the views chosen, or of "
        f"every candidate where it measured them all) within its work limit, `gap views, "
        f"max` the most views any of its plans lies above the "
        f"proven fewest (0: proven).",
        "",
        *([] if any(row["views_above_optimum"] is not None for row in table) else [
            f"No `{OPTIMUM}` rows here, so the comparison with it is empty: add it to the "
            f"planners (`--planners ... {OPTIMUM}`; minutes per episode on the hardest parts) to "
            f"fill it.",
            ""]),
        header,
        "|" + "---|" * (header.count("|") - 1),
    ]
    for row in table:
        coverage = f"{row['coverage_pct']:.2f} ± {row['coverage_std_pct']:.2f}"
        cells = [row["planner"], row["carrier"], str(row["episodes"]), coverage,
                 _cell(row["acquisitions"], 2), _cell(row["requested"], 2),
                 _cell(row["failed_requests"], 2), _cell(row["success_pct"], 0),
                 _cell(row["area_pct"], 2),
                 _cell(row["views_to_goal"], 2), _cell(row["cycle_time_s"], 2),
                 _cell(row["joint_time_s"], 2),
                 _cell(row["joint_path_rad"], 2), _cell(row["cartesian_m"], 2),
                 _cell(row["paper_m"], 2), _cell(row["reachable_pct"], 1),
                 _cell(row["plan_s"], 3), _cell(row["plan_ms_per_view"], 1),
                 _cell(row["cov_5_pct"], 2), _cell(row["cov_10_pct"], 2),
                 _cell(row["views_above_optimum"], 2), _cell(row["within_one_view_pct"], 0),
                 _cell(row["cycle_ratio"], 3), _cell(row["proven_pct"], 0),
                 _cell(row["gap_views_max"], 0)]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Paper, Table 9 (free-flying sensor, 100 synthetic motors):", "",
              "| agent | coverage % | acquisitions | calculation time s |", "|---|---|---|---|"]
    lines += [f"| {name} | {coverage:.2f} | {views} | {seconds} |"
              for name, coverage, views, seconds in PAPER_TABLE_9]
    return "\n".join(lines) + "\n"


_INTEGER_COLUMNS = ("episode", "seed", "acquisitions", "requested", "failed_requests",
                    "views_to_goal", "gap_views")
_TEXT_COLUMNS = ("planner", "carrier", "part")


def _typed(line: str) -> dict[str, Any] | None:
    """A line of the episodes CSV as the row `episode_row` wrote; None for a damaged line (too
    few or too many cells, or a cell that does not parse: a torn write)."""
    cells = next(csv.reader([line]), [])
    if len(cells) != len(EPISODE_COLUMNS):
        return None
    typed: dict[str, Any] = {}
    for key, text in zip(EPISODE_COLUMNS, cells, strict=True):
        if key in _TEXT_COLUMNS:
            typed[key] = text
        elif key == "success" or (key in ("proven", "clearance_held") and text):
            if text not in ("True", "False"):
                return None
            typed[key] = text == "True"
        elif text == "":
            typed[key] = None
        else:
            try:
                typed[key] = int(text) if key in _INTEGER_COLUMNS else float(text)
            except ValueError:
                return None
    return typed


def finished_rows(path: Path) -> list[dict[str, Any]]:
    """The episode rows an earlier run wrote to `path`. A last line cut short by a kill, a
    damaged row and a second row of the same episode are dropped, and cut from the file, so
    that appending goes on cleanly and a dropped row's episode runs again; the dropped rows are
    named in one warning (a cut last line is the expected end of a kill: silently).

    Raises:
        ValueError: If the file is not an episodes table of this version (`LinkError`: or a
            symbolic link that it would cut).
    """
    if not path.is_file():
        return []
    data = path.read_bytes()
    complete = data[: data.rfind(b"\n") + 1]
    if len(complete) != len(data):
        truncate_output(path, len(complete))
    # Bytes that are not UTF-8 (a damaged row) decode to U+FFFD, and that row is dropped.
    lines = complete.decode(errors="replace").splitlines()
    if not lines:
        return []
    header = lines[0].split(",")
    # Tables written before the column said "part" said "motor"; the rows are alike.
    if [FORMER_COLUMNS.get(column, column) for column in header] != list(EPISODE_COLUMNS):
        # An older version's table lacks columns (the coverage curve, the cycle time) that its
        # episodes would need to be run again for.
        missing = [column for column in EPISODE_COLUMNS if column not in header]
        differ = (f"it lacks {', '.join(missing)}" if missing
                  else "its columns differ")
        raise ValueError(f"{path} is not an episodes table of this vprobot version ({differ}); "
                         f"use another --out")
    rows: dict[tuple[int, str, str], dict[str, Any]] = {}
    kept, damaged, repeated = [lines[0]], [], []
    for number, line in enumerate(lines[1:], start=2):
        row = _typed(line) if "\ufffd" not in line else None
        if row is None:
            damaged.append(number)
            continue
        key = (row["episode"], row["carrier"], row["planner"])
        if key in rows:
            repeated.append(number)
            continue
        rows[key] = row
        kept.append(line)
    if damaged or repeated:
        parts = [f"{len(numbers)} {what} row(s) at line(s) {', '.join(map(str, numbers))}"
                 for what, numbers in (("damaged", damaged), ("repeated", repeated)) if numbers]
        warnings.warn(f"{path}: dropped {' and '.join(parts)}; a damaged row's episode runs "
                      f"again", stacklevel=2)
        write_text(path, "\n".join(kept) + "\n")
    return list(rows.values())


def _append_row(path: Path, row: dict[str, Any]) -> None:
    """Append one row as a single write, flushed to disk: a kill leaves whole rows, and at
    worst a cut last line that `finished_rows` drops."""
    append_line(path, csv_text(EPISODE_COLUMNS, [row],
                               header=not path.exists() or path.stat().st_size == 0))


def plan_path(out: Path, episode: int, carrier: str, planner: str) -> Path:
    """Where an evaluation folder `out` keeps the plan of an episode row: `plans/<episode>/
    <carrier>/<planner label, %-quoted>.json` (a label may hold `:`, `/` or spaces)."""
    return out / PLANS_FOLDER / str(episode) / carrier / f"{quote(planner, safe='')}.json"


def stop_label(planner: str, stop: str) -> str:
    """A planner's label in the tables under a stop rule: the planner's own under `goal`."""
    return planner if stop == "goal" else f"{planner} --stop {stop}"


def _check_inputs(config: Config, specs: Sequence[EpisodeSpec],
                  planners: Sequence[tuple[str, str, int | None, str]],
                  estimator: str | Path | None, keep: bool, run_id: str) -> None:
    """Every part of the list, every planner (an agent's files) and stop rule (an
    estimator) loads, and every rule applies to its planner, before the first episode runs;
    with `keep`, the parts stay loaded for the episodes this process runs (`_scene`). The
    planners and rules are those the run `run_id` then runs in this process (`_built`)."""
    _checked.clear()  # left by an earlier evaluation whose scenes were already built
    for part in dict.fromkeys((spec.part_path, spec.scale) for spec in specs):
        mesh = load_mesh(*part)
        if keep:
            _checked[part] = mesh
    for label, name, views, stop in planners:
        planner, rule = _built(run_id, config, name, views, stop, estimator)
        if not rule.applies_to(stop_subject(planner)):
            raise ValueError(f"stop rule {stop!r} does not apply to planner {name!r} ({label})")


def _start_episode_list(path: Path, specs: Sequence[EpisodeSpec]) -> None:
    """Write the episode list, or check that a resumed evaluation ran the same one."""
    if not path.exists():
        write_episode_list(path, specs)
        return
    if read_episode_list(path) != list(specs):
        raise ValueError(f"{path.parent} holds an evaluation of other episodes; use another "
                         f"--out, or --episodes {path} to resume that one")


CONTENT = "sha256 of "
"""The settings' key of a file's content hash, before the file's path."""


def _settings(config: Config, specs: Sequence[EpisodeSpec],
              estimator: str | Path | None) -> dict[str, Any]:
    """What an evaluation's rows depend on besides its episodes, planners and carriers, as
    JSON data: the config, the estimator file and the content of it and of the mesh files
    (a file overwritten between a kill and the resume would mix two parts in one table; a
    generated object's content is named by its name). Files are named as the episode list and
    the command name them (a bundled motor by its name, a file by the path given), not by
    where this checkout lies: a clone elsewhere resumes the folder."""
    files = {spec.part: spec.part_path for spec in specs if not is_generated(spec.part)}
    if estimator is not None:
        files[str(estimator)] = Path(estimator)
    return {"config": config_document(config),
            "estimator": None if estimator is None else str(estimator),
            "sha256": {name: file_sha256(file) for name, file in files.items()}}


def _named_as_now(document: dict[str, Any], current: dict[str, Any]) -> dict[str, Any]:
    """A record made when files were named by their absolute paths (tied to the checkout that
    made it), with each such name replaced by the current name it ends with."""
    names = [*current["sha256"], *([current["estimator"]] if current["estimator"] else [])]

    def renamed(name: str) -> str:
        if not Path(name).is_absolute() or name in names:
            return name
        return next((now for now in names if name.endswith("/" + now.lstrip("./"))), name)

    estimator = document.get("estimator")
    return {**document, "estimator": None if estimator is None else renamed(estimator),
            **({"sha256": {renamed(name): digest for name, digest in document["sha256"].items()}}
               if "sha256" in document else {})}


def _flat_settings(settings: dict[str, Any]) -> dict[str, Any]:
    """Settings by `section.key` (and `estimator`, and `CONTENT` + a file's path)."""
    return {"estimator": settings.get("estimator"),
            **{f"{section}.{key}": value for section, values in settings["config"].items()
               for key, value in values.items()},
            **{f"{CONTENT}{name}": digest
               for name, digest in settings.get("sha256", {}).items()}}


def _in_current_keys(recorded: dict[str, Any]) -> dict[str, Any]:
    """A recorded config in this version's keys, as `load_config` would read it (a key renamed
    since, such as `env.motors`, under its new name); as recorded where it no longer loads."""
    try:
        with warnings.catch_warnings():
            # The renames' notes are for configs a user writes, not for a folder's record.
            warnings.simplefilter("ignore", FutureWarning)
            return config_document(from_mapping(Config, recorded))
    except ConfigError:
        return recorded


def _start_settings(path: Path, settings: dict[str, Any], resumed: bool) -> None:
    """Record an evaluation's settings, or check that a resumed evaluation ran with the same.

    Raises:
        ValueError: If the folder holds an evaluation of other settings, or a file whose
            content changed since.
    """
    if not path.exists():
        if resumed:
            warnings.warn(f"{path.parent} holds episodes of an evaluation that did not record "
                          f"its settings (an older vprobot); they are taken to be this run's",
                          stacklevel=3)
        write_text(path, json.dumps(settings, indent=1) + "\n")
        return
    document = _named_as_now(json.loads(path.read_text()), settings)
    recorded = _flat_settings({**document, "config": _in_current_keys(document["config"])})
    current = _flat_settings(settings)
    # A setting added to vprobot after the folder was made left its rows as they were if it is
    # at its default; the contents of a folder made before they were recorded go unchecked.
    defaults = _flat_settings({"config": config_document(Config())})
    recorded = {**{key: defaults[key] for key in current
                   if key not in recorded and key in defaults},
                **{key: current[key] for key in current
                   if key.startswith(CONTENT) and "sha256" not in document}, **recorded}
    changed = [key for key in {**recorded, **current} if recorded.get(key) != current.get(key)]
    if not changed:
        return
    key = changed[0]
    if key.startswith(CONTENT) and key in recorded and key in current:
        raise ValueError(f"{key.removeprefix(CONTENT)} changed since the evaluation in "
                         f"{path.parent} began (sha256 {str(recorded[key])[:12]}... there, "
                         f"{str(current[key])[:12]}... now; see {path}): its rows would mix "
                         f"the two; restore the file, or use another --out")
    raise ValueError(f"{path.parent} holds an evaluation of other settings ({key} "
                     f"{recorded.get(key)!r} there, {current.get(key)!r} now; see {path}); "
                     f"resume it with those settings, or use another --out")


def plot_coverage_curves(table: Sequence[dict[str, Any]], config: Config, path: Path,
                         title: str) -> Path:
    """Plot the summary rows' mean coverage curves into a PNG (atomically): one panel per
    carrier, one line per planner, `OPTIMUM`'s black and dotted (the floor of the views to the
    goal, not of each request's coverage: its views are ordered for the cycle time), the
    coverage goal dashed.

    Raises:
        ValueError: For an empty table.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    carriers = list(dict.fromkeys(row["carrier"] for row in table))
    # The optimum is drawn apart, so that a planner's colour does not depend on whether the
    # optimum ran.
    planners = list(dict.fromkeys(row["planner"] for row in table if row["planner"] != OPTIMUM))
    if not carriers:
        raise ValueError("no evaluated episodes to plot")
    names = {"robot": f"robot {config.cell.robot} in the loop", "free": "free-flying sensor"}
    views = list(range(1, CURVE_VIEWS + 1))
    figure, axes = plt.subplots(1, len(carriers), figsize=(5.5 * len(carriers) + 1.5, 4.8),
                                sharey=True, squeeze=False)
    for axis, carrier in zip(axes[0], carriers, strict=True):
        for row in (row for row in table if row["carrier"] == carrier):
            curve = [row[key] for key in CURVE_COLUMNS]
            if row["planner"] == OPTIMUM:
                axis.plot(views, curve, marker="s", markersize=3, color="black", linestyle=":",
                          linewidth=2.0, label=f"{OPTIMUM} (fewest views)")
                continue
            # A planner keeps its colour in every panel; the default cycle has ten colours,
            # so later planners are told apart by their line.
            number = planners.index(row["planner"])
            axis.plot(views, curve, marker="o", markersize=3, color=f"C{number % 10}",
                      linestyle="-" if number < 10 else "-.", label=row["planner"])
        axis.axhline(100.0 * config.env.coverage_goal, color="black", linestyle="--",
                     linewidth=1.0, label=f"goal {config.env.coverage_goal:.0%}")
        axis.set_title(names.get(carrier, carrier))
        axis.set_xlabel("requests (the initial view is 1)")
        axis.set_xticks(views)
        axis.grid(alpha=0.3)
    # One legend outside the panels (inside, it would hide the curves of a dozen planners),
    # from all of them: a partial evaluation may lack a planner in a panel.
    handles = {line.get_label(): line for axis in axes[0] for line in axis.get_lines()}
    axes[0][-1].legend(handles.values(), handles.keys(), fontsize="small", loc="upper left",
                       bbox_to_anchor=(1.02, 1.0))
    axes[0][0].set_ylabel("mean coverage %")
    return save_figure(figure, path, title)


def _write_tables(out: Path, rows: list[dict[str, Any]], specs: Sequence[EpisodeSpec],
                  config: Config, total: int) -> list[dict[str, Any]]:
    table = summarize(rows)
    text = markdown(table, specs, config)
    title = f"Mean coverage after each request, {len(specs)} episodes"
    if len(rows) < total:
        text = (f"**Partial: {len(rows)} of {total} episodes; run the same command again to "
                f"finish.**\n\n" + text)
        title += f" (partial: {len(rows)} of {total} episodes)"
    write_text(out / "evaluation.md", text)
    write_text(out / "evaluation.csv", csv_text(COLUMNS, table))
    write_text(out / VERSUS_NAME, csv_text(VERSUS_COLUMNS, versus_optimum(rows)))
    if table:  # an interrupt before the first episode finished leaves nothing to plot
        plot_coverage_curves(table, config, out / PLOT_NAME, title)
    return table


def evaluation_episodes(config: Config, parts: Sequence[str | Path] | None = None,
                        seeds: Sequence[int] | None = None,
                        episodes: str | Path | None = None) -> list[EpisodeSpec]:
    """The episode list of an evaluation: a bundled list by name (`BUNDLED_EPISODE_LISTS`) or a
    list file, the episodes of parts x seeds, or the bundled list over the test motors.

    Raises:
        ValueError: For a list together with parts or seeds, a missing list file that is not a
            bundled name, or a bad list.
    """
    if episodes is not None:
        if parts is not None or seeds is not None:
            raise ValueError("give either an episode list or parts and seeds, not both")
        return read_episode_list(bundled_or_path(episodes, BUNDLED_EPISODE_LISTS,
                                                 "episode list"))
    if parts is None and seeds is None:
        return read_episode_list(BUNDLED_TEST_EPISODES)
    return episode_list(config, [Path(path) for path in parts] if parts is not None
                        else held_out_motors(), seeds if seeds is not None else (0, 1, 2))


Job = tuple[int, EpisodeSpec, CarrierName, str, str, int | None, str]
"""An episode to run: (index in the list, spec, carrier, planner label, name, fixed views, stop
rule)."""


_checked: dict[tuple[Path, float], LoadedMesh] = {}
"""The parts `_check_inputs` loaded in this process, until `_scene` builds on them."""


_planners: dict[tuple[str, str, int | None, str], tuple[Planner, StopRule]] = {}
"""The planners and stop rules this process built, by (run id, name, views, stop rule): those
of the latest run only."""


def _built(run_id: str, config: Config, name: str, views: int | None, stop: str,
           estimator: str | Path | None) -> tuple[Planner, StopRule]:
    """A job's planner and stop rule, built once per run in this process (`_check_inputs` in
    the evaluating process, the first job in a Ray worker) and run episode after episode: each
    episode resets them (`run_episode`), and an agent's model loads once."""
    if any(key[0] != run_id for key in _planners):
        # Another run's (its config, or an agent file since rewritten): built anew.
        _planners.clear()
    key = (run_id, name, views, stop)
    if key not in _planners:
        _planners[key] = (make_planner(name, config, views),
                          make_stop_rule(stop, config, estimator))
    return _planners[key]


@functools.lru_cache(maxsize=2)
def _scene(config: Config, path: Path, scale: float) -> PartScene:
    # Kept across calls: a Ray worker runs many episodes, mostly of the parts it has loaded.
    mesh = _checked.pop((path, scale), None)
    return (PartScene.load(config, path, scale) if mesh is None
            else PartScene.build(config, mesh))


def _job_rows(config: Config, jobs: Sequence[Job], estimator: str | Path | None,
              run_id: str) -> Iterator[dict[str, Any]]:
    """Run episodes of the run `run_id` in this process (the latest motors stay loaded, its
    planners are built once: `_built`), one row per job as it finishes, under the job's label.
    Consecutive jobs of one episode and carrier share their work (`SharedWork`: the candidate
    views of the model-based planners)."""
    for _, group in itertools.groupby(jobs, key=lambda job: (job[0], job[2])):
        shared = SharedWork()
        for index, spec, carrier, label, name, views, stop in group:
            scene = _scene(config, spec.part_path, spec.scale)
            result = run(config, scene, name, spec, carrier, views, stop, estimator,
                         shared=shared,
                         built=_built(run_id, config, name, views, stop, estimator))
            # Without the ground truth (thousands of points): a replay computes it again.
            document = result_document(scene, result, ground_truth=False)
            yield {**episode_row(index, result), "planner": label,
                   PLAN_KEY: {**document, "planner": label}}


def run_jobs(config: Config, jobs: Sequence[Job], estimator: str | Path | None,
             run_id: str) -> list[dict[str, Any]]:
    """Run episodes of the run `run_id` in this process (`_job_rows`); one row per job, under
    the job's label; `estimator` is the coverage estimator of `estimate` (None: bundled)."""
    return list(_job_rows(config, jobs, estimator, run_id))


def _rows(config: Config, jobs: Sequence[Job], workers: int, address: str | None,
          estimator: str | Path | None, run_id: str) -> Generator[dict[str, Any], None, None]:
    """The jobs' rows as they finish: in order in this process, or per episode (all its
    carriers and planners, one part load) as Ray tasks."""
    if workers == 1 and address is None:
        yield from _job_rows(config, jobs, estimator, run_id)
        return
    groups: dict[int, list[Job]] = {}
    for job in jobs:
        groups.setdefault(job[0], []).append(job)
    with contextlib.closing(parallel_map(run_jobs, [(config, group, estimator, run_id)
                                                    for group in groups.values()],
                                         workers, address)) as tasks:
        for _, rows in tasks:
            yield from rows


def evaluate(config: Config, planners: Sequence[str], specs: Sequence[EpisodeSpec],
             out_dir: str | Path, progress: bool = True,
             carriers: Sequence[CarrierName] = CARRIERS, workers: int = 1,
             address: str | None = None, stops: Sequence[str] = ("goal",),
             estimator: str | Path | None = None) -> list[dict[str, Any]]:
    """Run every planner on every episode with every carrier; write the tables into `out_dir`.

    Resumable: each finished episode is appended to `evaluation_episodes.csv` at once, and a
    rerun into the same folder skips the episodes already there (a damaged row is dropped and
    its episode run again). On Ctrl-C (or SIGTERM via the CLI) the tables and the plot of the
    finished episodes are written before the interrupt goes on. The folder is locked
    (`folder.lock`) while this runs, and records the settings (`evaluation_settings.json`,
    with the sha256 of the mesh and estimator files) that a rerun must share. A planner,
    carrier or stop rule given twice runs once.

    Args:
        config: The configuration.
        planners: Planner names (`random1`, `random2`, `hrec`, `bscp`, `oracle`, `optimum`:
            the others are then compared with it), or `bscp<N>` for B_SCP with N views.
        specs: The episodes (`evaluation_episodes`).
        out_dir: Folder for `evaluation.md`, `evaluation.csv` (one row per planner and
            carrier), `evaluation_episodes.csv` (one row per episode), `episodes.json` (the
            episode list), `evaluation_vs_optimum.csv` (each episode row against `optimum`'s,
            when it ran), `coverage_vs_views.png` (the mean coverage curves),
            `evaluation_settings.json` and each episode's plan JSON (`plan_path`); created if
            missing.
        progress: Show a progress bar.
        carriers: `robot` and/or `free`.
        workers: Ray tasks at once (one CPU each); 1 without `address` runs in this process.
        address: A Ray cluster to run on (a local Ray with `workers` CPUs when None).
        stops: Stop rules (`vprobot.stopping.rules`), each with every planner; a planner
            under a rule other than `goal` is labelled `PLANNER --stop RULE` (`stop_label`).
        estimator: The coverage estimator file of `estimate` (None: the bundled one).

    Returns:
        The summary rows.

    Raises:
        ValueError: For an unknown planner, carrier or stop rule, no planners, episodes,
            carriers or stop rules, a rule that does not apply to a planner, a part that does
            not load, or an output folder holding an evaluation of other episodes or settings
            (`InUseError`: or in use by another process).
        OSError: If a row cannot be written whole (a full disk); the rows before it are kept.
    """
    # Given twice, a planner, carrier or rule would run each of its episodes twice.
    planners, stops = list(dict.fromkeys(planners)), list(dict.fromkeys(stops))
    carriers = list(dict.fromkeys(carriers))
    parsed = [(stop_label(spec, stop), *parse_planner(spec), stop) for stop in stops
              for spec in planners]
    unknown = [carrier for carrier in carriers if carrier not in CARRIERS]
    if unknown:
        raise ValueError(f"unknown carrier {unknown[0]!r}; allowed: {', '.join(CARRIERS)}")
    if not parsed or not specs or not carriers:
        raise ValueError("evaluate needs at least one planner, episode, carrier and stop rule")
    if workers > 1 or address is not None:
        require_ray()
    # Each planner is built once per run and process (`_built`), first by this check.
    run_id = uuid.uuid4().hex
    # Loading an agent takes seconds: its note says so rather than a silent start.
    with showing_progress() if progress else contextlib.nullcontext():
        _check_inputs(config, specs, parsed, estimator, keep=workers == 1 and address is None,
                      run_id=run_id)
    out = Path(out_dir)
    rows_path = out / EPISODES_NAME
    wanted = {(index, carrier, label) for index in range(len(specs)) for carrier in carriers
              for label, *_ in parsed}

    def recorded() -> list[dict[str, Any]]:
        return [row for row in finished_rows(rows_path)
                if (row["episode"], row["carrier"], row["planner"]) in wanted]

    # Two evaluations appending to one table would both run its missing episodes.
    with folder_lock(out, str(out)):
        # Before any episode: the rows would be appended through a link into a file outside.
        refuse_link(rows_path)
        # Read first: a folder holding an older version's table is refused before anything is
        # written into it.
        rows = recorded()
        _start_episode_list(out / "episodes.json", specs)
        _start_settings(out / SETTINGS_NAME, _settings(config, specs, estimator),
                        bool(rows))
        done = {(row["episode"], row["carrier"], row["planner"]) for row in rows}
        if done and progress:
            print(f"resuming: {len(done)} of {len(wanted)} episodes already in {rows_path}")
        jobs = [(index, spec, carrier, label, name, views, stop)
                for index, spec in enumerate(specs) for carrier in carriers
                for label, name, views, stop in parsed if (index, carrier, label) not in done]
        try:
            with tqdm(total=len(wanted), initial=len(done), desc="evaluate",
                      disable=not progress) as bar:
                # Closed at once on an interrupt: Ray's pending episodes are cancelled before
                # the partial tables are written.
                with contextlib.closing(_rows(config, jobs, workers, address,
                                              estimator, run_id)) as finished:
                    for row in finished:
                        # The plan before its row: a row on file has its plan.
                        plan = plan_path(out, row["episode"], row["carrier"], row["planner"])
                        plan.parent.mkdir(parents=True, exist_ok=True)
                        write_json(plan, row.pop(PLAN_KEY))
                        _append_row(rows_path, row)
                        rows.append(row)
                        bar.update()
        except KeyboardInterrupt:
            # From the file: the interrupt may have come between a row's line and
            # `rows.append`.
            rows = recorded()
            _write_tables(out, rows, specs, config, len(wanted))
            print(f"saved {len(rows)} of {len(wanted)} episodes in {out}; run the same command "
                  f"again to resume", file=sys.stderr)
            raise
        order = {key: position for position, key in enumerate(
            (index, carrier, label) for index in range(len(specs)) for carrier in carriers
            for label, *_ in parsed)}
        rows.sort(key=lambda row: order[(row["episode"], row["carrier"], row["planner"])])
        return _write_tables(out, rows, specs, config, len(wanted))
