"""`nbv_camera`: `nbv` scoring candidates by what the camera sees, whatever the sensor measures.

It is `nbv` as it was before issue 45 (`vprobot.coverage.view_gains.ViewGains.score`: the unknown
voxels the camera's rays reach, sample by sample), kept to compare against `nbv`, which scores by
what the sensor measures. With the ideal sensor the two rank the candidates alike. Names take the
same gain and stop rule: `nbv_camera:frontier`, `nbv_camera@grid`.
"""

from __future__ import annotations

from typing import ClassVar

from vprobot.planners.base import register_planner
from vprobot.planners.nbv import VolumetricPlanner


@register_planner
class CameraVolumetricPlanner(VolumetricPlanner):
    """`nbv` by the camera's gain (`VolumetricPlanner`'s arguments)."""

    name = "nbv_camera"
    evaluated: ClassVar[tuple[str, ...]] = ()
    sensed = False
