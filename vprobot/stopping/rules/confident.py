"""`confident[:P]`: stop when the calibrated probability that the goal is reached
(`vprobot.stopping.confidence`) reaches the threshold Learn-then-Test certified for it, or P.

The estimate is stated as `estimate` states it (refused or widened for inputs unlike those it
was fit on), but not held back where more space is unexplored than on the training views where
it claimed the goal: that guard is of `estimate`'s normal claims, while here the calibration
measured the errors on such views too (in the realistic cell the estimate never claimed the goal
in training, so `estimate` holds back every stop). The probability comes from the calibration
beside the estimator file (`confidence.npz`, made by `vprobot stop calibrate`), which is refused
for another cell, sensing model, goal or estimator than it was made with.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.stopping.confidence import Calibrated, GoalConfidence
from vprobot.stopping.estimator import CoverageEstimator, Stated, bundled_estimator, load_estimator
from vprobot.stopping.rules.base import StopRule, fraction_option, register_stop
from vprobot.stopping.rules.estimate import EstimateStop

CONFIDENCE_FILE = "confidence.npz"
"""The calibration's file name, beside the estimator file it calibrates."""


def confidence_path(estimator: Path) -> Path:
    """Where the calibration of estimator file `estimator` lies."""
    return estimator.with_name(CONFIDENCE_FILE)


@register_stop
class ConfidentStop(EstimateStop):
    """Stops once P(coverage >= goal) reaches the threshold.

    Args:
        config: The run's configuration.
        estimator: The coverage estimator.
        confidence: Its calibration, checked against the run (`Calibrated`) by `build`.
        probability: The threshold, in (0, 1); None: the certified one.

    Raises:
        ValueError: For a threshold outside (0, 1), or none given where the calibration
            certified none.
    """

    name = "confident"
    pattern = r"(?::(?P<probability>.*))?"
    usage = "confident[:P] (0 < P < 1, default: the calibrated threshold)"
    description = "the calibrated probability that the goal is reached reaches P"

    def __init__(self, config: Config, estimator: CoverageEstimator,
                 confidence: GoalConfidence, probability: float | None = None):
        super().__init__(config, estimator)
        threshold = probability if probability is not None else confidence.threshold
        if threshold is None:
            raise ValueError(f"the calibration certified no threshold for false stops at most "
                             f"{100 * confidence.risk:g} %; give one: confident:P")
        if not 0.0 < threshold < 1.0:
            raise ValueError(f"the threshold of confident:P must lie in (0, 1), got {threshold}")
        self.calibration = confidence
        self.threshold: float = threshold

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        return fraction_option(groups, "probability", "P")

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        path = Path(estimator) if estimator is not None else bundled_estimator(config.sensor)
        model = load_estimator(path, config.sensor)
        calibration = confidence_path(path)
        if not calibration.is_file():
            raise ValueError(f"confident needs a calibration of estimator {path} at "
                             f"{calibration}; make one with `vprobot stop calibrate`")
        confidence = GoalConfidence.load(calibration)
        mismatch = confidence.calibrated.mismatch(Calibrated.of(config, path))
        if mismatch is not None:
            raise ValueError(f"the calibration {calibration} was made for another run than "
                             f"this: {mismatch}; make one for it with `vprobot stop calibrate`")
        return cls(config, model, confidence, **options)

    def goal_probabilities(self, estimates: np.ndarray) -> np.ndarray:
        """P(coverage >= goal) after each view of an episode whose estimates (mean, std) after
        each view are `estimates` (len(estimates), 2); NaN where refused."""
        probability = np.full(len(estimates), np.nan)
        stated = ~np.isnan(estimates[:, 0])
        if stated.any():
            probability[stated] = self.calibration.probability(
                estimates[stated, 0], estimates[stated, 1], np.flatnonzero(stated) + 1)
        return probability

    def decide(self, stated: Stated, views: int) -> str | None:
        probability = float(self.calibration.probability(stated.mean, stated.std, views)[0])
        if probability < self.threshold:
            return None
        certified = ("" if self.threshold != self.calibration.threshold else
                     f" (certified: false stops at most {100 * self.calibration.risk:g} % with "
                     f"{100 * (1 - self.calibration.delta):g} % confidence, "
                     f"{self.calibration.episodes} calibration episodes)")
        return (f"P(coverage ≥ {100 * self.goal:g} %) = {probability:.3f} ≥ "
                f"{self.threshold:g}{certified}")
