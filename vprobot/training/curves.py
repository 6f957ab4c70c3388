"""Training curves (the paper's Fig. 6): coverage, acquisitions, reward and travel per episode,
the mean over runs with a min/max band (`vprobot curves RUN_DIR...`)."""

from __future__ import annotations

import csv
import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vprobot.config import read_yaml
from vprobot.files.atomic import read_text, save_figure

PANELS = (("coverage", "coverage at episode end", 100.0, "%"),
          ("acquisitions", "acquisitions per episode", 1.0, ""),
          ("r", "episode reward", 1.0, ""),
          ("travel_sum", "travel between views per episode", 1.0, ""))


class NoEpisodesError(ValueError):
    """A run has not finished an episode yet: there is nothing to plot."""


def _whole_lines(path: Path) -> list[str]:
    """The lines of a file a running training may be appending to, a last one cut short
    dropped."""
    text = read_text(path)
    return text.splitlines() if text.endswith("\n") else text.splitlines()[:-1]


def read_monitor(run_dir: Path) -> dict[str, np.ndarray]:
    """The per-episode columns of a run's `monitor.csv` (and `monitor_<rank>.monitor.csv` of
    parallel envs, interleaved episode by episode); read-only, so a running run can be read.

    Raises:
        ValueError: If the run has no monitor file.
    """
    files = sorted(run_dir.glob("monitor*.csv"))
    if not files:
        raise ValueError(f"{run_dir} has no monitor.csv: is it a training run?")
    # The first line of a monitor file is its JSON header. (Its time column restarts with each
    # resumed session, so episodes are kept in file order.)
    per_env = [list(csv.DictReader(_whole_lines(path)[1:])) for path in files]
    rows = [row for group in itertools.zip_longest(*per_env) for row in group if row is not None]
    return {key: np.array([float(row[key]) for row in rows]) for key in rows[0]} if rows else {}


def travel_column(run_dir: Path) -> tuple[str, str]:
    """Which travel to plot: joint time with the robot, the paper's approximation without."""
    config = read_yaml(run_dir / "config.yaml") if (run_dir / "config.yaml").is_file() else {}
    free = (config.get("env") or {}).get("carrier") == "free"
    return ("travel_sum_paper", "m") if free else ("travel_sum_joint_time", "s")


def smooth(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving average (shorter at the start)."""
    sums = np.cumsum(np.insert(values, 0, 0.0))
    index = np.arange(1, len(values) + 1)
    start = np.maximum(index - window, 0)
    return (sums[index] - sums[start]) / (index - start)


def plot_curves(run_dirs: Sequence[str | Path], out: str | Path, window: int = 50) -> Path:
    """Plot the runs' curves into a PNG (mean over runs, band from min to max).

    Runs are cut to the shortest one; each curve is a trailing mean over `window` episodes.

    Raises:
        NoEpisodesError: If a run has no finished episode yet.
        ValueError: For no runs, a run without a monitor file, or a window < 1.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not run_dirs:
        raise ValueError("curves need at least one run directory")
    if window < 1:
        raise ValueError(f"window must be >= 1, got {window}")
    runs = [Path(run) for run in run_dirs]
    monitors = [read_monitor(run) for run in runs]
    empty = [str(run) for run, monitor in zip(runs, monitors, strict=True) if not monitor]
    if empty:
        raise NoEpisodesError(f"no finished episodes yet in {', '.join(empty)}")
    travel, unit = travel_column(runs[0])
    length = min(len(monitor["r"]) for monitor in monitors)
    figure, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    episodes = np.arange(1, length + 1)
    for axis, (key, title, factor, label) in zip(axes.ravel(), PANELS, strict=True):
        column = travel if key == "travel_sum" else key
        curves = np.array([smooth(monitor[column][:length], window) * factor
                           for monitor in monitors])
        axis.plot(episodes, curves.mean(axis=0), color="tab:blue")
        if len(curves) > 1:
            axis.fill_between(episodes, curves.min(axis=0), curves.max(axis=0),
                              color="tab:blue", alpha=0.25, linewidth=0)
        axis.set_title(title)
        axis.set_ylabel(unit if key == "travel_sum" else label)
        axis.grid(alpha=0.3)
    for axis in axes[1]:
        axis.set_xlabel("episode")
    return save_figure(figure, out, f"{len(runs)} run(s): mean"
                       + (", min-max band" if len(runs) > 1 else "")
                       + f"; trailing mean over {window} episodes")
