"""`measurable[:S]`: stop when the reachable candidates would measure little more of the part, by
the grid alone (model-free): the share of the surface known so far (the occupied voxels and those
still measurable) that some reachable band candidate's sensor would still measure
(`ViewGains.revisits`' bound, `measurable_share`) falls to S. The candidates' reachability is
screened once per episode, from where the robot is at the first check (`screen_band`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vprobot.config import Config
from vprobot.coverage.occupancy import VOXEL_M, GridSettings
from vprobot.coverage.view_gains import measurable_share
from vprobot.episode.views import band_candidates, screen_band
from vprobot.stopping.rules.base import StopRule, fraction_option, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode

MEASURABLE_SHARE = 0.04
"""The default S: the largest of `scripts/measurable_surface.py`'s that stops `nbv` below the goal
on at most 5 % of the `validation-v2` episodes in the realistic cell (1 of 29, each of which `nbv`
brings to the goal within the budget; `results/real/measurable_surface.md`). It stops late: a
median 9 views past the goal there."""


@register_stop
class MeasurableStop(StopRule):
    """Reads the episode's occupancy grid (`Episode.occupancy`) and stops when what the
    reachable candidates would still measure is at most a share S of the known surface.

    Args:
        config: The cell, its sensor and sensing model.
        share: S, in (0, 1).
    """

    name = "measurable"
    pattern = r"(?::(?P<share>.*))?"
    usage = f"measurable[:S] (0 < S < 1, default {MEASURABLE_SHARE})"
    description = "what the reachable candidates would still measure falls to a share S"

    def __init__(self, config: Config, share: float = MEASURABLE_SHARE):
        self.config = config
        self.share = share
        self.settings = GridSettings.of(config)
        self._reachable: np.ndarray | None = None

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        return fraction_option(groups, "share", "S")

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config, **options)

    def reset(self) -> None:
        self._reachable = None

    def left(self, episode: Episode) -> float:
        """The share of the known surface the reachable candidates would still measure."""
        band = band_candidates(self.config, VOXEL_M)
        if self._reachable is None:
            joints, _ = screen_band(episode, band)
            self._reachable = ~np.isnan(joints).any(axis=1)
        episode_grid = episode.occupancy(self.settings)
        measurable = band.gains.revisits(episode_grid.grid, self._reachable).measurable
        return measurable_share(measurable, episode_grid.counts()["occupied"])

    def check(self, episode: Episode) -> str | None:
        left = self.left(episode)
        if left <= self.share:
            return (f"measurable: the reachable candidates would measure {left:.1%} of the known "
                    f"surface more (at most {self.share:.0%})")
        return None
