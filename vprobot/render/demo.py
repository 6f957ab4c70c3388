"""A simple fixed inspection for sample media, tests and benchmarks: look-at views around the
object, needing no planner."""

from __future__ import annotations

import numpy as np

from vprobot.episode import Episode, EpisodeRecord, PartScene, ViewRequest
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics import SensorTarget

MAX_POLAR_DEG = 110.0
"""By default the views come from the top down to 20 degrees below the equator."""


def ring_inspection(scene: PartScene, views: int, rotation: np.ndarray | None = None,
                    max_polar_deg: float = MAX_POLAR_DEG) -> EpisodeRecord:
    """Request `views` look-at views spread over the view sphere at the working distance.

    The directions are visited in order of azimuth, so the arm sweeps once around the object.

    Args:
        scene: The part's scene.
        views: Number of views requested (unreachable ones stay in the record).
        rotation: Object rotation (3x3); upright when omitted.
        max_polar_deg: Lowest view direction, as the angle from straight above.

    Raises:
        ValueError: If views < 1 or the polar limit is outside (0, 180].
    """
    if views < 1:
        raise ValueError(f"views must be >= 1, got {views}")
    episode = Episode(scene, np.eye(3) if rotation is None else rotation)
    directions = sphere_directions(views, np.deg2rad(max_polar_deg))
    directions = directions[np.argsort(np.arctan2(directions[:, 1], directions[:, 0]))]
    distance = scene.cell.config.sensor.working_distance_m
    for direction in directions:
        position = episode.center + distance * direction
        episode.request(ViewRequest(SensorTarget.look_at(position, episode.center)))
    return episode.record()
