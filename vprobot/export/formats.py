"""Every export format by name (docs/motion.md#export)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from vprobot.export import EXPORT_DT_S
from vprobot.export.motion import PlanMotion, plan_motion
from vprobot.export.ros2 import joint_trajectory_yaml
from vprobot.export.trajectory import trajectory_csv, trajectory_json
from vprobot.export.urscript import urscript

WRITERS: dict[str, Callable[[PlanMotion, float], str]] = {
    "trajectory": lambda motion, dt: trajectory_json(motion, motion.timed.sample(dt)),
    "csv": lambda motion, dt: trajectory_csv(motion, motion.timed.sample(dt)),
    # The controller times each segment itself: the program sends segments, not samples.
    "urscript": lambda motion, dt: urscript(motion),
    "ros2": lambda motion, dt: joint_trajectory_yaml(motion, motion.timed.sample(dt)),
}
"""Each format's writer: the plan's motion and the sampling step -> the file's text."""


def export_plan(document: dict[str, Any], format_name: str, dt: float = EXPORT_DT_S) -> str:
    """The text of a plan's motion in one format.

    Raises:
        ValueError: For an unknown format, a plan that has no robot cycle to export
            (`plan_motion`), a non-UR robot asked for URScript, or a step that is not > 0.
    """
    if format_name not in WRITERS:
        raise ValueError(f"unknown export format {format_name!r}; allowed: {', '.join(WRITERS)}")
    return WRITERS[format_name](plan_motion(document), dt)
