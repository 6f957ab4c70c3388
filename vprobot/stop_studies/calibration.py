"""Whether an estimate's stated uncertainty matches its observed error, and its error per view.

A Gaussian estimate (mean, std) is calibrated when the truth lies within mean +- z(p) std in a
share p of the cases, for every level p (z(p) the two-sided normal quantile), and when cases
stated with a larger std show a proportionally larger error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from statistics import NormalDist

import numpy as np

from vprobot.files.atomic import save_figure

LEVELS = (0.5, 0.68, 0.8, 0.9, 0.95)
"""Stated interval levels the calibration table reports."""
UNSEEN_LEVEL = 0.95
"""The two-sided level whose interval the widening for an unseen family makes hold."""


def two_sided_z(level: float) -> float:
    """The two-sided normal quantile of a level."""
    return NormalDist().inv_cdf(0.5 + level / 2.0)


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
    z = np.array([two_sided_z(level) for level in levels])
    error = np.abs(np.asarray(truth) - np.asarray(mean)) / np.asarray(std)
    return (error[None, :] <= z[:, None]).mean(axis=1)


def needed_variance(mean: np.ndarray, std: np.ndarray, truth: np.ndarray,
                    level: float = UNSEEN_LEVEL) -> np.ndarray:
    """Per case, the variance to add to the stated one for the two-sided interval of the level
    to hold the truth: (e^2 / z^2 - std^2), at least 0 (e the error, z the level's quantile)."""
    error = np.asarray(truth) - np.asarray(mean)
    return np.maximum(error ** 2 / two_sided_z(level) ** 2 - np.asarray(std) ** 2, 0.0)


def least_holding(needed: np.ndarray, level: float = UNSEEN_LEVEL) -> float:
    """The least value that is at least what a share `level` of the cases need."""
    # "inverted_cdf": the least value that holds at least `level` of the cases; the case at
    # the quantile lies on the interval's edge, which rounding must not move out.
    return float(np.quantile(needed, level, method="inverted_cdf")) * (1.0 + 1e-9)


def unseen_scale(mean: np.ndarray, std: np.ndarray, disagreement: np.ndarray,
                 truth: np.ndarray, level: float = UNSEEN_LEVEL) -> float:
    """The least factor c such that the two-sided interval of the level, with c times the
    ensemble's disagreement added to the stated variance, holds the truth in at least a share
    `level` of the cases.

    A case is held once c reaches `needed_variance` / disagreement, so c is the `level`
    quantile of that over the cases (at least 0: an interval that holds already is not
    narrowed).

    Args:
        mean, std, truth: The estimates, their stated std and the truth (n,).
        disagreement: (n,) the variance of the ensemble members' means.
        level: The two-sided level, in (0, 1).

    Raises:
        ValueError: For a level outside (0, 1), no cases, or too many cases that no factor
            holds (missed with no disagreement at all).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"the level must lie in (0, 1), got {level}")
    if len(truth) == 0:
        raise ValueError("no cases to widen the estimate on")
    needed = needed_variance(mean, std, truth, level)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(needed > 0.0, needed / np.asarray(disagreement), 0.0)
    scale = least_holding(factor, level)
    if not np.isfinite(scale):
        raise ValueError(f"no factor on the disagreement holds {100 * level:g} % of the cases")
    return scale


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


def plot_reliability(series: Mapping[str, tuple[np.ndarray, np.ndarray]], path: Path,
                     title: str, levels: Sequence[float] = LEVELS) -> Path:
    """Two panels into a PNG (atomically), one line per series (its stated std and its
    absolute error, (n,) each): stated std against the observed RMS error per bin, and the
    stated interval levels against the observed shares within them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4.4))
    top = 0.0
    for label, (std, error) in series.items():
        rows = reliability(std, error)
        stated = [100.0 * row[0] for row in rows]
        left.plot(stated, [100.0 * row[1] for row in rows], marker="o", label=label)
        top = max(top, *stated, *(100.0 * row[1] for row in rows))
        observed = interval_coverage(np.zeros(len(error)), std, error, levels)
        right.plot([100 * level for level in levels], [100 * share for share in observed],
                   marker="o", label=label)
    left.plot([0, 1.1 * top], [0, 1.1 * top], color="black", linestyle="--", linewidth=1,
              label="calibrated")
    left.set_xlabel("stated std (pp), bins of equal counts")
    left.set_ylabel("observed RMS error (pp)")
    right.plot([0, 100], [0, 100], color="black", linestyle="--", linewidth=1,
               label="calibrated")
    right.set_xlabel("stated interval level (%)")
    right.set_ylabel("truth within the interval (%)")
    for axis in (left, right):
        axis.legend(fontsize=8)
        axis.grid(alpha=0.3)
    return save_figure(figure, path, title)
