"""Action mappings: an action in [-1, 1]^n to a requested sensor pose
(docs/states-actions-rewards.md#actions).

Spherical (phi azimuth, theta polar angle from +z, r) and Cartesian coordinates are in the
object-centred frame: origin at the object's centre, axes parallel to the world's (z up).
Absolute orientations are ZYZ Euler angles with the roll gamma = 0, R = Rz(alpha) Ry(beta):
the viewing axis is then (sin b cos a, sin b sin a, cos b). The `_lim` variants look at the
centre and deviate by d_alpha about the sensor's y axis (pan) and d_beta about its x axis (tilt).

`A_view` is discrete: action k requests the k-th band candidate (`vprobot.episode.views`), the
look-at view at the working distance that `nbv` requests as its candidate k.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from vprobot.config import ActionName, EnvConfig
from vprobot.episode.views import band_directions
from vprobot.geometry.poses import (
    Pose,
    look_at_rotation,
    rotation_about_x,
    rotation_about_y,
    rotation_about_z,
    spherical_position,
)
from vprobot.kinematics import SensorTarget

ACTION_SIZES: dict[str, int] = {
    "A_2S0R": 2, "A_3S0R": 3, "A_2S2R": 4, "A_2S2R_lim": 4,
    "A_3S2R": 5, "A_3S2R_lim": 5, "A_3C0R": 3, "A_3C2R": 5,
}
"""Components of the continuous (Box) variants."""
VIEW_ACTION = "A_view"
"""The discrete variant: the index of a band candidate."""


def _unit(value: float, low: float, high: float) -> float:
    """Map a in [-1, 1] linearly onto [low, high]."""
    return low + (value + 1.0) / 2.0 * (high - low)


def euler_rotation(alpha: float, beta: float) -> np.ndarray:
    """Sensor rotation of ZYZ Euler angles (alpha, beta, gamma=0)."""
    return rotation_about_z(alpha) @ rotation_about_y(beta)


class ActionMapping:
    """Maps actions of one variant onto requested views.

    Args:
        config: The environment config (variant, npk/wpk ranges, deviation limit).
        working_distance_m: The sensor's optimal distance (the fixed radius).

    Raises:
        ValueError: If the action variant is unknown.
    """

    def __init__(self, config: EnvConfig, working_distance_m: float):
        if config.action not in (*ACTION_SIZES, VIEW_ACTION):
            raise ValueError(f"unknown action {config.action!r}; allowed: "
                             f"{[*ACTION_SIZES, VIEW_ACTION]}")
        self.name: ActionName = config.action
        self.discrete = config.action == VIEW_ACTION
        if self.discrete:
            self.directions = band_directions()
        self.view_size = 1 if self.discrete else ACTION_SIZES[config.action]
        # With a stop decision the last component says "stop here" when it is > 0.
        self.size = self.view_size + (1 if config.stop_action else 0)
        self.config = config
        self.working_distance_m = working_distance_m
        self.deviation_rad = np.deg2rad(config.deviation_limit_deg)

    @property
    def space(self) -> gym.spaces.Space:
        """The action space: Discrete(candidates) for `A_view`, else Box [-1, 1]^size."""
        if self.discrete:
            return gym.spaces.Discrete(len(self.directions))
        return gym.spaces.Box(-1.0, 1.0, (self.size,), dtype=np.float32)

    def candidate(self, action: np.ndarray | int) -> int:
        """The band candidate an `A_view` action requests: one integer in [0, count).

        Raises:
            ValueError: Naming the bad action and what is allowed.
        """
        array = np.asarray(action)
        count = len(self.directions)
        if (array.size != 1 or not np.issubdtype(array.dtype, np.integer)
                or not 0 <= int(array.reshape(-1)[0]) < count):
            raise ValueError(f"action for {VIEW_ACTION} must be one integer in [0, {count}), "
                             f"got {array.tolist()!r}")
        return int(array.reshape(-1)[0])

    def check(self, action: np.ndarray | int) -> np.ndarray:
        """Validate an action: shape (size,), finite, every component in [-1, 1].

        Raises:
            ValueError: Naming the bad shape or values and what is allowed.
        """
        array = np.asarray(action, dtype=float)
        if array.shape != (self.size,):
            stop = " plus a stop component" if self.size > self.view_size else ""
            raise ValueError(
                f"action for {self.name}{stop} must have shape ({self.size},), got "
                f"{array.shape}"
            )
        if not np.all(np.isfinite(array)):
            raise ValueError(f"action must be finite, got {array.tolist()}")
        if np.any(np.abs(array) > 1.0 + 1e-6):
            raise ValueError(f"action components must lie in [-1, 1], got {array.tolist()}")
        return np.clip(array, -1.0, 1.0)

    def _radius(self, value: float) -> float:
        if self.config.position_mapping == "wpk":
            return self.working_distance_m
        return _unit(value, *self.config.radius_range_m)

    def _cartesian(self, values: np.ndarray) -> np.ndarray:
        if self.config.position_mapping == "npk":
            return values * self.config.cartesian_range_m
        low, high = self.config.wpk_distance_range_m
        point = values * high
        distance = np.linalg.norm(point)
        # The centre itself has no direction: a zero action views from straight above.
        direction = point / distance if distance > 1e-9 else np.array([0.0, 0.0, 1.0])
        return direction * np.clip(distance, low, high)

    def target(self, action: np.ndarray | int, center: np.ndarray, roll_free: bool,
               ) -> SensorTarget:
        """The requested sensor pose of an action in the world, around the object `center`.

        A look-at view with a free roll leaves the rotation about the optical axis to the IK.

        Raises:
            ValueError: For an action of the wrong shape, NaN or outside [-1, 1].
        """
        requested = self.view(action)
        pose = Pose(requested.pose.position + center, requested.pose.rotation)
        if requested.look_at_point is not None and roll_free:
            return SensorTarget.look_at(pose.position, center)
        return SensorTarget(pose, roll_free=roll_free)

    def stops(self, action: np.ndarray | int) -> bool:
        """Whether the action decides to stop (only with `stop_action`).

        Raises:
            ValueError: For an invalid action.
        """
        return bool(self.config.stop_action and self.check(action)[-1] > 0.0)

    def view(self, action: np.ndarray | int) -> SensorTarget:
        """The requested view of a (validated) action, in the object-centred frame: a look-at
        view (its roll left free) looks at the origin, the object's centre."""
        if self.discrete:
            return self._look_at_center(self.working_distance_m
                                        * self.directions[self.candidate(action)])
        a = self.check(action)[: self.view_size]
        name = self.name
        if name in ("A_3C0R", "A_3C2R"):
            position = self._cartesian(a[:3])
            angles = a[3:]
        else:
            phi = _unit(a[0], 0.0, 2.0 * np.pi)
            theta = _unit(a[1], 0.0, np.pi)
            with_radius = name.startswith("A_3S")
            radius = self._radius(a[2]) if with_radius else self.working_distance_m
            position = spherical_position(phi, theta, radius)
            angles = a[3:] if with_radius else a[2:]
        if name.endswith("0R"):
            return self._look_at_center(position)
        if name.endswith("_lim"):
            looking = self._look_at_center(position)
            pan = angles[0] * self.deviation_rad
            tilt = angles[1] * self.deviation_rad
            rotation = looking.pose.rotation @ rotation_about_y(pan) @ rotation_about_x(tilt)
            return SensorTarget(Pose(position, rotation), roll_free=False)
        alpha = _unit(angles[0], 0.0, 2.0 * np.pi)
        beta = _unit(angles[1], 0.0, np.pi)
        return SensorTarget(Pose(position, euler_rotation(alpha, beta)), roll_free=False)

    @staticmethod
    def _look_at_center(position: np.ndarray) -> SensorTarget:
        if np.linalg.norm(position) < 1e-9:
            # At the centre there is nothing to look at: look down by convention.
            return SensorTarget(Pose(position, np.diag([1.0, -1.0, -1.0])), roll_free=False)
        return SensorTarget(Pose(position, look_at_rotation(position, np.zeros(3))),
                            roll_free=True, look_at_point=np.zeros(3))
