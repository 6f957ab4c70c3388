"""`estimate[:C]`: stop when the model-free coverage estimate says the goal is reached with
confidence C, i.e. when mean - z(C) std >= goal (z the one-sided normal quantile).

The estimate is stated as `vprobot.stopping.estimator.EstimateTracker` states it: a view that
added no new surface never raises it, and it is widened or refused (the rule then never stops)
for inputs unlike those it was fit on: another sensor, features outside their training range.
Nor does the rule stop while more space is unexplored than on the training views where the
estimate claimed the goal (`Stated.held`: cavities no view has seen into).

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
from vprobot.coverage.occupancy import EpisodeGrid
from vprobot.stopping.estimator import CoverageEstimator, EstimateTracker, Stated, load_estimator
from vprobot.stopping.features import CoverageFeatures, episode_features
from vprobot.stopping.rules.base import StopRule, StopSubject, fraction_option, register_stop

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
    description = "the model-free coverage estimate reaches the goal with confidence C"

    def __init__(self, config: Config, estimator: CoverageEstimator,
                 confidence: float = DEFAULT_CONFIDENCE):
        if not 0.0 < confidence < 1.0:
            raise ValueError(f"the confidence of estimate:C must lie in (0, 1), got {confidence}")
        self.goal = config.env.coverage_goal
        self.config = config
        self.estimator = estimator
        self.confidence = confidence
        self.z = NormalDist().inv_cdf(confidence)
        self.features = CoverageFeatures(config)
        self.tracker = EstimateTracker(estimator, config)
        self._stated = 0

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        return fraction_option(groups, "confidence", "C")

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config, load_estimator(estimator, config.sensor), **options)

    def bind(self, planner: StopSubject) -> None:
        super().bind(planner)
        # The tracker notes a planner the estimate was not fit on.
        self.tracker = EstimateTracker(self.estimator, self.config, planner.name)

    def reset(self) -> None:
        self.features.reset()
        self.tracker.reset()
        self._stated = 0

    def check(self, episode: Episode) -> str | None:
        views = episode.views
        self.features.read(episode)
        stated: Stated | None = None
        features = np.empty(0)
        # View by view, as `view_estimates` states them, however many came since the last check.
        for count in range(self._stated + 1, len(views) + 1):
            features = self.features.update(views[:count])
            stated = self.tracker.update(features)
        self._stated = len(views)
        if stated is None or stated.refused:
            return None
        return self.decide(stated, features, len(views))

    def decide(self, stated: Stated, features: np.ndarray, views: int) -> str | None:
        """Why to stop on the estimate `stated` from the latest view's `features`, after
        `views` views (None: go on)."""
        if stated.held is None and stated.mean - self.z * stated.std >= self.goal:
            return (f"estimate {100 * stated.mean:.1f} ± {100 * stated.std:.1f} % ≥ "
                    f"{100 * self.goal:g} % at {100 * self.confidence:g} %")
        return None


def view_estimates(config: Config, views: Sequence[ViewRecord], estimator: CoverageEstimator,
                   planner: str | None = None, grid: EpisodeGrid | None = None
                   ) -> tuple[np.ndarray, list[str]]:
    """The estimated coverage after each view, as `estimate` states it (`EstimateTracker`):
    (len(views), 2), the mean and the standard deviation (NaN where refused), and the notes
    on why it was refused, widened or kept (each once). `grid` is the episode's grid of the
    features (`episode_features`), else the views are integrated here."""
    tracker = EstimateTracker(estimator, config, planner)
    stated = [tracker.update(features) for features in episode_features(config, views, grid)]
    return (np.array([(one.mean, one.std) for one in stated]).reshape(len(views), 2),
            tracker.notes)
