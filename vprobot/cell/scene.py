"""The inspection cell as a MuJoCo model: robot, sensor, fixture and the object to inspect."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import numpy.typing as npt
import trimesh

from vprobot.config import Config
from vprobot.config.cell import Solid
from vprobot.geometry.poses import (
    Pose,
    as_vector,
    quat_to_matrix,
    rotation_about_y,
    rotation_about_z,
)
from vprobot.parts.loading import load_mesh, solid_problem
from vprobot.robots import RobotDescription, load_robot
from vprobot.robots.description import (
    GEOM_GROUP_ROBOT,
    SENSOR_BODY,
    SENSOR_SITE,
    MotionLimits,
    hangs_below,
)

# Geom groups and collision bits of the bundled scenes (see scripts/convert_robots.py).
GEOM_GROUP_OBJECT = 1
ROBOT_BIT, ENVIRONMENT_BIT = 1, 2

NOMINAL_OBJECT_HALF_HEIGHT_M = 0.06
"""Fixture height below the object centre while no object is loaded (a motor lying down)."""

CEILING_HEIGHT_M = 2.2
"""Height of the cell's ceiling, which carries a hanging robot's column."""
WALL_MOUNT_COSINE = 0.2
"""A base whose z axis is within about 78-102 degrees of the vertical hangs on a wall bracket."""
WALL_BRACKET_M = 0.3

ROBOT_STAND_RADIUS_M = 0.09
"""Radius of the column under a raised robot base (about that of the UR10's base link)."""
PLANNING_SLACK_M = 0.005
"""What planning keeps beyond the clearance margins: a path is checked at configurations
`kinematics.path_max_joint_step_rad` apart, and between two of them the arm may pass closer to an
object than at either: without it the UR5's `nbv` plan of the bundled motor came within its 10 mm
of the part between two checked configurations. The replay check holds the margins themselves at
every 2 ms sample (`vprobot check`, `clearance_held` in `vprobot evaluate`)."""
OBJECT_GEOM = "object"
"""The part's geom on the `object` body, made from its mesh."""
HOUSING_GEOM = "sensor_housing"
"""The sensor housing's geom on the sensor body, made from `sensor.housing`."""
FIXTURE_BODY = "fixture"
STATIC_PREFIX = "static:"
"""Prefix of the geom names of the cell's static objects (`static:table`)."""


@dataclasses.dataclass(frozen=True)
class JointSpace:
    """The robot's joints: names, limits (inside the cell's joint-limit margin), velocity limits
    (at the cell's speed scale) and the start configuration."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity_limits: np.ndarray
    start: np.ndarray

    @property
    def dof(self) -> int:
        return len(self.names)

    def within_limits(self, q: np.ndarray, tolerance: float = 1e-9) -> bool:
        return bool(np.all(q >= self.lower - tolerance) and np.all(q <= self.upper + tolerance))

    def check(self, q: npt.ArrayLike, name: str = "joint configuration") -> np.ndarray:
        """Return `q` as a finite vector of the right size, or raise ValueError."""
        return as_vector(q, self.dof, name)


def robot_base_pose(config: Config, robot: RobotDescription) -> Pose:
    """Where the robot's base stands: the config's placement, else the robot's own."""
    cell = config.cell
    position = (cell.robot_base_position_m if cell.robot_base_position_m is not None
                else robot.base_position_m)
    yaw_deg = cell.robot_base_yaw_deg if cell.robot_base_yaw_deg is not None else robot.base_yaw_deg
    tilt_deg = (cell.robot_base_tilt_deg if cell.robot_base_tilt_deg is not None
                else robot.base_tilt_deg)
    rotation = rotation_about_z(np.deg2rad(yaw_deg)) @ rotation_about_y(np.deg2rad(tilt_deg))
    return Pose(np.array(position, dtype=float), rotation)


def stand_length(base: Pose) -> float:
    """Length of the column that carries the base along its -z: down to the floor for an upright
    base, up to the ceiling for a hanging one, a short bracket for a wall mount (0: none)."""
    up = float(base.rotation[2, 2])
    if up > WALL_MOUNT_COSINE:
        return max(float(base.position[2]) / up, 0.0)
    if up < -WALL_MOUNT_COSINE:
        return max((CEILING_HEIGHT_M - float(base.position[2])) / -up, 0.0)
    return WALL_BRACKET_M


class Cell:
    """A compiled inspection cell for one robot, one sensor mount and optionally one object.

    The robot is read through its description (`robot.yaml`): its base is placed where the config
    says, or where the description's default placement puts it.

    The object body and the fixture are mocap bodies, so placing the object for an episode
    (`place_object`) needs no recompilation; a different mesh needs a new `Cell`.

    Args:
        config: Cell and sensor settings.
        object_mesh: The part's mesh, centred at its bounding-box centre, in metres; `None` builds
            the empty cell.

    Raises:
        ValueError: If the robot is unknown or its folder does not match its description, or
            the mesh has no faces, non-finite vertices or lies flat in a plane.
    """

    def __init__(self, config: Config, object_mesh: trimesh.Trimesh | None = None):
        self.config = config
        self.robot: RobotDescription = load_robot(config.cell.robot)
        spec = mujoco.MjSpec.from_file(str(self.robot.scene_path))
        base = spec.body(self.robot.base)
        if base is None:
            raise ValueError(f"robot {self.robot.name}: base {self.robot.base!r} is not a body "
                             f"of {self.robot.model}")
        placement = robot_base_pose(config, self.robot)
        base.pos = list(placement.position)
        base.quat = list(placement.quaternion)
        length = stand_length(placement)
        if length > 0.0 and config.cell.robot_stand:
            self._add_robot_stand(base, length)
        sensor = spec.body(SENSOR_BODY)
        sensor.pos = list(config.sensor.mount_position_m)
        sensor.quat = list(np.asarray(config.sensor.mount_quaternion_wxyz) /
                           np.linalg.norm(config.sensor.mount_quaternion_wxyz))
        self._add_housing(spec, sensor, config.sensor.housing)
        if config.cell.fixture == "none":
            for geom in spec.body(FIXTURE_BODY).geoms:
                spec.delete(geom)
        for item in config.cell.static_objects:
            _add_solid(spec, spec.worldbody, item, STATIC_PREFIX + item.name,
                       [0.55, 0.57, 0.6, 1.0], group=0, contype=ENVIRONMENT_BIT,
                       conaffinity=ROBOT_BIT)
        # The base stands on a table or the floor, bolted down: its contact with them is no
        # collision (the cell's own check refuses a base inside one).
        spec.add_exclude(bodyname1="world", bodyname2=self.robot.base)
        self.object_vertices = np.zeros((0, 3))
        if object_mesh is not None:
            self._add_object(spec, object_mesh)
        self._set_margins(spec)
        self.model = spec.compile()
        self._index_model()
        self.object_center = np.array(config.cell.object_center_m, dtype=float)

    @staticmethod
    def _add_robot_stand(base: mujoco.MjsBody, length_m: float) -> None:
        """The column that carries the robot base, along the base's -z (see `stand_length`)."""
        base.add_geom(
            name="robot_stand",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            fromto=[0.0, 0.0, -length_m, 0.0, 0.0, -0.005],
            size=[ROBOT_STAND_RADIUS_M, 0.0, 0.0],
            rgba=[0.3, 0.32, 0.35, 1.0],
            group=0,
            contype=ENVIRONMENT_BIT,
            conaffinity=ROBOT_BIT,
        )

    @staticmethod
    def _add_housing(spec: mujoco.MjSpec, sensor: mujoco.MjsBody, housing: Solid) -> None:
        """The housing of `sensor.housing` on the sensor body, in place of any the robot's MJCF
        carries (robot folders imported before the housing was the sensor's)."""
        for geom in sensor.geoms:
            if geom.name == HOUSING_GEOM:
                spec.delete(geom)
        _add_solid(spec, sensor, housing, HOUSING_GEOM, [0.15, 0.15, 0.18, 1.0],
                   group=GEOM_GROUP_ROBOT, contype=ROBOT_BIT,
                   conaffinity=ROBOT_BIT | ENVIRONMENT_BIT)

    def _set_margins(self, spec: mujoco.MjSpec) -> None:
        """Every environment geom (static objects, fixture, column, floor) keeps the robot at
        `safety.clearance_m`, the part at `safety.part_clearance_m`, and planning
        `PLANNING_SLACK_M` more: MuJoCo then reports a contact for any robot geom closer than
        that (`CollisionChecker`)."""
        safety = self.config.cell.safety
        for geom in spec.geoms:
            if geom.contype & ENVIRONMENT_BIT:
                geom.margin = PLANNING_SLACK_M + (
                    safety.part_clearance_m if geom.name == OBJECT_GEOM else safety.clearance_m)

    def _add_object(self, spec: mujoco.MjSpec, mesh: trimesh.Trimesh) -> None:
        if len(mesh.faces) == 0:
            raise ValueError("object mesh has no faces")
        # `load_mesh` rejects these with the file's name; this guards meshes built in code, which
        # would otherwise fail deep inside qhull or MuJoCo's compiler.
        problem = solid_problem(mesh)
        if problem is not None:
            raise ValueError(f"object mesh {problem}")
        asset = spec.add_mesh(
            name="object_mesh",
            uservert=np.asarray(mesh.vertices, dtype=np.float32).ravel().tolist(),
            userface=np.asarray(mesh.faces, dtype=np.int32).ravel().tolist(),
        )
        # Only the surface matters to vprobot: a shell inertia tolerates open user meshes.
        asset.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        spec.body("object").add_geom(
            name=OBJECT_GEOM,
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname="object_mesh",
            group=GEOM_GROUP_OBJECT,
            contype=ENVIRONMENT_BIT,
            conaffinity=ROBOT_BIT,
            rgba=[0.78, 0.55, 0.25, 1.0],
        )
        self.object_vertices = np.asarray(mesh.convex_hull.vertices, dtype=float)

    def _index_model(self) -> None:
        model = self.model
        joint_ids = self.robot.check_model(model)
        # The object and fixture are mocap bodies: the robot's joints are the whole of qpos,
        # which lets kinematics write qpos wholesale.
        if model.nq != len(joint_ids) or list(model.jnt_qposadr[joint_ids]) != list(
                range(len(joint_ids))):
            raise ValueError(f"robot {self.robot.name}: qpos must hold the arm's "
                             f"{len(joint_ids)} joints only, found nq={model.nq}")
        names = tuple(model.joint(j).name for j in joint_ids)
        safety = self.config.cell.safety
        # The joint-limit margin narrows the compiled ranges themselves, so that the IK (mink
        # reads jnt_range), the path planner and the replay check all keep it.
        margin = np.deg2rad(safety.joint_limit_margin_deg)
        limited = np.array(joint_ids)[model.jnt_limited[joint_ids].astype(bool)]
        model.jnt_range[limited, 0] += margin
        model.jnt_range[limited, 1] -= margin
        start = self.config.cell.start_joints_rad
        self.joints = JointSpace(
            names=names,
            lower=model.jnt_range[joint_ids, 0].copy(),
            upper=model.jnt_range[joint_ids, 1].copy(),
            velocity_limits=self.motion_limits.velocity,
            start=np.array(self.robot.home if start is None else start, dtype=float),
        )
        self.pan_index = names.index(self.robot.pan_joint)
        self.roll_index = names.index(self.robot.roll_joint)
        self.sensor_site_id = model.site(SENSOR_SITE).id
        self.sensor_body_id = model.body(SENSOR_BODY).id
        self.flange_body_id = model.body(self.robot.flange).id
        self.base_body_id = model.body(self.robot.base).id
        self.pan_body_id = int(model.jnt_bodyid[joint_ids[self.pan_index]])
        self.object_body_id = model.body("object").id
        self.object_mocap_id = model.body_mocapid[self.object_body_id]
        self.fixture_mocap_id = model.body_mocapid[model.body("fixture").id]
        robot_bodies = {b for b in range(model.nbody)
                        if hangs_below(model, b, self.base_body_id)}
        self.robot_geom_ids = np.array(
            [g for g in range(model.ngeom) if model.geom_bodyid[g] in robot_bodies]
        )
        self.object_geom_ids = np.array(
            [g for g in range(model.ngeom) if model.geom_bodyid[g] == self.object_body_id]
        )

    @property
    def motion_limits(self) -> MotionLimits:
        """The robot's motion limits at the cell's speed scale (`MotionLimits.scaled`)."""
        return MotionLimits.of(self.robot).scaled(self.config.cell.safety.speed_scale)

    @property
    def has_object(self) -> bool:
        return len(self.object_vertices) > 0

    @property
    def sensor_mount(self) -> Pose:
        """Sensor frame in the flange frame."""
        return Pose(
            self.model.body_pos[self.sensor_body_id].copy(),
            quat_to_matrix(self.model.body_quat[self.sensor_body_id]),
        )

    @property
    def robot_base(self) -> Pose:
        base = self.base_body_id
        return Pose(self.model.body_pos[base].copy(), quat_to_matrix(self.model.body_quat[base]))

    def make_data(self) -> mujoco.MjData:
        """A fresh MjData at the start configuration with the object placed upright at the
        configured centre."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = self.joints.start
        self.place_object(data, np.eye(3))
        return data

    def place_object(self, data: mujoco.MjData, rotation: np.ndarray) -> Pose:
        """Put the object's centre at the configured point with `rotation`, fixture underneath.

        Returns:
            The object pose in the world.
        """
        pose = Pose(self.object_center.copy(), np.asarray(rotation, dtype=float))
        data.mocap_pos[self.object_mocap_id] = pose.position
        data.mocap_quat[self.object_mocap_id] = pose.quaternion
        if self.has_object:
            lowest = float(np.min((self.object_vertices @ pose.rotation.T)[:, 2]))
        else:
            lowest = -NOMINAL_OBJECT_HALF_HEIGHT_M
        data.mocap_pos[self.fixture_mocap_id] = pose.position + [0.0, 0.0, lowest]
        data.mocap_quat[self.fixture_mocap_id] = [1.0, 0.0, 0.0, 0.0]
        mujoco.mj_kinematics(self.model, data)
        return pose


def _add_solid(spec: mujoco.MjSpec, body: mujoco.MjsBody, solid: Solid, name: str,
               rgba: list[float], group: int, contype: int, conaffinity: int) -> None:
    """Add `solid` to `body` as a geom (a mesh as a mesh asset of the same name)."""
    pose = solid.pose
    geom = body.add_geom(name=name, pos=list(pose.position), quat=list(pose.quaternion),
                         rgba=rgba, group=group, contype=contype, conaffinity=conaffinity)
    if solid.shape == "box":
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [extent / 2.0 for extent in solid.size_m or ()]
    elif solid.shape == "cylinder":
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        geom.size = [solid.radius_m or 0.0, (solid.length_m or 0.0) / 2.0, 0.0]
    else:
        # The file's own origin is the shape's origin: no centring, unlike a part.
        loaded = load_mesh(solid.mesh or "", solid.scale)
        vertices = np.asarray(loaded.mesh.vertices) + loaded.offset
        asset = spec.add_mesh(name=name, uservert=vertices.astype(np.float32).ravel().tolist(),
                              userface=np.asarray(loaded.mesh.faces,
                                                  dtype=np.int32).ravel().tolist())
        asset.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = name
