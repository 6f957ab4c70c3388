"""What an export format is, and the registry of them (docs/motion.md#export): light to
import, as `vprobot export --help` lists the formats; `vprobot.export.program` writes one."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

from vprobot.extensions.registry import Bundled, Registry

if TYPE_CHECKING:
    # Light to import, so that `vprobot export --help` lists the formats at once: the motion
    # of a plan (MuJoCo, the time laws) is what a writer is handed, not what it is named by.
    from vprobot.export.motion import PlanMotion

Writer = Callable[["PlanMotion", float], str]
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
