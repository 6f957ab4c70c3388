"""`uniform<k>`: k fixed look-at views spread evenly over the view band, whatever the object.

The views lie on the view sphere at the sensor's working distance about the fixture's centre,
spread evenly (Fibonacci lattice) from the top down to the band's lowest polar angle
(`ground_truth.MAX_POLAR_DEG`, 30 degrees below the equator: the band the inspectable surface
is defined from), each looking at the centre. They depend on k and the cell only: not on the
object, its pose or its mesh. With the robot, each view is reached from the current
configuration and the reachable ones are ordered for short joint travel (the others follow and
are reported unreachable when executed); free-flying, they are ordered for a short sensor path.
The plan runs to its end: a fixed pattern does not know the coverage.
"""

from __future__ import annotations

import numpy as np

from vprobot.episode import Episode, ViewRequest
from vprobot.ground_truth import MAX_POLAR_DEG
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import PlanPlanner
from vprobot.planners.ordering import fixed_plan
from vprobot.viewsphere import sphere_directions


def uniform_targets(count: int, center: np.ndarray, distance: float) -> list[SensorTarget]:
    """`count` look-at targets spread evenly over the view band about `center`.

    Raises:
        ValueError: If count < 1.
    """
    directions = sphere_directions(count, np.deg2rad(MAX_POLAR_DEG))
    return [SensorTarget.look_at(center + distance * direction, center)
            for direction in directions]


class UniformPlanner(PlanPlanner):
    """k fixed views over the view band, in a short travel order.

    Args:
        count: Number of views k.
        working_distance_m: Distance of the views from the fixture's centre.

    Raises:
        ValueError: If count < 1.
    """

    name = "uniform"
    stops_at_goal = False

    def __init__(self, count: int, working_distance_m: float):
        if count < 1:
            raise ValueError(f"a uniform pattern needs at least one view, got {count}")
        super().__init__()
        self.count = count
        self.working_distance_m = working_distance_m

    def plan(self, episode: Episode) -> list[ViewRequest]:
        return fixed_plan(episode, uniform_targets(self.count, episode.center,
                                                   self.working_distance_m))
