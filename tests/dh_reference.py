"""Reference forward kinematics of the bundled robots from their makers' published DH parameters.

UR5 and UR10: Universal Robots' standard DH table. Franka Emika Panda: the modified (Craig) DH
table of Franka's documentation ("Robot and interface specifications", Denavit-Hartenberg
parameters), flange 0.107 m beyond joint 7.

Independent of MuJoCo and of vprobot's kinematics: the tests compare vprobot's FK and the poses
it exports against these plain functions. Every pose is a 4 x 4 homogeneous transform.
"""

from __future__ import annotations

import numpy as np

from vprobot.config import Config
from vprobot.robots import load_robot

# Universal Robots' published DH parameters (standard DH, metres).
UR_DH = {
    "ur5": {
        "d": [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823],
        "a": [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0],
    },
    "ur10": {
        "d": [0.1273, 0.0, 0.0, 0.163941, 0.1157, 0.0922],
        "a": [0.0, -0.612, -0.5723, 0.0, 0.0, 0.0],
    },
}
UR_ALPHA = [np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0]

# Franka's published modified DH parameters (a_{i-1}, d_i, alpha_{i-1}) of joints 1-7 and the
# flange (theta fixed at 0), metres and radians.
PANDA_MDH = [
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.316, np.pi / 2),
    (0.0825, 0.0, np.pi / 2),
    (-0.0825, 0.384, -np.pi / 2),
    (0.0, 0.0, np.pi / 2),
    (0.088, 0.0, np.pi / 2),
    (0.0, 0.107, 0.0),
]


def transform(position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Homogeneous transform of a position and a rotation matrix."""
    result = np.eye(4)
    result[:3, :3], result[:3, 3] = rotation, position
    return result


def quaternion_matrix(quat_wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix of a w, x, y, z quaternion (normalised here)."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=float) / np.linalg.norm(quat_wxyz)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def yaw_matrix(angle_rad: float) -> np.ndarray:
    """Rotation about the z axis."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def ur_flange(q: np.ndarray, robot: str) -> np.ndarray:
    """UR flange (`tool0`) pose in the UR controller's base frame from the standard DH table."""
    result = np.eye(4)
    for theta, d, a, alpha in zip(q, UR_DH[robot]["d"], UR_DH[robot]["a"], UR_ALPHA, strict=True):
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        result = result @ np.array(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
             [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]]
        )
    return result


def panda_flange(q: np.ndarray) -> np.ndarray:
    """Panda flange pose in its base frame from the modified DH table:
    T_i = RotX(alpha_{i-1}) TransX(a_{i-1}) RotZ(theta_i) TransZ(d_i)."""
    result = np.eye(4)
    for theta, (a, d, alpha) in zip([*q, 0.0], PANDA_MDH, strict=True):
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        result = result @ np.array(
            [[ct, -st, 0.0, a], [st * ca, ct * ca, -sa, -d * sa],
             [st * sa, ct * sa, ca, d * ca], [0.0, 0.0, 0.0, 1.0]]
        )
    return result


def dh_flange(q: np.ndarray, robot: str) -> np.ndarray:
    """Flange pose in the maker's base frame of the DH chain."""
    return panda_flange(q) if robot == "panda" else ur_flange(q, robot)


def controller_base(config: Config) -> np.ndarray:
    """The maker's base frame (where the DH chain starts) in the world, from the cell config.

    The robot description's base body sits at `robot_base_position_m`, turned by
    `robot_base_yaw_deg` about world z and then by `robot_base_tilt_deg` about its own y (the
    robot's own placement where the config leaves them unset). For the URs the controller's
    base frame is `base_link` turned half a turn about z; Franka's coincides with `panda_link0`.
    """
    cell = config.cell
    robot = load_robot(cell.robot)
    position = (cell.robot_base_position_m if cell.robot_base_position_m is not None
                else robot.base_position_m)
    yaw = np.deg2rad(cell.robot_base_yaw_deg if cell.robot_base_yaw_deg is not None
                     else robot.base_yaw_deg)
    tilt = np.deg2rad(cell.robot_base_tilt_deg if cell.robot_base_tilt_deg is not None
                      else robot.base_tilt_deg)
    c, s = np.cos(tilt), np.sin(tilt)
    rotation = yaw_matrix(yaw) @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    if robot.name != "panda":
        rotation = rotation @ yaw_matrix(np.pi)
    return transform(np.asarray(position, dtype=float), rotation)


def sensor_mount(config: Config) -> np.ndarray:
    """The sensor frame in the flange frame, from the sensor config."""
    sensor = config.sensor
    return transform(np.asarray(sensor.mount_position_m, dtype=float),
                     quaternion_matrix(sensor.mount_quaternion_wxyz))


def world_flange(q: np.ndarray, config: Config) -> np.ndarray:
    """Flange pose in the world for joints `q` of the configured robot."""
    return controller_base(config) @ dh_flange(np.asarray(q, dtype=float), config.cell.robot)


def world_sensor(q: np.ndarray, config: Config) -> np.ndarray:
    """Sensor pose (+z viewing direction) in the world for joints `q` of the configured robot."""
    return world_flange(q, config) @ sensor_mount(config)


def rotation_difference(rotation_a: np.ndarray, rotation_b: np.ndarray) -> float:
    """Angle (rad) of the rotation between two rotation matrices."""
    cosine = (np.trace(rotation_a.T @ rotation_b) - 1.0) / 2.0
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)))
