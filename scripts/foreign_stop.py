"""Measure `--stop estimate` on the foreign parts (results/stop_estimate/foreign/, made by
scripts/make_foreign_parts.py): how often it stops below the goal, and how far its stated
interval misses the truth.

`rollouts` runs each planner on each part (STL in millimetres, `--scale 0.001`, as a user
would) and seed with the robot in the loop and no coverage goal, so that every episode runs to
the view budget, and appends one row per view (its features and true coverage, the columns of
`vprobot.stop_studies.dataset`) to `rollouts.csv`; it resumes after the episodes already there.
`score` replays `--stop estimate` on those views, as the rule meets them (a planner under the
rule follows the same views until the rule stops it): `before`, the estimator's plain estimate
after each view (the rule before issue 30); `after`, the estimate as
`vprobot.stopping.estimator.EstimateTracker` states it (no rise without new surface, widened or
refused outside what the estimator was fit on) but stopping wherever its bound reaches the goal;
`held`, the rule as it is now: `after`, and no stop while more space is unexplored than on the
training views where the estimate claimed the goal (`Stated.held`). It writes
`rollouts-stops.csv` and `rollouts-stops.md` (or NAME-stops.* beside any table of rollouts
given, e.g. those of `vprobot stop error`). `list` writes the episodes of the parts and seeds as
an episode list (`--out`, default FOLDER/FOLDER.json, named after its folder) for `vprobot stop
study --episodes`.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path
from statistics import NormalDist
from typing import Any

import numpy as np

from vprobot.config import Config, load_config
from vprobot.episode import seeded_episode
from vprobot.episode.specs import episode_list, write_episode_list
from vprobot.files.atomic import append_line, csv_text, write_text
from vprobot.stop_studies.dataset import COLUMNS, read_dataset, rollout
from vprobot.stopping.estimator import CoverageEstimator, EstimateTracker, load_estimator

FOLDER = Path("results/stop_estimate/foreign")
SCALE = 0.001
SEEDS = (0, 1)
PLANNERS = ("nbv", "uniform8", "random2")
CONFIDENCE = 0.95
MISS_PP = 3.0
"""An interval misses badly when the truth lies more than this far outside it."""


def rollouts(folder: Path, planners: tuple[str, ...], seeds: tuple[int, ...]) -> None:
    """Append the views of every (part, seed, planner) episode not in `rollouts.csv` yet."""
    config = Config()
    table = folder / "rollouts.csv"
    done: set[tuple[str, str, str]] = set()
    if table.exists():
        with table.open(newline="") as stream:
            done = {(row["object"], row["seed"], row["planner"]) for row in csv.DictReader(stream)}
    else:
        append_line(table, csv_text(COLUMNS, []))
    parts = sorted(folder.glob("*.stl"))
    for part in parts:
        for seed in seeds:
            spec = seeded_episode(config.env, part, seed, SCALE)
            for planner in planners:
                if (spec.part, str(spec.seed), planner) in done:
                    continue
                rows = [{"episode": 0, "object": spec.part, "family": "foreign",
                         "planner": planner, "seed": spec.seed, **row}
                        for row in rollout(config, spec, planner)]
                # One write per episode: a killed run leaves whole episodes.
                append_line(table, csv_text(COLUMNS, rows, header=False))
                print(f"{part.stem} seed {seed} {planner}: {len(rows)} views, coverage "
                      f"{100 * rows[-1]['coverage']:.1f} %", flush=True)


def replay(mean: np.ndarray, std: np.ndarray, truth: np.ndarray, goal: float, z: float,
           held: np.ndarray | None = None) -> dict[str, Any]:
    """One episode under `estimate`: where it stops (mean - z std >= goal and not `held`; NaN:
    refused) and how its statement then compares with the truth."""
    with np.errstate(invalid="ignore"):
        confident = np.flatnonzero((mean - z * std >= goal)
                                   & (True if held is None else ~held))
    reached = np.flatnonzero(truth >= goal - 1e-12)
    stop = int(confident[0]) if len(confident) else len(truth) - 1
    two_sided = NormalDist().inv_cdf(0.5 + CONFIDENCE / 2.0)
    with np.errstate(invalid="ignore"):
        # Over: the interval lies above the truth (it claims too much); under: below it.
        over = (mean - two_sided * std) - truth
        outside = np.maximum(truth - (mean + two_sided * std), over)
    return {"stopped_on_estimate": bool(len(confident)), "stop_view": stop + 1,
            "truth_at_stop": truth[stop], "mean_at_stop": mean[stop], "std_at_stop": std[stop],
            "below_goal": bool(truth[stop] < goal - 1e-12),
            "goal_view": int(reached[0]) + 1 if len(reached) else None,
            "miss_pp_at_stop": 100 * max(float(np.nan_to_num(outside[stop], nan=-1.0)), 0.0),
            "worst_miss_pp": 100 * max(float(np.nanmax(outside, initial=-1.0)), 0.0),
            "worst_over_pp": 100 * max(float(np.nanmax(over, initial=-1.0)), 0.0),
            "refused_views": int(np.isnan(mean).sum())}


def score(rollouts: Path, estimator: CoverageEstimator, config: Config) -> None:
    """Replay the three rules on every episode of a table of rollouts; write `NAME-stops.csv`
    and `NAME-stops.md` beside it (NAME its stem)."""
    data = read_dataset(rollouts)
    with rollouts.open(newline="") as stream:
        keys = [(row["object"], row["seed"], row["planner"], row["episode"])
                for row in csv.DictReader(stream)]
    goal = config.env.coverage_goal
    z = NormalDist().inv_cdf(CONFIDENCE)
    rows = []
    for key in dict.fromkeys(keys):
        mask = np.array([other == key for other in keys])
        features, truth = data.features[mask], data.coverage[mask]
        before = estimator.estimate(features)
        # The tracker takes the planner's class name (`uniform` for `uniform8`).
        tracker = EstimateTracker(estimator, config, key[2].rstrip("0123456789"))
        stated = [tracker.update(vector) for vector in features]
        after = (np.array([one.mean for one in stated]), np.array([one.std for one in stated]))
        held = np.array([one.held is not None for one in stated])
        for rule, (mean, std), holds in (("before", before, None), ("after", after, None),
                                         ("held", after, held)):
            rows.append({"part": Path(key[0]).stem, "seed": key[1], "planner": key[2],
                         "rule": rule, **replay(mean, std, truth, goal, z, holds)})
    columns = list(rows[0])
    write_text(rollouts.with_name(f"{rollouts.stem}-stops.csv"), csv_text(columns, rows))
    write_text(rollouts.with_name(f"{rollouts.stem}-stops.md"), table(rows, goal))


def table(rows: list[dict[str, Any]], goal: float) -> str:
    """Per planner and rule: episodes, stops on the estimate, false stops, bad misses."""
    lines = ["| planner | rule | episodes | stopped on the estimate | false stops (below the goal) "
             "| worst false stop pp | interval misses truth by > 3 pp at stop | worst miss at "
             "stop pp | episodes with an interval above the truth by > 3 pp, any view (worst pp) "
             "| with one excluding it by > 3 pp, any view | mean views at stop | mean views to the "
             "goal (true) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for planner in dict.fromkeys(row["planner"] for row in rows):
        for rule in ("before", "after", "held"):
            chosen = [row for row in rows if row["planner"] == planner and row["rule"] == rule]
            stopped = [row for row in chosen if row["stopped_on_estimate"]]
            false = [row for row in stopped if row["below_goal"]]
            worst = max((100 * (goal - row["truth_at_stop"]) for row in false), default=0.0)
            missed = [row for row in stopped if row["miss_pp_at_stop"] > MISS_PP]
            misses = max((row["miss_pp_at_stop"] for row in stopped), default=0.0)
            reached = [row["goal_view"] for row in chosen if row["goal_view"] is not None]
            lines.append(
                f"| {planner} | {rule} | {len(chosen)} | {len(stopped)} | {len(false)} "
                f"({100 * len(false) / len(chosen):.0f} %) | {worst:.1f} | {len(missed)} | "
                f"{misses:.1f} | {sum(row['worst_over_pp'] > MISS_PP for row in chosen)} "
                f"({max(row['worst_over_pp'] for row in chosen):.1f}) | "
                f"{sum(row['worst_miss_pp'] > MISS_PP for row in chosen)} | "
                f"{np.mean([row['stop_view'] for row in chosen]):.2f} | "
                f"{np.mean(reached) if reached else float('nan'):.2f} ({len(reached)} reach it) |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("step", choices=("rollouts", "score", "list"))
    parser.add_argument("--folder", type=Path, default=FOLDER,
                        help="rollouts: the folder of the parts and of rollouts.csv")
    parser.add_argument("--rollouts", type=Path, nargs="+", default=None,
                        help="score: tables of rollouts (default: FOLDER/rollouts.csv)")
    parser.add_argument("--planners", nargs="+", default=list(PLANNERS))
    parser.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    parser.add_argument("--estimator", type=Path, default=None,
                        help="an estimator.npz (default: the bundled one)")
    parser.add_argument("--config", default=None,
                        help="list: the config whose episodes to draw (default: the default)")
    parser.add_argument("--out", type=Path, default=None,
                        help="list: the episode list (default: FOLDER/FOLDER.json)")
    args = parser.parse_args()
    if args.step == "list":
        config = load_config(args.config) if args.config else Config()
        specs = episode_list(config, sorted(args.folder.glob("*.stl")), args.seeds, SCALE)
        print(write_episode_list(args.out or args.folder / f"{args.folder.name}.json", specs))
    elif args.step == "rollouts":
        rollouts(args.folder, tuple(args.planners), tuple(args.seeds))
    else:
        for table_path in args.rollouts or [args.folder / "rollouts.csv"]:
            score(table_path, load_estimator(args.estimator), Config())


if __name__ == "__main__":
    main()
