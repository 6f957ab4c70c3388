"""Leave-one-family-out: how wrong the coverage estimate is on a part family it never saw.

Each training family of the split is left out in turn: its rows are removed from both the
training and the validation rollouts, an estimator is fit on the rest as `stop fit` fits the
full one (same seed, same selection), and it estimates the left-out family's rows (training and
validation alike: it saw none of them). The pooled errors of the folds are what
`vprobot.stop_studies.calibration.unseen_scale` turns into the widening the estimate states for
any part, since a cell cannot tell whether its part is of a family the estimate knows. Motors
are never left out: they are the cell's own objects, present in every fold.

Each fold's estimator is kept in `out/folds/FAMILY.npz` and reused when present, so that a run
cut short goes on where it stopped (the caller removes the folder when the rollouts change).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vprobot.stop_studies.dataset import Dataset
from vprobot.stopping.estimator import CoverageEstimator, fit

FOLDS_DIR = "folds"
"""Subfolder of a `stop fit` folder holding the folds' estimators."""


@dataclasses.dataclass(frozen=True)
class FoldEstimates:
    """Each fold's estimate of its left-out family's rows, pooled over the folds.

    Attributes:
        mean: (n,) the estimated coverage.
        std: (n,) its stated standard deviation (no widening).
        disagreement: (n,) the variance of the fold's members' means.
        truth: (n,) the true coverage.
        views: (n,) views requested so far.
        families: (n,) the left-out family of the row's fold.
        planners: (n,) the planner of the row's episode.
    """

    mean: np.ndarray
    std: np.ndarray
    disagreement: np.ndarray
    truth: np.ndarray
    views: np.ndarray
    families: np.ndarray
    planners: np.ndarray


def fold_data(training: Dataset, validation: Dataset, family: str
              ) -> tuple[Dataset, Dataset, Dataset]:
    """One fold's rows: training and validation without `family`, and `family`'s rows of both
    (what the fold's estimator is scored on).

    Raises:
        ValueError: If `family` has no rows, or is all there is.
    """
    keep_training, keep_validation = training.families != family, validation.families != family
    left_out = np.concatenate([training.families, validation.families]) == family
    if not left_out.any() or keep_training.all() or not keep_training.any():
        raise ValueError(f"cannot leave out family {family!r}: it has no rows or is all there is")
    both = Dataset(*(np.concatenate([getattr(training, field.name), getattr(validation,
                                                                            field.name)])
                     for field in dataclasses.fields(Dataset)))
    return training.select(keep_training), validation.select(keep_validation), both.select(
        left_out)


def family_folds(training: Dataset, validation: Dataset, families: Sequence[str],
                 names: Sequence[str], seed: int = 0, out_dir: str | Path | None = None,
                 progress: bool = True, **fit_options: int) -> FoldEstimates:
    """Fit one estimator per left-out family (or read it from `out_dir/folds/`) and pool their
    estimates of the families they never saw.

    Args:
        training: The training rollouts.
        validation: The validation rollouts (early stopping).
        families: The families to leave out in turn.
        names: The feature names.
        seed: Seeds each fold's networks, as the full fit's.
        out_dir: Where the folds' estimators are kept; None keeps nothing.
        progress: Show a progress bar.
        **fit_options: Passed on to `fit` (members, hidden, steps).

    Raises:
        ValueError: If a family has no rows, or a kept estimator cannot be read.
    """
    folder = Path(out_dir) / FOLDS_DIR if out_dir is not None else None
    parts: list[FoldEstimates] = []
    for family in tqdm(families, desc="family folds", disable=not progress):
        fit_rows, check_rows, left_out = fold_data(training, validation, family)
        path = folder / f"{family}.npz" if folder is not None else None
        if path is not None and path.is_file():
            estimator = CoverageEstimator.load(path)
        else:
            estimator = fit(fit_rows.features, fit_rows.coverage, check_rows.features,
                            check_rows.coverage, names, seed, **fit_options)
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                estimator.save(path)
        mean, variance, disagreement = estimator.mixture(left_out.features)
        parts.append(FoldEstimates(mean, np.sqrt(variance), disagreement, left_out.coverage,
                                   left_out.views,
                                   left_out.families, left_out.planners))
    return FoldEstimates(*(np.concatenate([getattr(part, field.name) for part in parts])
                           for field in dataclasses.fields(FoldEstimates)))
