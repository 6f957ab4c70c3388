"""How a sensor turns what its rays reach into points: the sensing model (docs/sensor.md#sensing).

`ideal` keeps every object point that a camera ray meets first within range, exactly where it
lies. `structured_light` models a camera and a projector a baseline apart, as the structured-light
devices of the presets are built:

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

The geometry (projector visibility, normals) is the acquisition's (`vprobot.sensor`); this module
holds the figures and the two laws.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math

import numpy as np

from vprobot.schema import ConfigError

SENSING_MODELS = ("ideal", "structured_light")
"""The names a sensor's `sensing` setting and `--sensing` take."""


@dataclasses.dataclass(frozen=True)
class IdealSensing:
    """Every point a camera ray reaches first within range, measured exactly."""

    name = "ideal"


IDEAL = IdealSensing()


@dataclasses.dataclass(frozen=True)
class StructuredLight:
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
            "baseline_m": (self.baseline_m > 0.0, "> 0"),
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


SensingModel = IdealSensing | StructuredLight
"""A sensor's sensing model: `IDEAL` or a `StructuredLight`."""


def frame_generator(*state: np.ndarray) -> np.random.Generator:
    """The noise and dropout generator of a frame taken in `state` (e.g. the sensor's and the
    object's pose): the same frame gets the same draws, whichever order frames are taken in."""
    digest = hashlib.sha256(b"".join(np.ascontiguousarray(part, dtype=np.float64).tobytes()
                                     for part in state)).digest()
    return np.random.default_rng(int.from_bytes(digest[:16], "little"))


def check_sensing(name: str, structured_light: StructuredLight | None) -> None:
    """Raise ConfigError unless `name` is a sensing model the sensor has figures for."""
    if name not in SENSING_MODELS:
        raise ConfigError(f"sensor.sensing must be one of {list(SENSING_MODELS)}, got {name!r}")
    if name == "structured_light" and structured_light is None:
        raise ConfigError("sensor.sensing structured_light needs the sensor's structured_light "
                          "figures, which this sensor does not give (`vprobot sensors` lists "
                          "the presets that have them)")
