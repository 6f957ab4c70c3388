"""An episode's motion as the cell runs it: its moves timed, and the cycle time of the part
(docs/motion.md#cycle-time)."""

from __future__ import annotations

import numpy as np

from vprobot.episode.records import EpisodeRecord
from vprobot.kinematics.trajectory import MotionLimits, TimedPlan, time_plan
from vprobot.scene import Cell


def episode_moves(record: EpisodeRecord) -> list[np.ndarray] | None:
    """The moves of a robot episode's cycle: the approach to the first acquisition, the moves
    to the later ones and the return to the start, each as its corners (m, dof).

    Views where the robot stayed (unreachable requests) are no moves. None without a robot,
    before the first acquisition, or when the cycle cannot be closed (no path back was found).
    """
    moves = [view.waypoints for view in record.views if view.acquired]
    if (record.carrier != "robot" or not moves or record.return_waypoints is None
            or any(move is None for move in moves)):
        return None
    return [*moves, record.return_waypoints]


def timed_episode(record: EpisodeRecord, cell: Cell) -> TimedPlan | None:
    """The episode's moves timed under the cell's robot limits, with a stop of the sensor's
    acquisition time at every view; None where `episode_moves` is."""
    moves = episode_moves(record)
    if moves is None:
        return None
    return time_plan(moves, MotionLimits.of(cell.robot), cell.config.sensor.acquisition_time_s,
                     cell.joints.names)
