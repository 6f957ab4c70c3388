"""How sure the model-free estimate may be that the goal is reached: a calibrated probability
P(coverage >= goal) after each view, and the threshold on it that bounds false stops.

- **The probability.** A conformal predictive system (crepes) over the estimate's errors on
  calibration views: the true coverage minus the estimate's mean, in units of its stated std
  (normalised residuals). It turns the mean and std stated after a view into a distribution of
  the coverage whose value at the goal is P(coverage < goal); for a new view drawn like the
  calibration views that value is uniform, so the probability is calibrated. It is Mondrian by
  the number of views taken (`VIEW_CATEGORIES`): the estimate errs differently after a few views
  than after many, and the count is known in a real cell (a part's family is not). A category
  with fewer than `MIN_PER_CATEGORY` calibration views pools them all.
- **The threshold.** Learn-then-Test (Angelopoulos et al.; MAPIE's Hoeffding-Bentkus p-values
  and fixed-sequence testing): on calibration episodes the probability was not fitted on, every
  threshold of `THRESHOLDS`, the highest first, is tested for a risk of false stops (a run that
  stops at the first view whose probability reaches the threshold, below the goal) above
  `risk`; the lowest threshold whose test and those of every higher one reject is kept. With
  probability at least 1 - `delta` over the calibration draw, a run drawn like the calibration
  episodes ends in a false stop with probability at most `risk`.

- **Giving up.** Where the goal is out of reach, the probability stays low and a run would go
  on to the view budget. The rule gives up instead once the probability is below the threshold
  and the seen surface has stopped growing: each of the latest two acquisitions added less than
  a share of the occupied voxels (`quiet_share`, the `grid` rule's test). The share is chosen
  by Learn-then-Test too, on the same episodes and after the threshold: every share of
  `GIVE_UP_SHARES`, the smallest first, is tested for a risk of false give-ups (a run that gives
  up below the goal at a view from which it still reaches it) above `risk`; the largest share
  whose test and those of every smaller one reject is kept. A run that gives up may be at the
  goal already (the probability is not sure enough to say so): the surface has stopped growing
  either way, and further views are unlikely to change that.

These hold for parts drawn as the calibration episodes were, in the cell, sensing model and
estimate they were calibrated with (`Calibrated`); `GoalConfidence.mismatch` names any other.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import json
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from vprobot.config import Config
from vprobot.files.atomic import file_sha256, write_arrays
from vprobot.stopping.estimator import sensor_geometry
from vprobot.stopping.features import FEATURES

VIEW_CATEGORIES = (3, 6)
"""Upper ends of the Mondrian categories by views taken: 1-3, 4-6, 7 and more."""
MIN_PER_CATEGORY = 100
"""Calibration views a category needs to be calibrated on its own."""
THRESHOLDS = np.round(np.arange(0.999, 0.4995, -0.001), 3)
"""The thresholds Learn-then-Test tries, highest (fewest false stops) first."""
PLATEAU = 0.01
"""An episode's plateau: its first view within this of its highest coverage."""
GIVE_UP_SHARES = np.round(np.arange(0.0025, 0.1001, 0.0025), 4)
"""The shares of new occupied voxels under which Learn-then-Test tries giving up, smallest
(fewest give-ups) first."""
FORMAT = 1


def view_category(views: npt.ArrayLike) -> np.ndarray:
    """The Mondrian category of a view count (1 is the first view)."""
    return np.searchsorted(np.asarray(VIEW_CATEGORIES), np.asarray(views), side="left")


@dataclasses.dataclass(frozen=True)
class Calibrated:
    """What a calibration holds for: the cell's robot, the sensor's sensing model and
    geometry, the coverage goal and the estimator file (its SHA-256)."""

    robot: str
    sensing: str
    sensor: tuple[float, ...]
    goal: float
    estimator: str | None

    @classmethod
    def of(cls, config: Config, estimator: Path) -> Calibrated:
        return cls(config.cell.robot, config.sensor.sensing, sensor_geometry(config.sensor),
                   float(config.env.coverage_goal), file_sha256(estimator))

    def mismatch(self, other: Calibrated) -> str | None:
        """What of `other` differs from this, in words; None: nothing."""
        differences = [f"{field.name} {getattr(other, field.name)!r} (calibrated: "
                       f"{getattr(self, field.name)!r})"
                       for field in dataclasses.fields(self)
                       if getattr(other, field.name) != getattr(self, field.name)]
        return "; ".join(differences) or None


def first_crossings(probabilities: np.ndarray, thresholds: np.ndarray = THRESHOLDS) -> np.ndarray:
    """For each threshold, the index of the first view whose probability reaches it
    (len(probabilities): none does)."""
    highest = np.maximum.accumulate(np.nan_to_num(np.asarray(probabilities, float), nan=0.0))
    return np.searchsorted(highest, thresholds, side="left")


def false_stops(probabilities: Sequence[np.ndarray], coverages: Sequence[np.ndarray],
                goal: float, thresholds: np.ndarray = THRESHOLDS) -> np.ndarray:
    """(episodes, thresholds): whether the episode, stopped at the first view whose
    probability reaches the threshold, stops below the goal (False where it never stops)."""
    rows = []
    for probability, coverage in zip(probabilities, coverages, strict=True):
        crossing = first_crossings(probability, thresholds)
        below = np.append(np.asarray(coverage, float) < goal, False)
        rows.append(below[crossing])
    return np.array(rows, dtype=bool).reshape(len(rows), len(thresholds))


def plateau_view(coverage: npt.ArrayLike) -> int:
    """The index of an episode's plateau: its first view within `PLATEAU` of its highest
    coverage (fractions, view by view)."""
    coverage = np.asarray(coverage, dtype=float)
    return int(np.argmax(coverage >= coverage.max() - PLATEAU))


def quiet_share(features: np.ndarray) -> np.ndarray:
    """How much the latest two acquisitions grew the seen surface, from feature vectors
    (..., len(FEATURES)): the larger share of the occupied voxels either added (1 before two
    acquisitions)."""
    features = np.asarray(features, dtype=float)
    return np.maximum(features[..., FEATURES.index("added_last")],
                      features[..., FEATURES.index("added_before")])


def give_ups(probabilities: np.ndarray, quiet: np.ndarray, threshold: float,
             shares: np.ndarray = GIVE_UP_SHARES) -> np.ndarray:
    """For each share, the index of the view at which a run gives up: the first whose quiet
    share is below it, before the probability reaches `threshold` (len(probabilities): it never
    gives up)."""
    claim = int(first_crossings(probabilities, np.array([threshold]))[0])
    quietest = np.minimum.accumulate(np.asarray(quiet, float)[:claim])
    # The first view whose running minimum falls below each share.
    return np.where(shares > (quietest[-1] if claim else np.inf),
                    np.searchsorted(-quietest, -shares, side="right"), len(probabilities))


def false_give_ups(probabilities: Sequence[np.ndarray], quiet: Sequence[np.ndarray],
                   coverages: Sequence[np.ndarray], goal: float, threshold: float,
                   shares: np.ndarray = GIVE_UP_SHARES) -> np.ndarray:
    """(episodes, shares): whether the episode gives up (`give_ups`) below the goal at a
    view from which its coverage still reaches it."""
    rows = []
    for probability, still, coverage in zip(probabilities, quiet, coverages, strict=True):
        reached = np.asarray(coverage) >= goal
        # Whether a later view reaches the goal; the index past the last view never gives up.
        later = np.append(np.maximum.accumulate(reached[::-1])[::-1][1:], [False, False])
        rows.append((~np.append(reached, True) & later)[give_ups(probability, still, threshold,
                                                                  shares)])
    return np.array(rows, dtype=bool).reshape(len(rows), len(shares))


def _learn_then_test(losses: np.ndarray, risk: float, delta: float) -> int | None:
    """The last of a sequence of settings (columns of `losses`, episodes x settings, the
    safest first) whose risk test rejects with those of every one before it; None: none.

    Raises:
        ValueError: For risk or delta outside (0, 1) or no episode.
    """
    from mapie.risk_control import control_fwer
    from mapie.risk_control.methods import compute_hoeffding_bentkus_p_value

    if not 0.0 < risk < 1.0 or not 0.0 < delta < 1.0:
        raise ValueError(f"risk and delta must lie in (0, 1), got {risk} and {delta}")
    if not len(losses):
        raise ValueError("Learn-then-Test needs calibration episodes, got none")
    p_values = compute_hoeffding_bentkus_p_value(losses.mean(axis=0), len(losses), risk,
                                                 binary=True)[:, 0]
    rejected = control_fwer(p_values, delta, "fixed_sequence")
    return int(np.max(rejected)) if len(rejected) else None


def stop_threshold(probabilities: Sequence[np.ndarray], coverages: Sequence[np.ndarray],
                   goal: float, risk: float, delta: float,
                   thresholds: np.ndarray = THRESHOLDS) -> float | None:
    """The lowest threshold Learn-then-Test certifies: false stops at most `risk` with
    probability 1 - `delta` (see the module docstring); None: not even the highest.

    Raises:
        ValueError: For risk or delta outside (0, 1) or no episode.
    """
    chosen = _learn_then_test(false_stops(probabilities, coverages, goal, thresholds), risk,
                              delta)
    return None if chosen is None else float(thresholds[chosen])


def give_up_share(probabilities: Sequence[np.ndarray], quiet: Sequence[np.ndarray],
                  coverages: Sequence[np.ndarray], goal: float, threshold: float, risk: float,
                  delta: float, shares: np.ndarray = GIVE_UP_SHARES) -> float | None:
    """The largest share Learn-then-Test certifies for giving up: false give-ups at most
    `risk` with probability 1 - `delta` (see the module docstring); None: not even the
    smallest.

    Raises:
        ValueError: For risk or delta outside (0, 1) or no episode.
    """
    chosen = _learn_then_test(false_give_ups(probabilities, quiet, coverages, goal, threshold,
                                             shares), risk, delta)
    return None if chosen is None else float(shares[chosen])


@dataclasses.dataclass(frozen=True)
class GoalConfidence:
    """The calibrated probability that the goal is reached, and the stop threshold.

    Attributes:
        residuals: (n,) true coverage minus the stated mean, on the calibration views.
        sigmas: (n,) the stated std there.
        views: (n,) the views taken there.
        threshold: The threshold Learn-then-Test certified (None: none).
        risk: The false-stop risk it was certified for.
        delta: The chance that the certificate is wrong.
        episodes: The calibration episodes Learn-then-Test ran on.
        calibrated: What the calibration holds for.
        give_up: The quiet share under which a run gives up, certified for false give-ups at
            most `risk` (None: it never gives up).
    """

    residuals: np.ndarray
    sigmas: np.ndarray
    views: np.ndarray
    threshold: float | None
    risk: float
    delta: float
    episodes: int
    calibrated: Calibrated
    give_up: float | None = None

    @functools.cached_property
    def mondrian(self) -> bool:
        """Whether every category has `MIN_PER_CATEGORY` calibration views of its own."""
        counts = np.bincount(view_category(self.views), minlength=len(VIEW_CATEGORIES) + 1)
        return bool(counts.min() >= MIN_PER_CATEGORY)

    @functools.cached_property
    def _system(self) -> Any:
        # crepes imports scikit-learn and pandas: only a rule that uses it pays that.
        from crepes import ConformalPredictiveSystem

        bins = view_category(self.views) if self.mondrian else None
        return ConformalPredictiveSystem().fit(self.residuals, sigmas=self.sigmas, bins=bins)

    def probability(self, mean: npt.ArrayLike, std: npt.ArrayLike, views: npt.ArrayLike
                    ) -> np.ndarray:
        """P(coverage >= goal) after views stating `mean` and `std`, `views` taken."""
        mean, std = np.atleast_1d(mean).astype(float), np.atleast_1d(std).astype(float)
        bins = view_category(np.atleast_1d(views)) if self.mondrian else None
        below = self._system.predict(y_hat=mean, sigmas=std, bins=bins,
                                     y=self.calibrated.goal, smoothing=False)
        return 1.0 - np.asarray(below, dtype=float).reshape(len(mean))

    def save(self, path: str | Path) -> Path:
        """Write it to an `.npz` file (atomically)."""
        path = Path(path)
        arrays = {"format": np.array(FORMAT), "residuals": self.residuals,
                  "sigmas": self.sigmas, "views": self.views,
                  "certificate": np.array(json.dumps({
                      "threshold": self.threshold, "risk": self.risk, "delta": self.delta,
                      "episodes": self.episodes, "give_up": self.give_up,
                      "calibrated": dataclasses.asdict(self.calibrated)}))}
        return write_arrays(path, arrays)

    @classmethod
    def load(cls, path: str | Path) -> GoalConfidence:
        """Read what `save` wrote.

        Raises:
            ValueError: If the file is missing or not a calibration of a known format.
        """
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                if int(data["format"]) != FORMAT:
                    raise ValueError(f"format {int(data['format'])}, expected {FORMAT}")
                certificate: Mapping[str, Any] = json.loads(str(data["certificate"]))
                calibrated = dict(certificate["calibrated"])
                calibrated["sensor"] = tuple(calibrated["sensor"])
                return cls(data["residuals"], data["sigmas"], data["views"],
                           certificate["threshold"], float(certificate["risk"]),
                           float(certificate["delta"]), int(certificate["episodes"]),
                           Calibrated(**calibrated), certificate.get("give_up"))
        except (OSError, EOFError, zipfile.BadZipFile, KeyError, TypeError,
                ValueError) as error:
            raise ValueError(f"cannot read goal confidence {path}: {error}") from None


def calibration_table(probability: np.ndarray, reached: np.ndarray,
                      edges: Sequence[float] = (0.0, 0.5, 0.8, 0.9, 0.95, 0.99, 1.0)
                      ) -> list[dict[str, Any]]:
    """Claimed P against the observed share at the goal, per bin of P: each bin's range, views,
    mean claimed P and observed share (NaN where the bin is empty)."""
    probability, reached = np.asarray(probability, float), np.asarray(reached, bool)
    rows = []
    for low, high in itertools.pairwise(edges):
        inside = (probability >= low) & ((probability < high) if high < 1.0
                                         else (probability <= high))
        rows.append({"low": low, "high": high, "views": int(inside.sum()),
                     "claimed": float(probability[inside].mean()) if inside.any() else np.nan,
                     "observed": float(reached[inside].mean()) if inside.any() else np.nan})
    return rows
