"""Whether an estimate's stated uncertainty matches its observed error, and its error per view.

A Gaussian estimate (mean, std) is calibrated when the truth lies within mean +- z(p) std in a
share p of the cases, for every level p (z(p) the two-sided normal quantile), and when cases
stated with a larger std show a proportionally larger error.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from statistics import NormalDist

import numpy as np

from vprobot.files import save_figure

LEVELS = (0.5, 0.68, 0.8, 0.9, 0.95)
"""Stated interval levels the calibration table reports."""


def interval_coverage(mean: np.ndarray, std: np.ndarray, truth: np.ndarray,
                      levels: Sequence[float] = LEVELS) -> np.ndarray:
    """The share of cases whose truth lies within each level's two-sided interval.

    Raises:
        ValueError: For a level outside (0, 1) or no cases.
    """
    if len(truth) == 0:
        raise ValueError("no cases to check the calibration on")
    if any(not 0.0 < level < 1.0 for level in levels):
        raise ValueError(f"interval levels must lie in (0, 1), got {list(levels)}")
    z = np.array([NormalDist().inv_cdf(0.5 + level / 2.0) for level in levels])
    error = np.abs(np.asarray(truth) - np.asarray(mean)) / np.asarray(std)
    return (error[None, :] <= z[:, None]).mean(axis=1)


def mae_per_view(mean: np.ndarray, truth: np.ndarray, views: np.ndarray
                 ) -> list[tuple[int, float, int]]:
    """(view count, mean absolute error, cases) for every view count present, in order."""
    error = np.abs(np.asarray(truth) - np.asarray(mean))
    return [(int(view), float(error[views == view].mean()), int((views == view).sum()))
            for view in np.unique(views)]


def reliability(std: np.ndarray, error: np.ndarray, bins: int = 8
                ) -> list[tuple[float, float, int]]:
    """(mean stated std, root-mean-square observed error, cases) per bin of equal counts of the
    stated std; a calibrated estimate has the two equal."""
    order = np.argsort(std, kind="stable")
    return [(float(np.mean(std[part])), float(np.sqrt(np.mean(error[part] ** 2))), len(part))
            for part in np.array_split(order, bins) if len(part)]


def plot_reliability(std: np.ndarray, error: np.ndarray, observed: Sequence[float],
                     path: Path, title: str, levels: Sequence[float] = LEVELS) -> Path:
    """Two panels into a PNG (atomically): stated std against the observed RMS error per bin,
    and the stated interval levels against the observed shares within them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = reliability(std, error)
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4.4))
    stated = [100.0 * row[0] for row in rows]
    left.plot(stated, [100.0 * row[1] for row in rows], marker="o", label="estimate")
    top = max(max(stated), max(100.0 * row[1] for row in rows)) * 1.1
    left.plot([0, top], [0, top], color="black", linestyle="--", linewidth=1, label="calibrated")
    left.set_xlabel("stated std (pp), bins of equal counts")
    left.set_ylabel("observed RMS error (pp)")
    left.legend()
    left.grid(alpha=0.3)
    right.plot([100 * level for level in levels], [100 * share for share in observed],
               marker="o", label="estimate")
    right.plot([0, 100], [0, 100], color="black", linestyle="--", linewidth=1,
               label="calibrated")
    right.set_xlabel("stated interval level (%)")
    right.set_ylabel("truth within the interval (%)")
    right.legend()
    right.grid(alpha=0.3)
    return save_figure(figure, path, title)
