"""A plan's motion written in one export format (`vprobot export`, docs/motion.md#export)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vprobot.cell.scene import Cell
from vprobot.config import load_config, replace
from vprobot.export import EXPORT_DT_S
from vprobot.export.formats import FORMATS
from vprobot.export.motion import plan_motion, require_robot
from vprobot.plan import plan_robot, read_plan


def export_plan(document: dict[str, Any], format_name: str, dt: float = EXPORT_DT_S) -> str:
    """The text of a plan's motion in one format.

    Raises:
        ValueError: For an unknown format, a plan that has no robot cycle to export
            (`plan_motion`), a non-UR robot asked for URScript, or a step that is not > 0.
    """
    return FORMATS[format_name].write(plan_motion(document), dt)


def export_plan_file(plan_path: str | Path, format_name: str, dt: float = EXPORT_DT_S) -> str:
    """The text of the motion of the plan at `plan_path` in one format, once its robot and
    joint names are found to be those of the robot it names (its bundled model or robot
    folder), as `vprobot check` finds them.

    Raises:
        ValueError: As `export_plan`, and for an unreadable plan, an unknown robot or names
            that are not the robot's.
    """
    document = read_plan(plan_path)
    motion = plan_motion(document)
    robot = plan_robot(document["robot"], Path(plan_path))
    cell = Cell(replace(load_config(None), "cell", robot=robot))
    require_robot(motion, cell.robot.name, cell.joints.names)
    return FORMATS[format_name].write(motion, dt)
