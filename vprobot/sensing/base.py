"""What a sensing model is (`SensingModel`), what it reads of the sensor (`SensorSettings`) and
of a frame (`CameraHits`); the registry of models is `vprobot.sensing.models`.

The sensor (`vprobot.cell.sensor.DepthSensor`) finds the camera's hits: every object point a ray
meets first within range, exactly where it lies. The model then decides which of them become
points and where (`SensingModel.measure`); its other methods say what the rest of vprobot needs
of it: the figures it takes from the `sensor` section, its deterministic part (what the ground
truth measures with), what of it joins the ground truth's cache key and the reductions that tell
a frame's lost points apart. A new model is a module of this package, declared in
`vprobot.sensing.models.SENSING_MODELS` (or a plugin, `vprobot.extensions.plugins`), with a
`SensingModel` subclass registered there (docs/extending.md#sensing-model).
"""

from __future__ import annotations

import dataclasses
import hashlib
from typing import Any, ClassVar, Protocol

import numpy as np


class SensorSettings(Protocol):
    """What a sensing model reads of the `sensor` section (`vprobot.config.SensorConfig`, which
    sits above the models: the config checks its `sensing` against them)."""

    @property
    def sensing(self) -> str: ...

    @property
    def structured_light(self) -> SensingModel | None: ...

    @property
    def fov_deg(self) -> tuple[float, float]: ...

    @property
    def near_m(self) -> float: ...


class CameraHits(Protocol):
    """One frame's camera hits as a sensing model reads them (the sensor gives them).

    Attributes:
        pixels: Row-major pixel index (n,) of each hit.
        points: The hits (n, 3) in the world, exactly where each ray meets the object.
        sensor_position: The camera's optical centre in the world (3,).
        rng: The frame's random draws (noise, dropout): the caller's, or seeded from the sensor
            and object poses (`frame_generator`), so that the same frame draws the same.
    """

    @property
    def pixels(self) -> np.ndarray: ...

    @property
    def points(self) -> np.ndarray: ...

    @property
    def sensor_position(self) -> np.ndarray: ...

    @property
    def rng(self) -> np.random.Generator: ...

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit directions (n, 3) of the rays of `pixels` in the sensor frame (+z the optical
        axis)."""
        ...

    def distances(self, pixels: np.ndarray) -> np.ndarray:
        """Distances (n,) from the optical centre to the hits of `pixels`, along their rays."""
        ...

    def normals(self, pixels: np.ndarray) -> np.ndarray:
        """Unit normals (n, 3), in the sensor frame, of the triangles the hits of `pixels` lie
        on; only for a model that sets `uses_normals`."""
        ...

    def lit(self, baseline_m: float, light: np.ndarray, light_distance: np.ndarray,
            points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """The indices of the points that a light source `baseline_m` along the sensor's +x axis
        reaches unoccluded by the object, the robot and the cell.

        Args:
            baseline_m: The source's offset from the optical centre along the sensor's +x axis.
            light: The points relative to the source, in the sensor frame (n, 3).
            light_distance: Their distances from the source (n,).
            points: The same points in the world (n, 3).
            normals: Their surfaces' unit normals in the sensor frame (n, 3).
        """
        ...


class SensingModel:
    """How a sensor turns its camera's hits into points. This base keeps every hit exactly
    where it lies (what `ideal` is); a model overrides what it does otherwise.

    Attributes:
        name: The model's name, as `sensor.sensing` and `--sensing` take it.
        uses_normals: Whether `measure` reads the hits' surface normals (the sensor then keeps
            each pixel's triangle).
    """

    name: ClassVar[str]
    uses_normals: ClassVar[bool] = False

    @classmethod
    def of_sensor(cls, sensor: SensorSettings) -> SensingModel:
        """The model as the `sensor` section configures it (its figures, if it has any).

        Raises:
            ConfigError: If the sensor lacks what the model needs (the message says what).
        """
        return cls()

    def measure(self, hits: CameraHits) -> tuple[np.ndarray, np.ndarray]:
        """The pixels (m,) and world points (m, 3) of the hits the frame keeps, where it
        measures them."""
        return hits.pixels, hits.points

    def deterministic(self) -> SensingModel:
        """The model without its random draws, which shapes what any view can measure (the
        ground truth's views measure with it): a point some frame keeps with a probability
        above 0 is inspectable, and noise moves a point without losing it."""
        return self

    def ground_truth_key(self) -> tuple[Any, ...]:
        """What of the deterministic model joins the ground truth's cache key: its name and
        fields."""
        fields = dataclasses.astuple(self) if dataclasses.is_dataclass(self) else ()
        return (self.name, *fields)

    def loss_stages(self) -> tuple[SensingModel, ...]:
        """Reductions of the model, one per cause of `vprobot.cell.sensor.LOSS_CAUSES` in order, the
        last the model itself, each keeping a subset of the points of the one before: a lost
        point is lost to the first that drops it. None: the model's losses are not told apart
        (`DepthSensor.losses_at` reports none)."""
        return ()


def frame_generator(*state: np.ndarray) -> np.random.Generator:
    """The noise and dropout generator of a frame taken in `state` (e.g. the sensor's and the
    object's pose): the same frame gets the same draws, whichever order frames are taken in."""
    digest = hashlib.sha256(b"".join(np.ascontiguousarray(part, dtype=np.float64).tobytes()
                                     for part in state)).digest()
    return np.random.default_rng(int.from_bytes(digest[:16], "little"))
