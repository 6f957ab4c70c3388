"""The sampled joint trajectory as JSON and as CSV (docs/motion.md#export)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from vprobot.export.motion import PlanMotion, ViewStop
from vprobot.kinematics.trajectory import Trajectory


def acquisition_entries(motion: PlanMotion) -> list[dict[str, Any]]:
    """Per acquisition: the view, when the robot stands there, its joints and the plan's sensor
    pose, for checking."""
    return [{"view": stop.view, "start_s": acquisition.start_s, "end_s": acquisition.end_s,
             "joints": stop.joints.tolist(), "sensor_position": stop.position.tolist(),
             "sensor_quaternion": stop.quaternion.tolist()}
            for stop, acquisition in zip(motion.stops, motion.timed.acquisitions, strict=True)]


def trajectory_json(motion: PlanMotion, samples: Trajectory) -> str:
    """Times, positions, velocities and accelerations at every sample, the cycle time and the
    acquisitions."""
    document = {
        "robot": motion.robot,
        "joint_names": list(samples.joint_names),
        "cycle_time": motion.timed.cycle.as_dict(),
        "times": samples.times.tolist(),
        "positions": samples.positions.tolist(),
        "velocities": samples.velocities.tolist(),
        "accelerations": samples.accelerations.tolist(),
        "acquisitions": acquisition_entries(motion),
    }
    return json.dumps(document, allow_nan=False) + "\n"


def trajectory_csv(motion: PlanMotion, samples: Trajectory) -> str:
    """One row per sample: `time_s`, the positions `q_<joint>`, the velocities `qd_<joint>` and
    `view`, the index of the view being acquired (-1 while moving); the acquisitions' sensor
    poses in `#` comment lines above the header."""
    view = np.full(len(samples.times), -1)
    for start_s, end_s, index in samples.acquisitions:
        view[(samples.times >= start_s) & (samples.times <= end_s)] = index
    lines = [f"# robot {motion.robot}; cycle time {motion.timed.cycle.total_s:.6f} s",
             *(_pose_comment(stop) for stop in motion.stops),
             ",".join(["time_s", *(f"q_{name}" for name in samples.joint_names),
                       *(f"qd_{name}" for name in samples.joint_names), "view"])]
    # repr-exact floats keep the finite differences of the file those of the trajectory.
    rows = np.column_stack([samples.times, samples.positions, samples.velocities])
    lines += [",".join([*map(repr, row.tolist()), str(index)])
              for row, index in zip(rows, view, strict=True)]
    return "\n".join(lines) + "\n"


def _pose_comment(stop: ViewStop) -> str:
    return (f"# acquisition view {stop.view}: sensor position {stop.position.tolist()} "
            f"quaternion {stop.quaternion.tolist()}")
