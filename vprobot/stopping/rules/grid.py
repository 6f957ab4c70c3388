"""`grid`: the volumetric rule of `nbv@grid` for any planner: stop when the surface seen has
stopped growing (`vprobot.planners.nbv.surface_quiet`), from an occupancy grid of the acquired
frames (model-free)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from vprobot.config import Config
from vprobot.occupancy import EpisodeGrid
from vprobot.planners.nbv import surface_quiet
from vprobot.stopping.rules.base import StopRule, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode


@register_stop
class GridStop(StopRule):
    """Integrates each acquired frame into the episode's occupancy grid and stops when the
    latest informative frames each added too little to the occupied voxels."""

    name = "grid"

    def __init__(self, config: Config):
        self.grid = EpisodeGrid(config)

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config)

    def reset(self) -> None:
        self.grid.reset()

    def check(self, episode: Episode) -> str | None:
        self.grid.update(episode.views)
        return surface_quiet(self.grid.added)
