"""The `structured_light` sensing model: a camera and a projector a baseline apart, as the
structured-light devices of the presets are built (docs/sensor.md#sensing):

- the projector's optical centre lies at `baseline_m` along the sensor's +x axis, its axes
  parallel to the camera's (the sensor frame stays the camera's); a point counts only where the
  projector reaches it unoccluded (the triangulation shadow; the object, the robot and the fixture
  all cast it);
- a point counts only where the camera ray and the projector ray meet the surface within their
  incidence limits (the angle between the ray and the surface normal), from the same side;
- the measured distance along the camera ray carries Gaussian noise of standard deviation
  sigma(z, theta) = noise_sigma_m * (z / noise_distance_m)^2 / cos(theta), z the point's depth
  along the optical axis and theta the camera ray's incidence;
- a point drops out with probability p(theta) = dropout_grazing * (theta / 90 deg)^dropout_exponent.

The geometry (projector visibility, normals) is the acquisition's (`vprobot.cell.sensor`, through
`CameraHits`); this module holds the figures and the laws.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from vprobot.files.schema import ConfigError
from vprobot.sensing.base import CameraHits, SensingModel, SensorSettings
from vprobot.sensing.models import SENSING_MODELS

MAX_BASELINE_M = 1.0
"""Longest camera-to-projector baseline. Structured-light devices are built with 0.05 to 0.6 m."""

MAX_NEAR_DISPARITY_FRAMES = 2.0
"""The most frame widths the baseline may shift the projector's view of a point at the near
end of the range (baseline / near over the frame's 2 tan(fov_x / 2)). The projector lights what
the camera sees, so in real devices the shift stays under one frame (PhoXi M 0.84, Zivid 2+
MR60 0.53). The projector's shadow test scan converts a grid that spans this shift: with no
bound, a preset's baseline of a million metres took 24 GB before the kernel ended vprobot."""


@SENSING_MODELS.register_named
@dataclasses.dataclass(frozen=True)
class StructuredLight(SensingModel):
    """The figures of a structured-light sensor (a camera and a projector a baseline apart).

    Attributes:
        baseline_m: Distance of the projector's optical centre from the camera's, along the
            sensor's +x axis.
        max_incidence_deg: Largest angle between a camera ray and the surface normal that still
            returns a point.
        projector_max_incidence_deg: The same limit for the projector's ray.
        noise_sigma_m: Axial noise (standard deviation along the camera ray) at depth
            `noise_distance_m` and normal incidence: sigma_0 of sigma(z, theta).
        noise_distance_m: The depth z_0 at which `noise_sigma_m` holds.
        dropout_grazing: Dropout probability at 90 degrees of incidence.
        dropout_exponent: How fast the dropout rises with the incidence angle.

    Raises:
        ConfigError: A ValueError, if a figure lies outside its range (the message names it).
    """

    name = "structured_light"
    uses_normals = True

    baseline_m: float
    max_incidence_deg: float
    projector_max_incidence_deg: float
    noise_sigma_m: float
    noise_distance_m: float
    dropout_grazing: float
    dropout_exponent: float

    def __post_init__(self) -> None:
        key = "sensor.structured_light"
        checks = {
            "baseline_m": (0.0 < self.baseline_m <= MAX_BASELINE_M,
                           f"in (0, {MAX_BASELINE_M:g}] m"),
            "max_incidence_deg": (0.0 < self.max_incidence_deg <= 90.0, "in (0, 90]"),
            "projector_max_incidence_deg": (0.0 < self.projector_max_incidence_deg <= 90.0,
                                            "in (0, 90]"),
            "noise_sigma_m": (self.noise_sigma_m >= 0.0, ">= 0"),
            "noise_distance_m": (self.noise_distance_m > 0.0, "> 0"),
            "dropout_grazing": (0.0 <= self.dropout_grazing <= 1.0, "in [0, 1]"),
            "dropout_exponent": (self.dropout_exponent > 0.0, "> 0"),
        }
        for name, (valid, allowed) in checks.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and valid):
                raise ConfigError(f"{key}.{name} must be {allowed} (finite), got {value!r}")

    @property
    def min_cos_incidence(self) -> tuple[float, float]:
        """cos of the camera's and the projector's incidence limits."""
        return (math.cos(math.radians(self.max_incidence_deg)),
                math.cos(math.radians(self.projector_max_incidence_deg)))

    def limits_only(self) -> StructuredLight:
        """The same sensor without noise and dropout: its deterministic limits (the projector's
        shadow, the incidence limits). What some view of it can measure at all is what this
        model measures: a point that a frame keeps with a probability above 0 is inspectable,
        since dropout is drawn anew per frame, and noise moves a point without losing it."""
        return dataclasses.replace(self, noise_sigma_m=0.0, dropout_grazing=0.0)

    def shadow_only(self) -> StructuredLight:
        """The projector alone: its limits widened to 90 degrees, no noise, no dropout. It loses
        what the projector leaves dark: its shadow, and surfaces it lights from behind."""
        return dataclasses.replace(self.limits_only(), max_incidence_deg=90.0,
                                   projector_max_incidence_deg=90.0)

    def noise_sigma(self, depth: np.ndarray, cos_incidence: np.ndarray) -> np.ndarray:
        """sigma(z, theta) = sigma_0 (z / z_0)^2 / cos(theta), per point (metres)."""
        return self.noise_sigma_m * (depth / self.noise_distance_m) ** 2 / cos_incidence

    def dropout_probability(self, incidence_rad: np.ndarray) -> np.ndarray:
        """p(theta) = dropout_grazing * (theta / 90 deg)^dropout_exponent, per point."""
        return self.dropout_grazing * (incidence_rad / (0.5 * math.pi)) ** self.dropout_exponent

    @classmethod
    def of_sensor(cls, sensor: SensorSettings) -> SensingModel:
        """The sensor's `structured_light` figures.

        Raises:
            ConfigError: If the sensor gives none, or its baseline shifts the projector's view
                of a point at the near end of the range by more than
                `MAX_NEAR_DISPARITY_FRAMES` frame widths.
        """
        figures = sensor.structured_light
        if not isinstance(figures, StructuredLight):
            raise ConfigError("sensor.sensing structured_light needs the sensor's "
                              "structured_light figures, which this sensor does not give "
                              "(`vprobot sensors` lists the presets that have them)")
        frame = 2.0 * math.tan(math.radians(sensor.fov_deg[0]) / 2.0)
        longest = MAX_NEAR_DISPARITY_FRAMES * frame * sensor.near_m
        if figures.baseline_m > longest:
            raise ConfigError(
                f"sensor.structured_light.baseline_m must be at most {longest:.4g} m for this "
                f"sensor's near_m and fov_deg, got {figures.baseline_m:g}: seen from the near end "
                f"of the range the projector may sit at most {MAX_NEAR_DISPARITY_FRAMES:g} frame "
                f"widths (2 near_m tan(fov_x / 2)) from the camera")
        return figures

    def deterministic(self) -> StructuredLight:
        return self.limits_only()

    def ground_truth_key(self) -> tuple[Any, ...]:
        # Noise and dropout do not shape the GT (`deterministic` has none).
        return (self.name, self.baseline_m, self.max_incidence_deg,
                self.projector_max_incidence_deg)

    def loss_stages(self) -> tuple[SensingModel, ...]:
        """The projector alone (shadowed), its limits (grazing), the whole model (dropped out)."""
        return self.shadow_only(), self.limits_only(), self

    def measure(self, hits: CameraHits) -> tuple[np.ndarray, np.ndarray]:
        """Keep the hits within both incidence limits that the projector lights, drop some by
        the dropout law and move the rest along their rays by the noise law.

        The geometry is done in the sensor frame, where the rays are the grid's own and the
        projector sits at (baseline, 0, 0) with the camera's axes: no point is rotated.
        """
        min_camera, min_projector = self.min_cos_incidence
        pixels, points, rng = hits.pixels, hits.points, hits.rng
        normals = hits.normals(pixels)
        rays = hits.rays(pixels)
        cos_camera = np.einsum("ij,ij->i", rays, normals)
        # The camera's limit and the dropout first: they need the camera ray alone, and fewer
        # points are left for the projector. (Rows are picked with np.take: boolean indexing of
        # (n, 3) arrays costs several times more.)
        incidence = np.arccos(np.minimum(np.abs(cos_camera), 1.0))
        seen = np.flatnonzero((np.abs(cos_camera) >= min_camera)
                              & (rng.random(len(pixels)) >= self.dropout_probability(incidence)))
        rays, normals = np.take(rays, seen, axis=0), np.take(normals, seen, axis=0)
        cos_camera, pixels = cos_camera[seen], pixels[seen]
        distance = hits.distances(pixels)
        light = rays * distance[:, None]
        light[:, 0] -= self.baseline_m
        light_distance = np.sqrt(np.einsum("ij,ij->i", light, light))
        cos_projector = np.einsum("ij,ij->i", light, normals) / light_distance
        # Both rays must meet the surface from the same side (a sheet lit from behind is dark).
        facing = np.flatnonzero((cos_camera * cos_projector > 0.0)
                                & (np.abs(cos_projector) >= min_projector))
        if len(facing):
            facing = facing[hits.lit(self.baseline_m, np.take(light, facing, axis=0),
                                     light_distance[facing],
                                     np.take(points, seen[facing], axis=0),
                                     np.take(normals, facing, axis=0))]
        points = np.take(points, seen[facing], axis=0)
        distance = distance[facing]
        noise = rng.standard_normal(len(facing)) * self.noise_sigma(
            light[facing, 2], np.abs(cos_camera[facing]))
        # Along the camera ray: the point moves from `distance` to `distance + noise`.
        return (pixels[facing],
                points + (points - hits.sensor_position) * (noise / distance)[:, None])
