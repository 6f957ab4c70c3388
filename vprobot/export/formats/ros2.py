"""The export format `ros2`: a ROS 2 `trajectory_msgs/msg/JointTrajectory` as YAML
(docs/motion.md#ros-2).

The document is the message and nothing else (`header`, `joint_names`, `points` with
`positions`, `velocities`, `accelerations` and `time_from_start`), so it can be published or
handed to a `joint_trajectory_controller` as it is; the acquisitions, with the plan's sensor
pose at each, are comments above the point where the robot stops to acquire.
"""

from __future__ import annotations

import math

import numpy as np
import yaml

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion

NANOSECONDS = 1_000_000_000


def _names(names: tuple[str, ...]) -> str:
    """The names as a YAML flow sequence on one line, written by YAML's dumper, which quotes a
    scalar that needs it."""
    return yaml.safe_dump(list(names), default_flow_style=True, width=math.inf).strip()


def _list(values: np.ndarray) -> str:
    return "[" + ", ".join(repr(float(x) + 0.0) for x in values) + "]"


def time_from_start(seconds: float) -> tuple[int, int]:
    """`builtin_interfaces/Duration` (sec, nanosec) of a time, rounded to the nanosecond."""
    return divmod(round(seconds * NANOSECONDS), NANOSECONDS)


@register_format("ros2", ".yaml", "a ROS 2 JointTrajectory message as YAML")
def joint_trajectory_yaml(motion: PlanMotion, dt: float) -> str:
    """The trajectory sampled every `dt` s as a JointTrajectory message in YAML."""
    samples = motion.timed.sample(dt)
    starts = {start_s: index for index, (start_s, _, _) in enumerate(samples.acquisitions)}
    lines = [f"# vprobot inspection trajectory for the {motion.robot}: "
             f"{len(motion.stops)} acquisitions, cycle time {motion.timed.cycle.total_s:.3f} s",
             "header:", "  stamp: {sec: 0, nanosec: 0}", "  frame_id: ''",
             f"joint_names: {_names(samples.joint_names)}", "points:"]
    for time_s, q, qd, qdd in zip(samples.times, samples.positions, samples.velocities,
                                  samples.accelerations, strict=True):
        if time_s in starts:
            stop = motion.stops[starts[time_s]]
            lines.append(f"  # acquisition view {stop.view} for {motion.acquisition_time_s} s: "
                         f"sensor position {_list(stop.position)} quaternion (w, x, y, z) "
                         f"{_list(stop.quaternion)}")
        sec, nanosec = time_from_start(float(time_s))
        lines += [f"  - positions: {_list(q)}", f"    velocities: {_list(qd)}",
                  f"    accelerations: {_list(qdd)}",
                  f"    time_from_start: {{sec: {sec}, nanosec: {nanosec}}}"]
    return "\n".join(lines) + "\n"
