"""An episode's motion as the cell runs it: its moves timed, and the cycle time of the part
(docs/motion.md#cycle-time)."""

from __future__ import annotations

import numpy as np

from vprobot.episode.records import EpisodeRecord
from vprobot.kinematics.trajectory import CycleTime, TimedPlan, time_plan
from vprobot.scene import Cell


def episode_moves(record: EpisodeRecord) -> list[np.ndarray] | None:
    """The moves of a robot episode's cycle: the approach to the first acquisition, the moves
    to the later ones and the return to the start, each as its corners (m, dof).

    Views where the robot stayed (unreachable requests) are no moves. None without a robot,
    before the first acquisition, or when the cycle cannot be closed (no path back was found).
    """
    moves = [view.waypoints for view in record.views if view.acquired]
    known = [move for move in moves if move is not None]
    if (record.carrier != "robot" or not moves or record.return_waypoints is None
            or len(known) < len(moves)):
        return None
    return [*known, record.return_waypoints]


def timed_episode(record: EpisodeRecord, cell: Cell) -> TimedPlan | None:
    """The episode's moves timed under the cell's robot limits, with a stop of the sensor's
    acquisition time at every view; None where `episode_moves` is."""
    moves = episode_moves(record)
    if moves is None:
        return None
    return time_plan(moves, cell.motion_limits, cell.config.sensor.acquisition_time_s,
                     cell.joints.names)


def episode_cycle(record: EpisodeRecord, cell: Cell) -> CycleTime | None:
    """The cycle time of the episode's part and its parts; None where `episode_moves` is."""
    timed = timed_episode(record, cell)
    return None if timed is None else timed.cycle


def describe_cycle(record: EpisodeRecord, cycle: CycleTime | None) -> str | None:
    """The cycle time of a robot episode and its parts in words, or why it has none; None
    without a robot."""
    if record.carrier != "robot":
        return None
    if cycle is None:
        why = ("no path back to the start was found" if any(view.acquired for view in record.views)
               else "nothing was acquired")
        return f"cycle time: none ({why})"
    return (f"cycle time {cycle.total_s:.2f} s: approach {cycle.approach_s:.2f} s, moves "
            f"{cycle.moves_s:.2f} s, acquisitions {cycle.acquisitions_s:.2f} s, return "
            f"{cycle.return_s:.2f} s")
