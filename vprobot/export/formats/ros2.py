"""The export format `ros2`: a ROS 2 `control_msgs/action/FollowJointTrajectory` goal as YAML
(docs/motion.md#ros-2).

The document is the goal and nothing else: `path_tolerance`, `goal_tolerance` and
`goal_time_tolerance` from the plan's `cell.program`, and the `trajectory` (a
`trajectory_msgs/msg/JointTrajectory`: `header`, `joint_names`, `points` with `positions`,
`velocities`, `accelerations` and `time_from_start`), so `ros2 action send_goal` or a client
can send it as it is; the fields it leaves out take their defaults. The acquisitions are
comments above the point where the robot stops to acquire, and, machine-readable, the format
`acquisitions` beside it.
"""

from __future__ import annotations

import math

import numpy as np
import yaml

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion

NANOSECONDS = 1_000_000_000
GOAL_TYPE = "control_msgs/action/FollowJointTrajectory"


def _names(names: tuple[str, ...]) -> str:
    """The names as a YAML flow sequence on one line, written by YAML's dumper, which quotes a
    scalar that needs it."""
    return yaml.safe_dump(list(names), default_flow_style=True, width=math.inf).strip()


def _list(values: np.ndarray) -> str:
    return "[" + ", ".join(repr(float(x) + 0.0) for x in values) + "]"


def time_from_start(seconds: float) -> tuple[int, int]:
    """`builtin_interfaces/Duration` (sec, nanosec) of a time, rounded to the nanosecond."""
    return divmod(round(seconds * NANOSECONDS), NANOSECONDS)


def _tolerances(motion: PlanMotion) -> str:
    """The goal's tolerances as YAML (its dumper quotes a joint name that needs it): the same
    position tolerance for every joint; velocity and acceleration 0, the controller's own."""
    io = motion.cell.io
    sec, nanosec = time_from_start(io.goal_time_tolerance_s)

    def per_joint(position: float) -> list[dict[str, object]]:
        return [{"name": name, "position": position, "velocity": 0.0, "acceleration": 0.0}
                for name in motion.joint_names]

    return yaml.safe_dump({"path_tolerance": per_joint(io.path_tolerance_rad),
                           "goal_tolerance": per_joint(io.goal_tolerance_rad),
                           "goal_time_tolerance": {"sec": sec, "nanosec": nanosec}},
                          sort_keys=False, default_flow_style=None, width=math.inf)


@register_format("ros2", ".yaml", "a ROS 2 FollowJointTrajectory goal as YAML")
def follow_joint_trajectory_yaml(motion: PlanMotion, dt: float) -> str:
    """The trajectory sampled every `dt` s, with the cell's tolerances, as a
    FollowJointTrajectory goal in YAML."""
    samples = motion.timed.sample(dt)
    starts = {start_s: index for index, (start_s, _, _) in enumerate(samples.acquisitions)}
    lines = [f"# vprobot inspection trajectory for the {motion.robot}: a {GOAL_TYPE} goal, "
             f"{len(motion.stops)} acquisitions, cycle time {motion.timed.cycle.total_s:.3f} s "
             f"(docs/motion.md#ros-2)",
             "# The acquisitions' times, joints and sensor poses, machine-readable: "
             "`vprobot export PLAN --format acquisitions`.",
             _tolerances(motion).rstrip("\n"),
             "trajectory:", "  header:", "    stamp: {sec: 0, nanosec: 0}", "    frame_id: ''",
             f"  joint_names: {_names(samples.joint_names)}", "  points:"]
    for time_s, q, qd, qdd in zip(samples.times, samples.positions, samples.velocities,
                                  samples.accelerations, strict=True):
        if time_s in starts:
            stop = motion.stops[starts[time_s]]
            lines.append(f"    # acquisition view {stop.view} for {motion.acquisition_time_s} s: "
                         f"sensor position {_list(stop.position)} quaternion (w, x, y, z) "
                         f"{_list(stop.quaternion)}")
        sec, nanosec = time_from_start(float(time_s))
        lines += [f"    - positions: {_list(q)}", f"      velocities: {_list(qd)}",
                  f"      accelerations: {_list(qdd)}",
                  f"      time_from_start: {{sec: {sec}, nanosec: {nanosec}}}"]
    return "\n".join(lines) + "\n"
