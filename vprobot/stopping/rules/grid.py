"""`grid`: stop when the surface seen has stopped growing, from an occupancy grid of the acquired
frames (model-free): each of the latest `STOP_QUIET_VIEWS` informative frames added less than
`STOP_NEW_SURFACE` to the occupied voxels. A change rule, as MA-SCVP's; one quiet view is not
enough, as a view into empty space is quiet too. `nbv@grid` is `nbv` stopping itself by it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vprobot.config import Config
from vprobot.coverage.occupancy import GridSettings
from vprobot.stopping.rules.base import StopRule, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode

STOP_NEW_SURFACE = 0.02
"""The share of occupied voxels a frame added below which it is quiet (chosen on the training
motors)."""
STOP_QUIET_VIEWS = 2
"""Quiet frames in a row that stop."""


def surface_quiet(added: Sequence[float]) -> str | None:
    """The rule's test on what each informative frame added to the occupied voxels
    (`EpisodeGrid.added`): why to stop, else None."""
    recent = added[-STOP_QUIET_VIEWS:]
    if len(added) > STOP_QUIET_VIEWS and max(recent) < STOP_NEW_SURFACE:
        return (f"grid: the latest {STOP_QUIET_VIEWS} views each added less than "
                f"{STOP_NEW_SURFACE:.0%} to the seen surface")
    return None


@register_stop
class GridStop(StopRule):
    """Reads the episode's occupancy grid (`Episode.occupancy`) and stops when the latest
    informative frames each added too little to the occupied voxels."""

    name = "grid"
    description = "the seen surface stops growing"

    def __init__(self, config: Config):
        self.settings = GridSettings.of(config)

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config)

    def check(self, episode: Episode) -> str | None:
        return surface_quiet(episode.occupancy(self.settings).added)
