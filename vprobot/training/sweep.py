"""`vprobot sweep STUDY.yaml`: a study of agent configurations, one `vprobot train` run per
(configuration, seed), on Ray; resumable; one table and a curves PNG per configuration.

A study file (`configs/studies/*.yaml`):

```yaml
profile: cpu.yaml             # in configs/agents/, or a path
steps: 20000                  # optional: overrides agent.total_steps
seeds: [0, 1, 2]
set: [agent.eval_freq=5000]   # optional: overrides of every trial
grid:                         # every combination is a configuration
  env.state: [s_cov, s_bin]
  agent.algorithm: [sac, ppo]
note: what the study asks    # optional, printed with the table
```

Ray core rather than Ray Tune: a trial is already a complete, resumable `train` run with its own
evaluation and checkpoints, so all a study needs is one CPU per trial and a place to run it;
Tune's schedulers and its own checkpointing would duplicate what `train` does. A trial is
finished when its run directory holds `result.json`; `--resume` runs the unfinished ones (from
their checkpoints).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from vprobot.compute.cluster import parallel_map, require_ray
from vprobot.config import ConfigError, read_yaml
from vprobot.files.atomic import csv_text, write_text
from vprobot.files.paths import PROFILES_DIR, bundled_or_path
from vprobot.training.curves import plot_curves, read_monitor, travel_column
from vprobot.training.runs import RESULT_FILE, read_result

CONVERGED_EPISODES = 100
"""The converged state: the last this many training episodes (as the paper reports)."""
STUDY_KEYS = {"profile", "steps", "seeds", "set", "grid", "note"}


@dataclasses.dataclass(frozen=True)
class Trial:
    """One training run of a study.

    Attributes:
        configuration: The configuration's name, e.g. `env.state=s_bin,agent.algorithm=ppo`.
        overrides: The trial's `section.key=value` overrides (study-wide ones first).
        seed: The run's seed.
        run_dir: Where the run lives.
    """

    configuration: str
    overrides: tuple[str, ...]
    seed: int
    run_dir: Path

    @property
    def finished(self) -> bool:
        return (self.run_dir / RESULT_FILE).is_file()


@dataclasses.dataclass(frozen=True)
class Study:
    """A parsed study file."""

    profile: Path
    steps: int | None
    seeds: tuple[int, ...]
    overrides: tuple[str, ...]
    grid: dict[str, list[Any]]
    note: str

    def configurations(self) -> list[tuple[str, tuple[str, ...]]]:
        """(name, overrides) of every grid point, in grid order."""
        keys = list(self.grid)
        points = []
        for values in itertools.product(*(self.grid[key] for key in keys)):
            pairs = [f"{key}={_yaml_value(value)}" for key, value in zip(keys, values,
                                                                           strict=True)]
            points.append((",".join(pairs) or "base", tuple(pairs)))
        return points

    def trials(self, out: Path) -> list[Trial]:
        return [Trial(name, (*self.overrides, *pairs), seed,
                      out / _slug(name) / f"seed{seed}")
                for name, pairs in self.configurations() for seed in self.seeds]


def _yaml_value(value: Any) -> str:
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_=." else "_" for c in name.replace(",", "__"))


def read_study(path: str | Path) -> Study:
    """Parse and check a study file (every trial's config is validated before any runs).

    Raises:
        FileNotFoundError, ConfigError: For a missing file or a bad key or value.
    """
    # Imported here: training needs torch and stable-baselines3; reading a study does not.
    from vprobot.training.train import profile_config

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"study file not found: {path}")
    data = read_yaml(path) or {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a study is a mapping with {sorted(STUDY_KEYS)}")
    unknown = sorted(set(data) - STUDY_KEYS)
    if unknown:
        raise ConfigError(f"{path}: unknown study key {unknown[0]!r}; allowed: "
                          f"{', '.join(sorted(STUDY_KEYS))}")
    try:
        profile = bundled_or_path(str(data.get("profile", "cpu.yaml")),
                                  {path.name: path for path in sorted(PROFILES_DIR.glob("*.yaml"))},
                                  "agent profile")
    except ValueError as error:
        raise ConfigError(f"{path}: profile: {error}") from None
    seeds = data.get("seeds", [0])
    if not isinstance(seeds, list) or not seeds or not all(
            isinstance(seed, int) and seed >= 0 for seed in seeds):
        raise ConfigError(f"{path}: seeds must be a non-empty list of integers >= 0, got "
                          f"{seeds!r}")
    grid = data.get("grid") or {}
    if not isinstance(grid, dict):
        raise ConfigError(f"{path}: grid must map section.key to a non-empty list of values, "
                          f"got {_yaml_value(grid)}")
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(f"{path}: grid {key} must be a non-empty list of values, e.g. "
                              f"[sac, ppo]; got {_yaml_value(values)}")
    steps = data.get("steps")
    if steps is not None and (not isinstance(steps, int) or steps < 1):
        raise ConfigError(f"{path}: steps must be an integer >= 1, got {steps!r}")
    overrides = data.get("set") or []
    # A mapping (`set: {agent.eval_freq: 5000}`) or list items written as `- key: value` would
    # otherwise reach the config as keys without values.
    bad = ([item for item in overrides if not isinstance(item, str) or "=" not in item]
           if isinstance(overrides, list) else [overrides])
    if bad:
        raise ConfigError(f"{path}: set must be a list of section.key=value, e.g. "
                          f"set: [agent.eval_freq=5000]; got {_yaml_value(bad[0])}")
    study = Study(profile=profile, steps=steps, seeds=tuple(seeds), overrides=tuple(overrides),
                  grid=grid, note=str(data.get("note", "")))
    for name, pairs in study.configurations():
        try:
            profile_config(study.profile, [*study.overrides, *pairs], study.steps)
        except ConfigError as error:
            raise ConfigError(f"{path}: configuration {name}: {error}") from None
    return study


def run_trial(profile: Path, overrides: Sequence[str], steps: int | None, seed: int,
              run_dir: Path) -> dict[str, Any]:
    """One trial (in a Ray worker): train or resume, then write `result.json`."""
    # Imported here: training needs torch and stable-baselines3; reading a study does not.
    from vprobot.training.train import profile_config, train_to_result

    return train_to_result(lambda: profile_config(profile, overrides, steps), run_dir, seed,
                           ["vprobot", "train", str(profile), "--set", *overrides, "--seed",
                            str(seed)])


def converged(run_dir: Path) -> dict[str, float]:
    """Means over the run's last `CONVERGED_EPISODES` training episodes."""
    monitor = read_monitor(run_dir)
    travel, _ = travel_column(run_dir)
    last = slice(-CONVERGED_EPISODES, None)
    return {"train_coverage": float(np.mean(monitor["coverage"][last])),
            "train_acquisitions": float(np.mean(monitor["acquisitions"][last])),
            "train_reward": float(np.mean(monitor["r"][last])),
            "train_travel": float(np.mean(monitor[travel][last])),
            "train_reachable": float(np.mean(monitor["reachable_share"][last]))}


TABLE_KEYS = ("train_coverage", "train_acquisitions", "train_reward", "train_travel",
              "train_reachable", "coverage_pct", "acquisitions", "success_pct", "reachable_pct",
              "joint_time_s", "plan_ms_per_view", "wall_s")


def study_table(study: Study, out: Path) -> list[dict[str, Any]]:
    """Per configuration: mean, min and max over its finished seeds of the converged training
    indicators and the final evaluation on the validation episodes; curves PNG per configuration."""
    table = []
    for name, _ in study.configurations():
        runs = [trial.run_dir for trial in study.trials(out)
                if trial.configuration == name and trial.finished]
        row: dict[str, Any] = {"configuration": name, "seeds": len(runs)}
        if runs:
            values = [{**converged(run), **read_result(run)}
                      for run in runs]
            for key in TABLE_KEYS:
                # Without the robot the joint-space figures and reachability are None.
                column = [float(value[key]) for value in values if value[key] is not None]
                if not column:
                    continue
                row[key] = statistics.fmean(column)
                row[f"{key}_min"], row[f"{key}_max"] = min(column), max(column)
            plot_curves(runs, out / _slug(name) / "curves.png")
        table.append(row)
    return table


def write_table(study: Study, out: Path, table: list[dict[str, Any]]) -> None:
    """`study.csv` and `study.md` in `out` (marked partial while trials are unfinished)."""
    columns = ["configuration", "seeds"] + [f"{key}{suffix}" for key in TABLE_KEYS
                                            for suffix in ("", "_min", "_max")]
    out.mkdir(parents=True, exist_ok=True)  # missing when interrupted before the first trial
    write_text(out / "study.csv", csv_text(columns, table))

    def cell(row: dict[str, Any], key: str, scale: float = 1.0, digits: int = 1) -> str:
        if key not in row:
            return "-"
        return (f"{row[key] * scale:.{digits}f} ({row[key + '_min'] * scale:.{digits}f}-"
                f"{row[key + '_max'] * scale:.{digits}f})")

    steps = study.steps if study.steps is not None else "the profile's"
    finished, total = sum(row["seeds"] for row in table), len(study.trials(out))
    partial = ([f"**Partial: {finished} of {total} trials; run the same sweep with --resume to "
                f"finish.**", ""] if finished < total else [])
    lines = [*partial, f"# Study: {study.profile.name}", "",
             *([study.note, ""] if study.note else []),
             f"Trials: {len(study.configurations())} configurations x {len(study.seeds)} seed(s) "
             f"({', '.join(map(str, study.seeds))}), {steps} steps each. The paper: 75 000 "
             f"steps, 3 runs per configuration. Mean (min-max) over seeds. Converged: the last "
             f"{CONVERGED_EPISODES} training episodes. Evaluation: the final model, "
             f"deterministic, on the validation episodes of its training sources (the split of "
             f"`env.split`, v1 unless set).", "",
             "| configuration | seeds | train coverage % | train acquisitions | eval coverage % "
             "| eval acquisitions | eval success % | reachable % | joint time s | ms per view "
             "| wall min |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in table:
        lines.append(" | ".join([
            f"| {row['configuration']}", str(row["seeds"]), cell(row, "train_coverage", 100),
            cell(row, "train_acquisitions", 1, 2), cell(row, "coverage_pct"),
            cell(row, "acquisitions", 1, 2), cell(row, "success_pct", 1, 0),
            cell(row, "reachable_pct", 1, 0), cell(row, "joint_time_s", 1, 2),
            cell(row, "plan_ms_per_view", 1, 1), cell(row, "wall_s", 1 / 60, 1)]) + " |")
    write_text(out / "study.md", "\n".join(lines) + "\n")


def sweep(study_path: str | Path, out: str | Path, resume: bool = False,
          address: str | None = None, workers: int | None = None,
          progress: bool = True) -> list[dict[str, Any]]:
    """Run a study's unfinished trials on Ray and write its table.

    Args:
        study_path: The study file.
        out: The study's folder (a run directory per trial below it).
        resume: Go on with a study already in `out` (finished trials are not rerun).
        address: A Ray cluster; a local Ray when None.
        workers: CPUs of the local Ray (default: all of this machine's).
        progress: Print a line per finished trial.

    On Ctrl-C (or SIGTERM via the CLI) the running trials are cancelled and the table of the
    finished ones is written, marked partial, before the interrupt goes on.

    Raises:
        ValueError, ConfigError: For a bad study, a folder that holds a study without
            `--resume`, or no Ray.
    """
    import os

    require_ray()
    study = read_study(study_path)
    out = Path(out)
    trials = study.trials(out)
    if not resume and any(trial.run_dir.exists() for trial in trials):
        raise ValueError(f"{out} already holds this study's runs; add --resume to go on with "
                         f"it, or choose another --out")
    pending = [trial for trial in trials if not trial.finished]
    if progress:
        print(f"{len(trials)} trials, {len(trials) - len(pending)} finished, "
              f"{len(pending)} to run")
    items = [(study.profile, trial.overrides, study.steps, trial.seed, trial.run_dir)
             for trial in pending]
    try:
        # Closed at once on an interrupt, so that the running trials are cancelled before the
        # partial table is written.
        with contextlib.closing(parallel_map(run_trial, items, workers or os.cpu_count() or 1,
                                             address)) as results:
            for index, result in results:
                if progress:
                    trial = pending[index]
                    print(f"finished {trial.configuration} seed {trial.seed}: coverage "
                          f"{result['coverage_pct']:.1f} %, {result['acquisitions']:.2f} "
                          f"acquisitions ({result['wall_s'] / 60:.1f} min)")
    except KeyboardInterrupt:
        table = study_table(study, out)
        write_table(study, out, table)
        finished = sum(row["seeds"] for row in table)
        print(f"saved {finished} of {len(trials)} trials in {out}; run it again with --resume "
              f"to finish (an unfinished trial goes on from its last checkpoint)",
              file=sys.stderr)
        raise
    table = study_table(study, out)
    write_table(study, out, table)
    return table
