"""Rigid poses and rotations (quaternions are always w, x, y, z)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import numpy.typing as npt


def as_vector(value: npt.ArrayLike, size: int, name: str) -> np.ndarray:
    """Return `value` as a finite float vector of `size`, or raise ValueError naming `name`."""
    array = np.asarray(value, dtype=float)
    if array.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return array


QUATERNION_NORM_MIN = 1e-9
"""Smallest norm of a quaternion that gives a rotation: one is normalised before use, and a zero
one has no direction (its normalisation divides by zero, and NaN poses compare as within every
tolerance)."""


def is_rotation_quaternion(quat_wxyz: npt.ArrayLike) -> bool:
    """Whether four numbers are a quaternion that gives a rotation: finite, of norm at least
    `QUATERNION_NORM_MIN`."""
    norm = float(np.linalg.norm(np.asarray(quat_wxyz, dtype=float)))
    return QUATERNION_NORM_MIN <= norm < np.inf


def quat_to_matrix(quat_wxyz: npt.ArrayLike) -> np.ndarray:
    """Rotation matrix of a (normalised) w, x, y, z quaternion."""
    quat = as_vector(quat_wxyz, 4, "quaternion")
    norm = np.linalg.norm(quat)
    if norm < QUATERNION_NORM_MIN:
        raise ValueError("quaternion must be non-zero")
    matrix = np.empty(9)
    mujoco.mju_quat2Mat(matrix, quat / norm)
    return matrix.reshape(3, 3)


def matrix_to_quat(rotation: np.ndarray) -> np.ndarray:
    """w, x, y, z quaternion (w >= 0) of a rotation matrix."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).ravel())
    return quat if quat[0] >= 0 else -quat


def rotation_about_x(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_about_y(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_about_z(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def look_at_rotation(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Sensor rotation at `position` whose +z axis points at `target`.

    The image x axis is kept horizontal (perpendicular to world z) where possible, which fixes the
    roll for views that need one; looking straight up or down falls back to world x.

    Raises:
        ValueError: If position and target coincide.
    """
    forward = np.asarray(target, dtype=float) - np.asarray(position, dtype=float)
    distance = np.linalg.norm(forward)
    if distance < 1e-9:
        raise ValueError("look-at target coincides with the sensor position")
    z_axis = forward / distance
    x_axis = np.cross(z_axis, [0.0, 0.0, 1.0])
    if np.linalg.norm(x_axis) < 1e-6:
        x_axis = np.array([1.0, 0.0, 0.0]) - z_axis[0] * z_axis
    x_axis /= np.linalg.norm(x_axis)
    y_axis = np.cross(z_axis, x_axis)
    return np.column_stack([x_axis, y_axis, z_axis])


def spherical_position(phi: float, theta: float, radius: float) -> np.ndarray:
    """Point at azimuth `phi`, polar angle `theta` from +z and distance `radius`."""
    return radius * np.array(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]
    )


def rotation_angle(rotation_a: np.ndarray, rotation_b: np.ndarray) -> float:
    """Angle (rad) of the relative rotation between two rotation matrices."""
    cosine = (np.trace(rotation_a.T @ rotation_b) - 1.0) / 2.0
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)))


def axis_angle(axis_a: np.ndarray, axis_b: np.ndarray) -> float:
    """Angle (rad) between two unit vectors."""
    # Scalar math: this runs in every IK iteration, where numpy's per-call overhead shows.
    return math.acos(max(-1.0, min(1.0, float(axis_a @ axis_b))))


@dataclasses.dataclass(frozen=True)
class Pose:
    """A rigid pose: `rotation` columns are the frame's axes in the parent frame."""

    position: np.ndarray
    rotation: np.ndarray

    @classmethod
    def from_quat(cls, position: npt.ArrayLike, quat_wxyz: npt.ArrayLike) -> Pose:
        return cls(as_vector(position, 3, "position"), quat_to_matrix(quat_wxyz))

    @classmethod
    def look_at(cls, position: npt.ArrayLike, target: npt.ArrayLike) -> Pose:
        """Pose at `position` with +z toward `target` (see `look_at_rotation`)."""
        position = as_vector(position, 3, "position")
        target = as_vector(target, 3, "look-at target")
        return cls(position, look_at_rotation(position, target))

    @property
    def quaternion(self) -> np.ndarray:
        """Orientation as w, x, y, z."""
        return matrix_to_quat(self.rotation)

    @property
    def view_axis(self) -> np.ndarray:
        """The sensor's viewing direction (+z axis)."""
        return self.rotation[:, 2]

    def compose(self, other: Pose) -> Pose:
        """This pose applied to `other` (other expressed in this frame)."""
        return Pose(self.position + self.rotation @ other.position, self.rotation @ other.rotation)

    def inverse(self) -> Pose:
        return Pose(-self.rotation.T @ self.position, self.rotation.T)
