"""The robot contract: the `robot.yaml` every robot folder carries, and its validation.

A robot folder (MuJoCo Menagerie layout) holds `<name>.xml` (the arm with vprobot's sensor body on
its flange), `scene.xml` (the arm in the inspection cell), `meshes/`, `LICENSE`, `README.md` and
`robot.yaml`, which says what vprobot needs to know about the arm and cannot read off the MJCF:
which body is the base and which the flange, which joint pans the arm and which rolls the sensor,
the home configuration, the joints' velocity, acceleration and jerk limits and where the base stands
in the cell.
Everything in vprobot reads the arm through this description; no code names a robot's links.
"""

from __future__ import annotations

import dataclasses
import textwrap
from collections.abc import Mapping
from pathlib import Path

import mujoco
import numpy as np
import yaml

from vprobot.files.paths import DESCRIPTION_FILE
from vprobot.files.schema import ConfigError, Vec3, brief, from_mapping, read_yaml

SCENE_FILE = "scene.xml"
SUPPORTED_DOF = (6, 7)

SENSOR_BODY = "sensor_body"
SENSOR_SITE = "sensor"
SENSOR_CAMERA = "sensor_camera"
"""vprobot's sensor mount, added on the flange by the converter: a body, the optical centre site
(+z viewing direction) and a camera for the renderer's sensor panel."""
GEOM_GROUP_ROBOT = 2
"""The geom group of the arm's geoms (0 environment, 1 object), which the converter writes and
the arm's sight check casts rays against (`RobotArm.hides`)."""

LIMIT_KEYS = ("velocity_limits_rad_s", "acceleration_limits_rad_s2", "jerk_limits_rad_s3")
"""The per-joint motion limits of `robot.yaml`, which time the trajectories
(`vprobot.kinematics.trajectory`)."""

ASSUMED_ACCELERATION_RAD_S2 = 5.0
ASSUMED_JERK_RAD_S3 = 100.0
ASSUMED_LIMIT_SOURCES = {
    "acceleration_limits_rad_s2": (
        "ASSUMPTION, not a maker's figure (Universal Robots publishes none; a URDF carries "
        "none): 5.0 rad/s^2 per joint, what Universal Robots' ROS 2 driver gives MoveIt to time "
        "trajectories (Universal_Robots_ROS2_Driver, ur_moveit_config/config/joint_limits.yaml: "
        "'the robot does not inherently have any limits on joint accelerations (only on "
        "torques)', values 'chosen conservatively'). Put the maker's limits here where "
        "published."),
    "jerk_limits_rad_s3": (
        "ASSUMPTION, not a maker's figure (Universal Robots publishes none; a URDF carries "
        "none): 100 rad/s^3 per joint, the jerk limit MoveIt's Ruckig smoothing applies to a "
        "joint without one (moveit ruckig_traj_smoothing.cpp, DEFAULT_MAX_JERK). Put the "
        "maker's limits here where published."),
}
"""The acceleration and jerk limits `vprobot robots import` writes (a URDF carries neither), and
the UR robots' limits (Universal Robots publishes neither), with the comments that say so."""


@dataclasses.dataclass(frozen=True)
class MotionLimits:
    """Per-joint velocity (rad/s), acceleration (rad/s^2) and jerk (rad/s^3) limits, which time
    the trajectories (`vprobot.kinematics.trajectory`)."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray

    @classmethod
    def of(cls, robot: RobotDescription) -> MotionLimits:
        """The limits of a robot's description (`robot.yaml`)."""
        return cls(np.array(robot.velocity_limits_rad_s),
                   np.array(robot.acceleration_limits_rad_s2), np.array(robot.jerk_limits_rad_s3))

    def scaled(self, speed_scale: float) -> MotionLimits:
        """The limits at speed scale s: velocity times s, acceleration times s^2, jerk times
        s^3, which time the same paths 1/s slower (a controller's speed slider)."""
        return MotionLimits(self.velocity * speed_scale, self.acceleration * speed_scale ** 2,
                            self.jerk * speed_scale ** 3)

    @property
    def dof(self) -> int:
        return len(self.velocity)


@dataclasses.dataclass(frozen=True)
class RobotDescription:
    """What vprobot knows about an arm (`robot.yaml`, every key required).

    Attributes:
        name: The robot's name (its folder name for the bundled robots).
        model: The MJCF file of the arm, relative to the folder.
        base: Body at the root of the arm; the cell moves it to the base placement.
        flange: Body of the flange frame, which carries the sensor.
        pan_joint: The first joint of the chain, which turns the whole arm about the base.
        roll_joint: The joint that turns the sensor about (nearly) its optical axis.
        home: The configuration episodes start from (rad).
        velocity_limits_rad_s: Joint velocity limits (rad/s), for the travel cost `joint_time`
            and the timed trajectories.
        acceleration_limits_rad_s2: Joint acceleration limits (rad/s^2) of the timed
            trajectories.
        jerk_limits_rad_s3: Joint jerk limits (rad/s^3) of the timed trajectories.
        base_position_m: Default position of the base in the cell (world frame).
        base_yaw_deg: Default rotation of the base about the world z axis.
        base_tilt_deg: Default rotation of the base about its own y axis after the yaw (0
            floor, 90 wall, 180 ceiling).
        folder: The robot folder (not a key of the file).
    """

    name: str
    model: str
    base: str
    flange: str
    pan_joint: str
    roll_joint: str
    home: tuple[float, ...]
    velocity_limits_rad_s: tuple[float, ...]
    acceleration_limits_rad_s2: tuple[float, ...]
    jerk_limits_rad_s3: tuple[float, ...]
    base_position_m: Vec3
    base_yaw_deg: float
    base_tilt_deg: float
    folder: Path = Path()

    @property
    def scene_path(self) -> Path:
        return self.folder / SCENE_FILE

    @property
    def dof(self) -> int:
        return len(self.home)

    @classmethod
    def load(cls, folder: str | Path) -> RobotDescription:
        """Read and check `robot.yaml` of a robot folder (the MJCF is checked by `check_model`).

        Raises:
            ConfigError: If the file is missing, not YAML, lacks a key, has an unknown one or a
                value of the wrong type; the message names the file and the piece.
        """
        folder = Path(folder)
        path = folder / DESCRIPTION_FILE
        if not path.is_file():
            raise ConfigError(f"robot folder {folder} has no {DESCRIPTION_FILE} (the robot "
                              f"description; `vprobot robots import` writes one)")
        data = read_yaml(path)
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: must be a mapping of the robot's keys")
        required = [field.name for field in dataclasses.fields(cls) if field.name != "folder"]
        missing = [key for key in required if key not in data]
        if missing:
            hint = (" (a folder written before vprobot timed trajectories: add the joints' "
                    "limits, see docs/cell-and-robots.md#motion-limits)"
                    if missing[0] in LIMIT_KEYS else "")
            raise ConfigError(f"{path}: missing {missing[0]!r}; a robot description needs "
                              f"{', '.join(required)}{hint}")
        if "folder" in data:
            raise ConfigError(f"{path}: unknown key 'folder'; allowed keys: {', '.join(required)}")
        try:
            description = from_mapping(cls, data)
        except ConfigError as error:
            raise ConfigError(f"{path}: {error}") from None
        description = dataclasses.replace(description, folder=folder)
        if description.dof not in SUPPORTED_DOF:
            raise ConfigError(f"{path}: home has {description.dof} joints; vprobot supports "
                              f"arms with {' or '.join(map(str, SUPPORTED_DOF))} joints")
        for key in LIMIT_KEYS:
            limits = getattr(description, key)
            if len(limits) != description.dof:
                raise ConfigError(f"{path}: {key} has {len(limits)} values, home "
                                  f"{description.dof}")
            if min(limits) <= 0:
                raise ConfigError(f"{path}: {key} must be > 0, got {list(limits)}")
        for file in (description.model, SCENE_FILE):
            if not (folder / file).is_file():
                raise ConfigError(f"robot folder {folder} has no {file}")
        return description

    def to_yaml(self, sources: Mapping[str, str] | None = None) -> str:
        """The description as `robot.yaml` text.

        Args:
            sources: Where values come from, by key: each is written as a comment above its key.
        """
        data = dataclasses.asdict(self)
        del data["folder"]
        for key in ("home", *LIMIT_KEYS, "base_position_m"):
            data[key] = [round(float(value), 6) for value in data[key]]
        lines = [f"# vprobot robot description of {self.name} (see vprobot/robots/"
                 f"description.py)."]
        for line in yaml.safe_dump(data, sort_keys=False, default_flow_style=None).splitlines():
            key = line.partition(":")[0]
            if sources and key in sources:
                lines += [f"# {text}" for text in textwrap.wrap(sources[key], 97)]
            lines.append(line)
        return "\n".join(lines) + "\n"

    def chain_joints(self, model: mujoco.MjModel) -> list[int]:
        """Ids of the joints from the base to the flange, in chain order.

        Raises:
            ValueError: If the base or flange body is missing, the flange does not hang below
                the base, or a joint of the chain is not a hinge.
        """
        base, flange = (self._body_id(model, key) for key in ("base", "flange"))
        chain: list[int] = []
        body = flange
        while body != base:
            if body == 0:
                raise ValueError(f"robot {self.name}: flange {self.flange!r} does not hang below "
                                 f"base {self.base!r} in {self.model}")
            first, count = model.body_jntadr[body], model.body_jntnum[body]
            chain[:0] = range(first, first + count)
            body = model.body_parentid[body]
        for joint in chain:
            if model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
                kind = mujoco.mjtJoint(model.jnt_type[joint]).name
                raise ValueError(f"robot {self.name}: joint {model.joint(joint).name!r} is "
                                 f"{kind}; vprobot arms have revolute joints only")
        return chain

    def check_model(self, model: mujoco.MjModel) -> list[int]:
        """Check the compiled cell against the description; return the chain's joint ids.

        Raises:
            ValueError: Naming the missing or inconsistent piece: a body, joint, site or camera
                that is not in the model, a joint count that differs from `home`, a home outside
                the joint limits, or a `home` keyframe that disagrees with `robot.yaml`.
        """
        joints = self.chain_joints(model)
        names = [model.joint(j).name for j in joints]
        where = f"robot {self.name} ({self.folder / DESCRIPTION_FILE})"
        if len(joints) != self.dof:
            raise ValueError(f"{where}: home has {self.dof} joints, the chain from "
                             f"{self.base!r} to {self.flange!r} has {len(joints)}: {names}")
        for key in ("pan_joint", "roll_joint"):
            if getattr(self, key) not in names:
                raise ValueError(f"{where}: {key} {brief(getattr(self, key))} is not a joint "
                                 f"of the chain {names}")
        if names[0] != self.pan_joint:
            raise ValueError(f"{where}: pan_joint must be the first joint of the chain "
                             f"({names[0]!r}), got {brief(self.pan_joint)}")
        sensor = self._named(model, mujoco.mjtObj.mjOBJ_BODY, SENSOR_BODY, "sensor body")
        if not hangs_below(model, sensor, self._body_id(model, "flange")):
            raise ValueError(f"{where}: {SENSOR_BODY!r} must hang below the flange "
                             f"{self.flange!r}")
        self._named(model, mujoco.mjtObj.mjOBJ_SITE, SENSOR_SITE, "sensor site")
        self._named(model, mujoco.mjtObj.mjOBJ_CAMERA, SENSOR_CAMERA, "sensor camera")
        home = np.asarray(self.home)
        lower, upper = model.jnt_range[joints, 0], model.jnt_range[joints, 1]
        outside = np.flatnonzero((home < lower - 1e-9) | (home > upper + 1e-9))
        if len(outside):
            j = outside[0]
            raise ValueError(f"{where}: home[{j}] = {home[j]} lies outside {names[j]}'s limits "
                             f"[{lower[j]:.4f}, {upper[j]:.4f}]")
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
        if key >= 0 and not np.allclose(model.key_qpos[key][: len(home)], home, atol=1e-6):
            raise ValueError(f"{where}: the 'home' keyframe of {self.model} differs from "
                             f"robot.yaml's home {list(self.home)}")
        return joints

    def _body_id(self, model: mujoco.MjModel, key: str) -> int:
        return self._named(model, mujoco.mjtObj.mjOBJ_BODY, getattr(self, key), key)

    def _named(self, model: mujoco.MjModel, kind: mujoco.mjtObj, name: str, piece: str) -> int:
        index = mujoco.mj_name2id(model, kind, name)
        if index < 0:
            raise ValueError(f"robot {self.name}: {piece} {brief(name)} is not in {self.model} "
                             f"({self.folder})")
        return index


def hangs_below(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    """Whether `body` is `ancestor` or one of its descendants."""
    while body != 0:
        if body == ancestor:
            return True
        body = model.body_parentid[body]
    return False
