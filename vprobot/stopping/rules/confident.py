"""`confident[:P]`: stop when the calibrated probability that the goal is reached
(`vprobot.stopping.confidence`) reaches the threshold Learn-then-Test certified for it, or P.

The estimate is stated as `estimate` states it (refused or widened for inputs unlike those it
was fit on), but not held back where more space is unexplored than on the training views where
it claimed the goal: that guard is of `estimate`'s normal claims, while here the calibration
measured the errors on such views too (in the realistic cell the estimate never claimed the goal
in training, so `estimate` holds back every stop). The probability comes from the calibration
beside the estimator file (`confidence.npz`, made by `vprobot stop calibrate`), which is refused
for another cell, sensing model, goal or estimator than it was made with.

Where the goal is out of reach the probability stays low; with its certified threshold the
rule then gives up, saying so (`GAVE_UP`), once the latest two acquisitions each grew the seen
surface less than the share the calibration certified for false give-ups (none: it never gives
up). The probability stays low too where the goal is reached but the estimate is unsure of it,
as in the realistic cell: giving up then ends a run the goal rule would have ended earlier.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.stopping.confidence import Calibrated, GoalConfidence, quiet_share
from vprobot.stopping.estimator import CoverageEstimator, Stated, bundled_estimator, load_estimator
from vprobot.stopping.rules.base import StopRule, fraction_option, register_stop
from vprobot.stopping.rules.estimate import EstimateStop

GAVE_UP = "gave up: the goal is out of reach here, or reached without the certainty to say so"
"""How a give-up's reason begins."""
CONFIDENCE_FILE = "confidence.npz"
"""The calibration's file name, beside the estimator file it calibrates."""


def confidence_path(estimator: Path) -> Path:
    """Where the calibration of estimator file `estimator` lies."""
    return estimator.with_name(CONFIDENCE_FILE)


@register_stop
class ConfidentStop(EstimateStop):
    """Stops once P(coverage >= goal) reaches the threshold, or gives up (the goal out of
    reach) where the calibration certified a quiet share and the seen surface grows less.

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

    def decide(self, stated: Stated, features: np.ndarray, views: int) -> str | None:
        probability = float(self.calibration.probability(stated.mean, stated.std, views)[0])
        calibration = self.calibration
        certificate = (f"with {100 * (1 - calibration.delta):g} % confidence, "
                       f"{calibration.episodes} calibration episodes)")
        goal = f"P(coverage ≥ {100 * self.goal:g} %) = {probability:.3f}"
        if probability >= self.threshold:
            certified = ("" if self.threshold != calibration.threshold else
                         f" (certified: false stops at most {100 * calibration.risk:g} % "
                         f"{certificate}")
            return f"{goal} ≥ {self.threshold:g}{certified}"
        # Giving up is certified with the certified threshold only.
        if (calibration.give_up is not None and self.threshold == calibration.threshold
                and float(quiet_share(features)) < calibration.give_up):
            return (f"{GAVE_UP}: {goal} < {self.threshold:g} and each of the latest 2 "
                    f"acquisitions added less than {100 * calibration.give_up:g} % to the seen "
                    f"surface (certified: false give-ups, below the goal where more views reach "
                    f"it, at most {100 * calibration.risk:g} % {certificate}")
        return None
