"""`estimate[:C]`: stop when the model-free coverage estimate says the goal is reached with
confidence C, i.e. when mean - z(C) std >= goal (z the one-sided normal quantile).

The estimate (`vprobot.stopping.estimator`) reads only the features of the acquired frames and
the sensor poses (`vprobot.stopping.features`), never the mesh, the ground truth or the
coverage (`tests/test_model_free.py` guards it), so the rule runs in a real cell.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from statistics import NormalDist
from typing import TYPE_CHECKING, Any

import numpy as np

from vprobot.config import Config
from vprobot.stopping.estimator import CoverageEstimator, load_estimator
from vprobot.stopping.features import CoverageFeatures, episode_features
from vprobot.stopping.rules.base import StopRule, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode, ViewRecord

DEFAULT_CONFIDENCE = 0.95


@register_stop
class EstimateStop(StopRule):
    """Stops once the estimate's lower one-sided bound at the confidence reaches the goal.

    Args:
        config: The run's configuration (the goal; the cell and sensor of the features).
        estimator: The coverage estimator.
        confidence: The one-sided confidence, in (0, 1).

    Raises:
        ValueError: For a confidence outside (0, 1).
    """

    name = "estimate"
    pattern = r"(?::(?P<confidence>.*))?"
    usage = f"estimate[:C] (0 < C < 1, default {DEFAULT_CONFIDENCE})"

    def __init__(self, config: Config, estimator: CoverageEstimator,
                 confidence: float = DEFAULT_CONFIDENCE):
        if not 0.0 < confidence < 1.0:
            raise ValueError(f"the confidence of estimate:C must lie in (0, 1), got {confidence}")
        self.goal = config.env.coverage_goal
        self.estimator = estimator
        self.confidence = confidence
        self.z = NormalDist().inv_cdf(confidence)
        self.features = CoverageFeatures(config)

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        text = groups.get("confidence")
        if text is None:
            return {}
        try:
            confidence = float(text)
        except ValueError:
            confidence = np.nan
        if not 0.0 < confidence < 1.0:
            raise ValueError("C must be a number in (0, 1)")
        return {"confidence": confidence}

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config, load_estimator(estimator), **options)

    def reset(self) -> None:
        self.features.reset()

    def check(self, episode: Episode) -> str | None:
        views = episode.views
        if not any(view.acquired for view in views):
            return None  # nothing acquired: the estimator has nothing to go on
        mean, std = (float(value) for value in
                     self.estimator.estimate(self.features.update(views)))
        if mean - self.z * std >= self.goal:
            return (f"estimate {100 * mean:.1f} ± {100 * std:.1f} % ≥ {100 * self.goal:g} % "
                    f"at {100 * self.confidence:g} %")
        return None


def view_estimates(config: Config, views: Sequence[ViewRecord],
                   estimator: CoverageEstimator) -> np.ndarray:
    """The estimated coverage after each view, as `estimate` sees it: (len(views), 2), the
    mean and the standard deviation."""
    if not views:
        return np.zeros((0, 2))
    mean, std = estimator.estimate(episode_features(config, views))
    return np.stack([mean, std], axis=1)
