"""The clearances an episode's robot kept: the least distance from it to each object of the
cell over the moves it made (`vprobot.cell.check.clearances` along them)."""

from __future__ import annotations

import numpy as np

from vprobot.cell.check import Clearance, clearances
from vprobot.cell.scene import Cell
from vprobot.episode.records import EpisodeRecord
from vprobot.kinematics.motion_planner import densify


def episode_clearances(record: EpisodeRecord, cell: Cell) -> tuple[Clearance, ...] | None:
    """The least distance from the robot to each object of the cell over the moves the
    episode's robot made (to its views, and back to the start when it returned), at the path
    planner's resolution; None when it made none (or carried no robot)."""
    moves = [view.waypoints for view in record.views if view.waypoints is not None]
    if record.return_waypoints is not None:
        moves.append(record.return_waypoints)
    if record.carrier != "robot" or not moves:
        return None
    data = cell.make_data()
    cell.place_object(data, record.object_pose.rotation)
    step = cell.config.kinematics.path_max_joint_step_rad
    return tuple(clearances(cell, data, np.concatenate([densify(move, step) for move in moves])))
