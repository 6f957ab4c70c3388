"""An episode's motion as the cell runs it: its moves, each timed once when executed, on the
clock of the part's cycle (docs/motion.md#cycle-time)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vprobot.cell.scene import Cell
from vprobot.episode.records import EpisodeRecord, ViewRecord
from vprobot.kinematics.trajectory import TimedMove, TimedPlan, chain_moves


def timed_cycle(views: Sequence[ViewRecord], back: TimedMove | None,
                cell: Cell) -> TimedPlan | None:
    """The cycle of a robot episode: the approach to the first acquisition, the moves to the
    later ones and the return `back` to the start, as the carrier timed them, with a stop of
    the sensor's acquisition time at every view.

    Views where the robot stayed (unreachable requests) are no moves. None without a robot,
    before the first acquisition, or when the cycle cannot be closed (no path back was found).
    """
    moves = [view.timed for view in views if view.acquired]
    known = [move for move in moves if move is not None]
    if not moves or back is None or len(known) < len(moves):
        return None
    return chain_moves([*known, back], cell.config.sensor.acquisition_time_s, cell.joints.names)


def episode_moves(record: EpisodeRecord) -> list[np.ndarray] | None:
    """The corners (m, dof) of each move of a robot episode's cycle (`EpisodeRecord.timed`);
    None where it has none."""
    return None if record.timed is None else [move.waypoints for move in record.timed.moves]


def describe_cycle(record: EpisodeRecord) -> str | None:
    """The cycle time of a robot episode and its parts in words, or why it has none; None
    without a robot."""
    if record.carrier != "robot":
        return None
    cycle = record.cycle
    if cycle is None:
        why = ("no path back to the start was found" if any(view.acquired for view in record.views)
               else "nothing was acquired")
        return f"cycle time: none ({why})"
    return (f"cycle time {cycle.total_s:.2f} s: approach {cycle.approach_s:.2f} s, moves "
            f"{cycle.moves_s:.2f} s, acquisitions {cycle.acquisitions_s:.2f} s, return "
            f"{cycle.return_s:.2f} s")
