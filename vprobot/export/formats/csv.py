"""The export format `csv`: the sampled joint trajectory as CSV (docs/motion.md#export)."""

from __future__ import annotations

import csv
import io

import numpy as np

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion, ViewStop


@register_format("csv", ".csv", "the sampled joint trajectory as CSV")
def trajectory_csv(motion: PlanMotion, dt: float) -> str:
    """One row per sample (every `dt` s): `time_s`, the positions `q_<joint>`, the velocities
    `qd_<joint>` and `view`, the index of the view being acquired (-1 while moving); the
    acquisitions' sensor poses in `#` comment lines above the header."""
    samples = motion.timed.sample(dt)
    view = np.full(len(samples.times), -1)
    for start_s, end_s, index in samples.acquisitions:
        view[(samples.times >= start_s) & (samples.times <= end_s)] = index
    header = io.StringIO()
    # The csv module quotes what a field needs quoted: the header stays one row of columns.
    csv.writer(header, lineterminator="\n").writerow(
        ["time_s", *(f"q_{name}" for name in samples.joint_names),
         *(f"qd_{name}" for name in samples.joint_names), "view"])
    lines = [f"# robot {motion.robot}; cycle time {motion.timed.cycle.total_s:.6f} s",
             *(_pose_comment(stop) for stop in motion.stops), header.getvalue().rstrip("\n")]
    # repr-exact floats keep the finite differences of the file those of the trajectory.
    rows = np.column_stack([samples.times, samples.positions, samples.velocities])
    lines += [",".join([*map(repr, row.tolist()), str(index)])
              for row, index in zip(rows, view, strict=True)]
    return "\n".join(lines) + "\n"


def _pose_comment(stop: ViewStop) -> str:
    return (f"# acquisition view {stop.view}: sensor position {stop.position.tolist()} "
            f"quaternion {stop.quaternion.tolist()}")
