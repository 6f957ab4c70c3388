"""What an export format is, and the registry of them (docs/motion.md#export)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vprobot.cell.scene import Cell
from vprobot.config import load_config, replace
from vprobot.export import EXPORT_DT_S
from vprobot.export.motion import PlanMotion, plan_motion, require_robot
from vprobot.extensions.registry import Bundled, Registry
from vprobot.plan import plan_robot, read_plan

Writer = Callable[[PlanMotion, float], str]
"""A format's writer: the plan's motion and the sampling step (s) -> the file's text."""


@dataclasses.dataclass(frozen=True)
class ExportFormat:
    """One file format a plan's motion is written in.

    Attributes:
        name: Its name in `FORMATS` (`vprobot export --format NAME`).
        suffix: The suffix the output file must have (`.json`).
        description: What the file is, for `vprobot export --help`.
        write: Its writer.
    """

    name: str
    suffix: str
    description: str
    write: Writer


_PACKAGE = "vprobot.export.formats"

FORMATS: Registry[ExportFormat] = Registry(
    "export format",
    facts={"suffix": "", "description": ""},
    bundled={
        "acquisitions": Bundled(f"{_PACKAGE}.acquisitions:acquisitions_json", suffix=".json",
                                description="the acquisitions' times, joints and sensor poses"),
        "csv": Bundled(f"{_PACKAGE}.csv:trajectory_csv", suffix=".csv",
                       description="the sampled joint trajectory as CSV"),
        "ros2": Bundled(f"{_PACKAGE}.ros2:follow_joint_trajectory_yaml", suffix=".yaml",
                        description="a ROS 2 FollowJointTrajectory goal as YAML"),
        "trajectory": Bundled(f"{_PACKAGE}.trajectory:trajectory_json", suffix=".json",
                              description="the sampled joint trajectory as JSON"),
        "urscript": Bundled(f"{_PACKAGE}.urscript:urscript", suffix=".script",
                            description="a URScript program (UR robots)"),
    })
"""Every export format by name, in name order: the bundled ones (declared here, each a module of
this package; tests/test_registries.py checks this index against the modules) and those of
plugins."""


def register_format(name: str, suffix: str, description: str) -> Callable[[Writer], Writer]:
    """Function decorator: registers the writer it decorates as the format `name`.

    Raises:
        ValueError: If a format of that name is already registered.
    """

    def register(write: Writer) -> Writer:
        FORMATS.register_named(ExportFormat(name, suffix, description, write))
        return write

    return register


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
