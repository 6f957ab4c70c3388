"""The inspection cell as a MuJoCo model: robot, sensor, fixture and the object to inspect."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import numpy.typing as npt
import trimesh

from vprobot.config import Config
from vprobot.geometry import Pose, as_vector, matrix_to_quat, quat_to_matrix, rotation_about_z
from vprobot.mesh_loading import solid_problem
from vprobot.robots import FLANGE_FRAME, scene_path

# Geom groups and collision bits of the bundled scenes (see scripts/convert_robots.py).
GEOM_GROUP_OBJECT = 1
ROBOT_BIT, ENVIRONMENT_BIT = 1, 2

NOMINAL_OBJECT_HALF_HEIGHT_M = 0.06
"""Fixture height below the object centre while no object is loaded (a motor lying down)."""

ROBOT_STAND_RADIUS_M = 0.09
"""Radius of the column under a raised robot base (about that of the UR10's base link)."""


@dataclasses.dataclass(frozen=True)
class JointSpace:
    """The robot's joints: names, limits, velocity limits and the home configuration."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity_limits: np.ndarray
    home: np.ndarray

    @property
    def dof(self) -> int:
        return len(self.names)

    def within_limits(self, q: np.ndarray, tolerance: float = 1e-9) -> bool:
        return bool(np.all(q >= self.lower - tolerance) and np.all(q <= self.upper + tolerance))

    def check(self, q: npt.ArrayLike, name: str = "joint configuration") -> np.ndarray:
        """Return `q` as a finite vector of the right size, or raise ValueError."""
        return as_vector(q, self.dof, name)


class Cell:
    """A compiled inspection cell for one robot, one sensor mount and optionally one object.

    The object body and the fixture are mocap bodies, so placing the object for an episode
    (`place_object`) needs no recompilation; a different mesh needs a new `Cell`.

    Args:
        config: Cell and sensor settings.
        object_mesh: The motor mesh, centred at its bounding-box centre, in metres; `None` builds
            the empty cell.

    Raises:
        ValueError: If the robot is unknown, or the mesh has no faces, non-finite vertices or
            lies flat in a plane.
    """

    def __init__(self, config: Config, object_mesh: trimesh.Trimesh | None = None):
        self.config = config
        spec = mujoco.MjSpec.from_file(str(scene_path(config.cell.robot)))
        base = spec.body("base_link")
        base.pos = list(config.cell.robot_base_position_m)
        yaw = rotation_about_z(np.deg2rad(config.cell.robot_base_yaw_deg))
        base.quat = list(matrix_to_quat(yaw))
        if config.cell.robot_base_position_m[2] > 0.0:
            self._add_robot_stand(base, config.cell.robot_base_position_m[2])
        sensor = spec.body("sensor_body")
        sensor.pos = list(config.sensor.mount_position_m)
        sensor.quat = list(np.asarray(config.sensor.mount_quaternion_wxyz) /
                           np.linalg.norm(config.sensor.mount_quaternion_wxyz))
        self.object_vertices = np.zeros((0, 3))
        if object_mesh is not None:
            self._add_object(spec, object_mesh)
        self.model = spec.compile()
        self._index_model()
        self.object_center = np.array(config.cell.object_center_m, dtype=float)

    @staticmethod
    def _add_robot_stand(base: mujoco.MjsBody, height_m: float) -> None:
        """A column under a raised robot base, down to the floor."""
        base.add_geom(
            name="robot_stand",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            fromto=[0.0, 0.0, -height_m, 0.0, 0.0, -0.005],
            size=[ROBOT_STAND_RADIUS_M, 0.0, 0.0],
            rgba=[0.3, 0.32, 0.35, 1.0],
            group=0,
            contype=ENVIRONMENT_BIT,
            conaffinity=ROBOT_BIT,
        )

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
            name="object",
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
        self.robot = self.config.cell.robot
        hinge = mujoco.mjtJoint.mjJNT_HINGE
        joint_ids = [j for j in range(model.njnt) if model.jnt_type[j] == hinge]
        # The object and fixture are mocap bodies: the robot's joints are the whole of qpos,
        # which lets kinematics write qpos wholesale.
        if model.nq != len(joint_ids):
            raise ValueError(f"expected only the robot's {len(joint_ids)} hinge joints in qpos, "
                             f"found nq={model.nq}")
        velocity_limits = model.numeric("joint_velocity_limits").data.copy()
        self.joints = JointSpace(
            names=tuple(model.joint(j).name for j in joint_ids),
            lower=model.jnt_range[joint_ids, 0].copy(),
            upper=model.jnt_range[joint_ids, 1].copy(),
            velocity_limits=velocity_limits,
            home=model.key("home").qpos.copy(),
        )
        self.sensor_site_id = model.site("sensor").id
        self.sensor_body_id = model.body("sensor_body").id
        self.flange_body_id = model.body(FLANGE_FRAME).id
        self.object_body_id = model.body("object").id
        self.object_mocap_id = model.body_mocapid[self.object_body_id]
        self.fixture_mocap_id = model.body_mocapid[model.body("fixture").id]
        robot_root = model.body("base_link").id
        robot_bodies = {b for b in range(model.nbody) if self._has_ancestor(b, robot_root)}
        self.robot_geom_ids = np.array(
            [g for g in range(model.ngeom) if model.geom_bodyid[g] in robot_bodies]
        )
        self.object_geom_ids = np.array(
            [g for g in range(model.ngeom) if model.geom_bodyid[g] == self.object_body_id]
        )

    def _has_ancestor(self, body: int, ancestor: int) -> bool:
        while body != 0:
            if body == ancestor:
                return True
            body = self.model.body_parentid[body]
        return False

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
        base = self.model.body("base_link").id
        return Pose(self.model.body_pos[base].copy(), quat_to_matrix(self.model.body_quat[base]))

    def make_data(self) -> mujoco.MjData:
        """A fresh MjData at `home` with the object placed upright at the configured centre."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = self.joints.home
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
