"""`vprobot train PROFILE --seeds 0 1 2 --out DIR`: one training run per seed, then the spread
over seeds.

Each seed is the run `vprobot train PROFILE --seed N --out DIR/seed-N` would make, followed by
its best model scored on the profile's test lists (`score_test_lists`). The seeds run one after
another in this process, or as Ray tasks (one CPU each) with `--workers` or `--address`, as the
trials of `vprobot sweep` do. Rerunning the same command goes on: a seed holding `result.json`
is not trained again, an interrupted one resumes from its checkpoint, and test lists resume by
episode. `DIR/seeds.md` and `DIR/seeds.csv` hold the mean and min-max over seeds of the
validation score of each seed's best model and of every test list.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import os
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vprobot.compute.cluster import parallel_map, require_ray
from vprobot.config import Config
from vprobot.episode import read_episode_list
from vprobot.episode.specs import bundled_episode_list
from vprobot.files.atomic import csv_text, read_text, write_text
from vprobot.training.runs import RESULT_FILE, best_validation

VALIDATION = "validation"
"""The name of the validation row of the summary (the test rows are named by their lists)."""
METRICS = (("coverage_pct", "coverage %", 1), ("acquisitions", "acquisitions", 2),
           ("success_pct", "success %", 0), ("area_pct", "area %", 1),
           ("views_to_goal", "views to goal", 2))
"""(column of `vprobot evaluate`'s evaluation.csv, heading, digits shown) of the summary."""


def seed_dir(out: Path, seed: int) -> Path:
    """The run directory of `seed` in the folder `out`."""
    return out / f"seed-{seed}"


def tested(run_dir: Path, test_lists: Sequence[str]) -> bool:
    """Whether every test list's table in `run_dir/test/` covers all of the list's episodes
    (an interrupted evaluation writes its table of the episodes it finished)."""
    for name in test_lists:
        table = run_dir / "test" / name / "evaluation.csv"
        if not table.is_file():
            return False
        scored = sum(int(row["episodes"])
                     for row in csv.DictReader(read_text(table).splitlines()))
        if scored < len(read_episode_list(bundled_episode_list(name))):
            return False
    return True


def finished(config: Config, run_dir: Path) -> bool:
    """Whether a seed's training and test lists are done."""
    return (run_dir / RESULT_FILE).is_file() and tested(run_dir, config.agent.test_lists or ())


def run_seed(config: Config, seed: int, run_dir: Path, argv: Sequence[str],
             device: str | None = None, progress: bool = False) -> dict[str, float]:
    """One seed (in this process or a Ray worker): train or resume unless finished, then score
    the test lists (`evaluate` skips the episodes already scored).

    Returns:
        The best validation row of the run (`best_validation`).
    """
    # Imported here: training needs torch and stable-baselines3; the seeds table does not.
    from vprobot.training.train import score_test_lists, train_to_result

    if not (run_dir / RESULT_FILE).is_file():
        train_to_result(lambda: config, run_dir, seed, argv, device, progress)
    score_test_lists(config, run_dir, progress=progress)
    return best_validation(run_dir, config.agent.select)


def list_scores(run_dir: Path, name: str) -> dict[str, float]:
    """The best model's scores on a test list that `tested` found complete (its row of the
    list's `evaluation.csv`; views to goal missing when no episode reached the goal)."""
    path = run_dir / "test" / name / "evaluation.csv"
    row = next(csv.DictReader(read_text(path).splitlines()))
    return {key: float(row[key]) for key, _, _ in METRICS if row[key]}


def spread(per_seed: dict[int, dict[str, float]]) -> dict[str, Any]:
    """Mean, min and max over seeds of every metric (of the seeds that have it: views to goal is
    missing for a seed none of whose episodes reached the goal)."""
    row: dict[str, Any] = {"seeds": " ".join(map(str, per_seed)), "runs": len(per_seed)}
    for key, _, _ in METRICS:
        column = [scores[key] for scores in per_seed.values() if key in scores]
        if column:
            row[key] = statistics.fmean(column)
            row[f"{key}_min"], row[f"{key}_max"] = min(column), max(column)
    return row


def seeds_table(config: Config, out: Path, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """One row for the validation list and one per test list: the spread over the seeds that
    have finished (training, and that test list)."""
    done = [seed for seed in seeds if (seed_dir(out, seed) / RESULT_FILE).is_file()]
    validation = {seed: best_validation(seed_dir(out, seed), config.agent.select)
                  for seed in done}
    table = [{"evaluation": VALIDATION, **spread(validation)}]
    for name in config.agent.test_lists or ():
        table.append({"evaluation": name, **spread(
            {seed: list_scores(seed_dir(out, seed), name) for seed in done
             if tested(seed_dir(out, seed), [name])})})
    return table


def write_summary(config: Config, out: Path, seeds: Sequence[int],
                  table: list[dict[str, Any]], command: Sequence[str]) -> None:
    """`seeds.csv` and `seeds.md` in `out` (marked partial while seeds are unfinished)."""
    columns = ["evaluation", "seeds", "runs"] + [f"{key}{suffix}" for key, _, _ in METRICS
                                                 for suffix in ("", "_min", "_max")]
    out.mkdir(parents=True, exist_ok=True)  # missing when interrupted before the first seed
    write_text(out / "seeds.csv", csv_text(columns, table))

    def cell(row: dict[str, Any], key: str, digits: int) -> str:
        if key not in row:
            return "-"
        return (f"{row[key]:.{digits}f} ({row[key + '_min']:.{digits}f}-"
                f"{row[key + '_max']:.{digits}f})")

    complete = sum(finished(config, seed_dir(out, seed)) for seed in seeds)
    partial = ([f"**Partial: {complete} of {len(seeds)} seeds; run the same command again "
                f"to finish.**", ""] if complete < len(seeds) else [])
    lines = [*partial, "# Training seeds", "",
             f"Seeds: {', '.join(map(str, seeds))}: one run per seed, "
             f"`{' '.join(command)} --seed <n> --out {out / 'seed-<n>'}`.", "",
             f"Mean (min-max) over seeds. `{VALIDATION}`: each seed's best model on the "
             f"validation list, as the evaluation that selected it during training scored it "
             f"(no area or views to goal there). The test lists: that best model scored once "
             f"after training (`seed-<n>/test/<list>/`). Views to goal: over the episodes that "
             f"reached the goal, of the seeds with any.", "",
             "| evaluation | seeds | " + " | ".join(title for _, title, _ in METRICS) + " |",
             "|---|---|" + "---|" * len(METRICS)]
    for row in table:
        lines.append(f"| {row['evaluation']} | {row['seeds'] or '-'} | " + " | ".join(
            cell(row, key, digits) for key, _, digits in METRICS) + " |")
    write_text(out / "seeds.md", "\n".join(lines) + "\n")


def _differences(config: Config, other: Config) -> list[str]:
    """The `section.key` names whose values differ between two configs."""
    return [f"{section.name}.{field.name}" for section in dataclasses.fields(config)
            for field in dataclasses.fields(getattr(config, section.name))
            if getattr(getattr(config, section.name), field.name)
            != getattr(getattr(other, section.name), field.name)]


def check_existing(config: Config, out: Path, seeds: Sequence[int]) -> None:
    """Refuse seed runs in `out` that were started with other settings than `config`.

    Raises:
        ValueError: Naming the run and the first setting that differs.
    """
    # Imported here: training needs torch and stable-baselines3; the seeds table does not.
    from vprobot.training.train import holds_run, load_run_config

    for seed in seeds:
        run_dir = seed_dir(out, seed)
        if holds_run(run_dir):
            differences = _differences(config, load_run_config(run_dir))
            if differences:
                raise ValueError(f"{run_dir} holds a run with another {differences[0]}; rerun "
                                 f"the command that started it to go on, or choose another --out")


def train_seeds(config: Config, out: str | Path, seeds: Sequence[int], command: Sequence[str],
                device: str | None = None, workers: int | None = None,
                address: str | None = None, progress: bool = True) -> list[dict[str, Any]]:
    """Train (or go on with) one run per seed and write the spread over seeds.

    Args:
        config: The resolved configuration of every seed.
        out: The folder of the seed runs (`seed-<n>/`) and the summary.
        seeds: The seeds, each once.
        command: The command line of one run without `--seed` and `--out` (each run records
            it with its own).
        device: Overrides `agent.device`.
        workers: Run the seeds as Ray tasks on a local Ray with this many CPUs.
        address: Run the seeds as Ray tasks on this Ray cluster.
        progress: Print a line per finished seed (and, in this process, the progress bars).

    On Ctrl-C (or SIGTERM via the CLI) the running seeds stop and the summary of the finished
    ones is written, marked partial, before the interrupt goes on.

    Returns:
        The summary rows (`seeds_table`).

    Raises:
        ValueError, ConfigError: For repeated seeds, runs in `out` of other settings, no Ray
            (with `workers` or `address`), or a config that does not train.
    """
    out = Path(out)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"--seeds {' '.join(map(str, seeds))}: give each seed once")
    check_existing(config, out, seeds)
    pending = [seed for seed in seeds if not finished(config, seed_dir(out, seed))]
    if progress:
        print(f"{len(seeds)} seeds, {len(seeds) - len(pending)} finished, {len(pending)} to run")
    items = [(config, seed, seed_dir(out, seed),
              [*command, "--seed", str(seed), "--out", str(seed_dir(out, seed))], device)
             for seed in pending]

    def report(seed: int, best: dict[str, float]) -> None:
        if progress:
            print(f"finished seed {seed}: best on validation (step {best['step']:.0f}) coverage "
                  f"{best['coverage_pct']:.1f} %, {best['acquisitions']:.2f} acquisitions")

    try:
        if workers is None and address is None:
            for item in items:
                report(item[1], run_seed(*item, progress=progress))
        elif items:
            require_ray()
            # Closed at once on an interrupt, so that the running seeds are cancelled before
            # the partial summary is written.
            with contextlib.closing(parallel_map(run_seed, items, workers or os.cpu_count() or 1,
                                                 address)) as results:
                for index, best in results:
                    report(pending[index], best)
    except KeyboardInterrupt:
        write_summary(config, out, seeds, seeds_table(config, out, seeds), command)
        print(f"saved the summary of the finished seeds in {out}; run the same command again "
              f"to finish (an unfinished seed goes on from its last checkpoint)",
              file=sys.stderr)
        raise
    table = seeds_table(config, out, seeds)
    write_summary(config, out, seeds, table, command)
    return table
