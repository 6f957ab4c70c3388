"""Greedy set cover on a visibility matrix, optionally confirming rows before picking them.

A candidate's row says which points it sees. Each step picks the candidate adding the most
uncovered points. Model-based planners know the rows only approximately (a coarse prediction
for hundreds of candidates); with `confirm`, a row is replaced by its exact value (a simulated
acquisition) before the candidate may be picked, and the step is re-run on the corrected
matrix. Only a few rows per step need confirming — those that rank first — so the picks are
those of the exact greedy whenever the prediction ranks the true best near the top.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt


def cover_input(visibility: npt.ArrayLike, covered: npt.ArrayLike,
                count: int) -> tuple[np.ndarray, np.ndarray]:
    """Copies of a set-cover instance's visibility (candidates, points) and covered (points,)
    as booleans, checked.

    Raises:
        ValueError: If the shapes disagree or count < 0.
    """
    rows = np.array(visibility, dtype=bool)
    covered = np.array(covered, dtype=bool)
    if rows.ndim != 2 or covered.shape != (rows.shape[1],):
        raise ValueError(f"visibility (candidates, points) and covered (points,) disagree: "
                         f"{rows.shape} and {covered.shape}")
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    return rows, covered


def greedy_cover(visibility: np.ndarray, covered: np.ndarray, count: int,
                 goal: float | None = None,
                 confirm: Callable[[int], np.ndarray] | None = None,
                 allowed: Callable[[int], bool] | None = None,
                 confirmations: int | None = None) -> tuple[list[int], list[int]]:
    """Pick up to `count` rows of `visibility`, each adding the most uncovered points.

    Args:
        visibility: Which points each candidate sees (candidates, points); not modified.
        covered: Points covered before the first pick (points,).
        count: Largest number of picks.
        goal: Stop once this fraction of the points is covered (None: make `count` picks).
        confirm: The exact row of a candidate; called at most once per candidate, before it
            is picked.
        allowed: Whether a candidate may be picked at all; asked before confirming it.
        confirmations: Rows confirmed per pick before settling for the best confirmed row (None:
            no limit; confirming goes on while no confirmed row adds anything).

    Returns:
        The picked rows and the points each added. Without `confirm` the gains are
        non-increasing (coverage is submodular). Picking stops early when no candidate adds
        anything.

    Raises:
        ValueError: If the shapes disagree or count < 0.
    """
    rows, covered = cover_input(visibility, covered, count)
    needed = math.ceil(goal * len(covered) - 1e-9) if goal is not None else None
    confirmed = np.zeros(len(rows), dtype=bool) if confirm is not None else np.ones(len(rows),
                                                                                   dtype=bool)
    excluded = np.zeros(len(rows), dtype=bool)
    picks: list[int] = []
    gains: list[int] = []
    spent = 0
    while len(picks) < count and (needed is None or covered.sum() < needed):
        added = np.count_nonzero(rows & ~covered, axis=1)
        added[excluded] = 0
        if confirmations is not None and spent >= confirmations:
            # Budget spent: the best confirmed row, unless none of them adds anything.
            confirmed_added = np.where(confirmed, added, 0)
            if confirmed_added.max() > 0:
                added = confirmed_added
        best = int(np.argmax(added))
        if added[best] == 0:
            break
        if allowed is not None and not allowed(best):
            excluded[best] = True
            continue
        if not confirmed[best] and confirm is not None:
            rows[best] = confirm(best)
            confirmed[best] = True
            spent += 1
            continue
        spent = 0
        picks.append(best)
        gains.append(int(added[best]))
        covered |= rows[best]
        excluded[best] = True
    return picks, gains
