"""Does an object fit the inspection cell? Checked up front, before any ground truth or planning.

Every view of vprobot (ground truth, candidates, planners) puts the sensor on the view sphere:
at the working distance d from the object centre, looking at the centre. The sensor measures
hits at ranges [near, far] within its opening angles, so a point at range s and angle alpha off
the optical axis lies sqrt(d^2 + s^2 - 2 d s cos(alpha)) from the centre. Over the inscribed
cone of the frustum (alpha <= beta, half the smaller opening angle) that distance is largest at
s = near (or s = far, should the range lie beyond d) and alpha = beta:

    sensor_limit = sqrt(d^2 + near^2 - 2 d near cos(beta))

and beyond it only the corners of a frame reach (up to 0.207 m for the paper's sensor). The
object turns about its centre (episode rotations and tilts), so what counts is its
bounding-sphere radius about that centre (the centre of its bounding box, which the views look
at). With the paper's sensor (d = 0.47 m, near = 0.30 m, 27 x 25 degrees) the limit is
0.189 m: a bounding sphere up to 0.377 m across.

Measured on the default cell: the bundled motors reach at most 0.133 m (70 % of the limit). A
0.218 m cube (radius 0.1888 m, at the limit) and motor_000 scaled by 1.65 (0.188 m) lie wholly
in their ground truth and reach the 90 % goal within the 10-view budget, with the robot and
free-flying; a 0.225 m cube (0.195 m) no longer reaches it, and beyond about 0.2 m of radius
the far ends of an object silently drop out of the ground truth (motor_000 x 2: its last
26 mm; x 2.5: a quarter of its surface). Much larger objects also block the robot: a 0.8 m box
engulfs its base, and no configuration is collision-free.

The cell adds two clearances, which bind only for unusual placements: the object must stay
above the floor (z = 0) and clear of the robot base and the column that carries it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from vprobot.cell.scene import ROBOT_STAND_RADIUS_M, robot_base_pose, stand_length
from vprobot.config import Config
from vprobot.config.sensor import SensorModel
from vprobot.parts.loading import MIN_EXTENT_M, LoadedMesh, scale_setting
from vprobot.robots import load_robot

_PLAUSIBLE_MIN_EXTENT_M = 0.05
"""A unit hint must give at least this size: a 2 cm starter motor is a unit mistake too."""

_UNITS = (("metres", 1.0), ("millimetres", 1e-3), ("centimetres", 1e-2), ("inches", 0.0254))


@dataclasses.dataclass(frozen=True)
class FitLimit:
    """The largest bounding-sphere radius the cell allows, and what sets it.

    Attributes:
        radius_m: Largest radius about the object centre.
        reason: Which part of the cell sets it, as a clause for an error message.
    """

    radius_m: float
    reason: str


def segment_distance(point: np.ndarray, start: np.ndarray, end: np.ndarray) -> float:
    """Distance from `point` to the segment from `start` to `end`."""
    along = end - start
    length2 = float(along @ along)
    fraction = 0.0 if length2 == 0.0 else float(np.clip((point - start) @ along / length2, 0, 1))
    return float(np.linalg.norm(point - (start + fraction * along)))


def sensor_limit_m(config: Config) -> float:
    """Farthest distance from the object centre that any view on the view sphere measures."""
    sensor = SensorModel.from_config(config.sensor)
    d = sensor.working_distance_m
    cos_beta = math.cos(sensor.inscribed_cone_angle_rad)
    # The distance is convex in the range s, so its largest value is at an end of [near, far].
    return max(math.sqrt(max(d * d + s * s - 2.0 * d * s * cos_beta, 0.0))
               for s in (sensor.near_m, sensor.far_m))


def fit_limit(config: Config) -> FitLimit:
    """The bounding-sphere radius an object may have in this cell (see the module docstring)."""
    sensor = config.sensor
    center = np.asarray(config.cell.object_center_m, dtype=float)
    base = robot_base_pose(config, load_robot(config.cell.robot))
    column_end = base.position - stand_length(base) * base.rotation[:, 2]
    limits = [
        FitLimit(sensor_limit_m(config),
                 f"the sensor, {sensor.working_distance_m:g} m from the centre and measuring from "
                 f"{sensor.near_m:g} m on, sees nothing farther than that from the centre"),
        FitLimit(float(center[2]), "the object would reach through the floor"),
        FitLimit(segment_distance(center, base.position, column_end) - ROBOT_STAND_RADIUS_M,
                 "the object would reach the robot base or its column"),
    ]
    return min(limits, key=lambda limit: limit.radius_m)


def _scale_hint(radius: float, extent: float, scale: float, limit: float, option: str) -> str:
    """Suggest the file unit that makes the object fit, else the largest scale that does."""
    for unit, factor in _UNITS:
        if math.isclose(factor, scale, rel_tol=1e-9):
            continue
        if radius / scale * factor <= limit and extent / scale * factor >= _PLAUSIBLE_MIN_EXTENT_M:
            return f"did you mean {scale_setting(factor, option)} (file in {unit})?"
    largest = float(f"{scale * limit / radius:.3g}")
    return f"{scale_setting(largest, option)} or less would make it fit"


def check_fits(mesh: LoadedMesh, config: Config, scale_option: str = "scale") -> None:
    """Raise ValueError unless the loaded object fits the cell of `config`.

    Args:
        mesh: The loaded object.
        config: The configuration whose cell it must fit.
        scale_option: How the user set the mesh's scale (`mesh_loading.scale_setting`): the
            hint names it.

    Raises:
        ValueError: If its bounding-sphere radius about its centre exceeds `fit_limit(config)`;
            the message gives its size, the limit and a scale hint.
    """
    limit = fit_limit(config)
    if limit.radius_m < MIN_EXTENT_M / 2.0:
        raise ValueError(f"the cell of this config has room for no object: {limit.reason} "
                         f"(limit {limit.radius_m:.3g} m); check cell.object_center_m and the "
                         f"sensor settings")
    radius = float(np.linalg.norm(mesh.mesh.vertices, axis=1).max())
    if radius <= limit.radius_m:
        return
    extents = " x ".join(f"{x:.3g}" for x in mesh.mesh.extents)
    hint = _scale_hint(radius, float(mesh.mesh.extents.max()), mesh.scale, limit.radius_m,
                       scale_option)
    raise ValueError(
        f"{mesh.path} does not fit the cell: at {scale_setting(mesh.scale, scale_option)} it "
        f"measures {extents} m, {radius:.3g} m from its centre to its farthest point, but the "
        f"cell allows {limit.radius_m:.3g} m (a bounding sphere {2.0 * limit.radius_m:.3g} m "
        f"across): {limit.reason}; {hint}"
    )
