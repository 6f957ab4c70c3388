"""The user's cell as settings: static objects, the part's pose, safety and the program's I/O.

A cell file (`configs/cells/NAME.yaml`, or any YAML file named by its path: `--cell PATH`,
`cell: PATH` in a config) holds a config's `cell` and `sensor` sections, the description of one
real cell (docs/your-cell.md). Paths inside it (meshes) are read relative to the file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from vprobot.files.paths import CELLS_DIR, available_cells, bundled_or_path
from vprobot.files.schema import ConfigError, Vec3, brief, check_within, read_yaml
from vprobot.geometry.poses import Pose, rotation_about_x, rotation_about_y, rotation_about_z

Shape = Literal["box", "cylinder", "mesh"]
CELL_FILE_SECTIONS = ("cell", "sensor")
"""The sections of a cell file: the robot's cell and the sensor on its flange."""
MESH_KEYS = ("mesh",)
"""Keys of a cell file whose values are files, read relative to the cell file."""
MAX_CLEARANCE_M = 0.2
"""Largest clearance margin (a margin wider than a link rules out every pose near the part)."""
MAX_JOINT_LIMIT_MARGIN_DEG = 30.0
MAX_STATIC_OBJECTS = 64


def rpy_rotation(rpy_deg: Vec3) -> np.ndarray:
    """Rotation of roll, pitch, yaw angles in degrees, as ROS and URDF give them: about the fixed
    x, then y, then z axes (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    roll, pitch, yaw = np.deg2rad(np.asarray(rpy_deg, dtype=float))
    return rotation_about_z(yaw) @ rotation_about_y(pitch) @ rotation_about_x(roll)


def rotation_rpy_deg(rotation: np.ndarray) -> Vec3:
    """The roll, pitch, yaw in degrees of `rpy_rotation` that give `rotation` (pitch in
    [-90, 90]; at +-90 deg, where roll and yaw turn about the same axis, roll 0)."""
    pitch = math.asin(float(np.clip(-rotation[2, 0], -1.0, 1.0)))
    if math.cos(pitch) < 1e-9:
        roll, yaw = 0.0, math.atan2(-rotation[0, 1], rotation[1, 1])
    else:
        roll = math.atan2(rotation[2, 1], rotation[2, 2])
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def _check_vector(values: tuple[float, ...], key: str) -> None:
    if not all(math.isfinite(value) for value in values):
        raise ConfigError(f"{key} must be finite numbers, got {brief(list(values))}")


@dataclasses.dataclass(frozen=True)
class Solid:
    """A rigid shape with a pose in its parent frame.

    Attributes:
        shape: `box` (`size_m`), `cylinder` (`radius_m`, `length_m` along its z axis) or `mesh`
            (`mesh` file, `scale`); MuJoCo collides a mesh as its convex hull.
        size_m: The box's full extents along its x, y and z axes.
        radius_m: The cylinder's radius.
        length_m: The cylinder's length.
        mesh: The mesh file (STL, OBJ, PLY), relative to the cell file.
        scale: Factor from the mesh file's units to metres (0.001 for millimetres).
        position_m: Where the shape's centre (box, cylinder) or the mesh file's origin sits.
        rpy_deg: Its orientation: roll, pitch, yaw in degrees about the parent's fixed x, y, z.
    """

    shape: Shape = "box"
    size_m: Vec3 | None = None
    radius_m: float | None = None
    length_m: float | None = None
    mesh: str | None = None
    scale: float = 1.0
    position_m: Vec3 = (0.0, 0.0, 0.0)
    rpy_deg: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        needs = {"box": ("size_m",), "cylinder": ("radius_m", "length_m"), "mesh": ("mesh",)}
        for key in ("size_m", "radius_m", "length_m", "mesh"):
            given = getattr(self, key) is not None
            if given != (key in needs[self.shape]):
                what = "needs" if not given else "takes no"
                raise ConfigError(f"a {self.shape} {what} {key} (a box: size_m; a cylinder: "
                                  f"radius_m and length_m; a mesh: mesh and scale)")
        sizes = {"size_m": self.size_m or (), "radius_m": (self.radius_m,) if self.radius_m
                 is not None else (), "length_m": (self.length_m,) if self.length_m is not None
                 else (), "scale": (self.scale,)}
        for key, values in sizes.items():
            if not all(0.0 < value < math.inf for value in values):
                raise ConfigError(f"{key} must be > 0 and finite, got {brief(list(values))}")
        _check_vector(self.position_m, "position_m")
        _check_vector(self.rpy_deg, "rpy_deg")

    @property
    def pose(self) -> Pose:
        return Pose(np.array(self.position_m, dtype=float), rpy_rotation(self.rpy_deg))


@dataclasses.dataclass(frozen=True)
class StaticObject(Solid):
    """A static collision object of the cell (table, fixture, guarding, wall), in the world
    frame.

    Attributes:
        name: Its name in messages, the plan and `vprobot check`'s report (unique).
    """

    name: str = ""

    def __post_init__(self) -> None:
        if not self.name or not self.name.replace("_", "").replace("-", "").isalnum():
            raise ConfigError(f"name must be letters, digits, '_' and '-', got {brief(self.name)}")
        super().__post_init__()


@dataclasses.dataclass(frozen=True)
class PartConfig:
    """The part to inspect, where it really sits (`vprobot plan` plans it there).

    Attributes:
        mesh: The part's mesh file (its CAD export), relative to the cell file.
        scale: Factor from the file's units to metres (0.001 for millimetres).
        position_m: Where the mesh file's origin (the CAD origin) sits in the world.
        rpy_deg: The CAD frame's orientation: roll, pitch, yaw in degrees about the world's
            fixed x, y, z axes.
    """

    mesh: str
    position_m: Vec3
    scale: float = 1.0
    rpy_deg: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not 0.0 < self.scale < math.inf:
            raise ConfigError(f"scale must be > 0 and finite, got {brief(self.scale)}")
        _check_vector(self.position_m, "position_m")
        _check_vector(self.rpy_deg, "rpy_deg")

    @property
    def rotation(self) -> np.ndarray:
        return rpy_rotation(self.rpy_deg)

    def center(self, offset_m: np.ndarray) -> np.ndarray:
        """Where the mesh's bounding-box centre sits in the world, given that centre in the CAD
        frame (`offset_m`, metres; `LoadedMesh.offset`)."""
        return np.asarray(self.position_m, dtype=float) + self.rotation @ offset_m


@dataclasses.dataclass(frozen=True)
class SafetyConfig:
    """Margins every plan keeps, and the speed it is timed at.

    Attributes:
        clearance_m: Least distance from the robot and the sensor housing to every static
            object, the fixture and the robot's column.
        part_clearance_m: Least distance from the robot and the sensor housing to the part.
        joint_limit_margin_deg: Every joint stays this far inside its limits.
        speed_scale: Fraction of the robot's velocity limits the moves are timed at (the
            acceleration by its square, the jerk by its cube: the same path, slower), as a
            controller's speed slider.
    """

    clearance_m: float = 0.010
    part_clearance_m: float = 0.010
    joint_limit_margin_deg: float = 2.0
    speed_scale: float = 1.0

    def __post_init__(self) -> None:
        for key in ("clearance_m", "part_clearance_m"):
            check_within(f"cell.safety.{key}", getattr(self, key), 0.0, MAX_CLEARANCE_M, "m")
        check_within("cell.safety.joint_limit_margin_deg", self.joint_limit_margin_deg, 0.0,
                     MAX_JOINT_LIMIT_MARGIN_DEG, "deg")
        if not 0.0 < self.speed_scale <= 1.0:
            raise ConfigError(f"cell.safety.speed_scale must lie in (0, 1], got "
                              f"{brief(self.speed_scale)}")


@dataclasses.dataclass(frozen=True)
class ProgramConfig:
    """How the exported programs trigger the sensor and wait for it (docs/your-cell.md).

    Attributes:
        trigger_output: The controller's digital output that triggers an acquisition (pulsed
            high); None when `trigger_script` triggers it.
        trigger_script: A URScript statement that triggers an acquisition instead (a function
            of the sensor's URCap, say); None for the digital output.
        done_input: The digital input the sensor sets when its frame is taken; None waits the
            sensor's `acquisition_time_s` instead.
        done_timeout_s: Longest wait for `done_input` before the program stops with an error.
        path_tolerance_rad: ROS 2: the largest joint deviation from the trajectory while
            moving (the goal's path tolerance).
        goal_tolerance_rad: ROS 2: the largest joint error at the end.
        goal_time_tolerance_s: ROS 2: how late the trajectory may end.
    """

    trigger_output: int | None = 0
    trigger_script: str | None = None
    done_input: int | None = None
    done_timeout_s: float = 5.0
    path_tolerance_rad: float = 0.05
    goal_tolerance_rad: float = 0.005
    goal_time_tolerance_s: float = 0.5

    def __post_init__(self) -> None:
        if (self.trigger_output is None) == (self.trigger_script is None):
            raise ConfigError("cell.program needs exactly one of trigger_output (a digital "
                              "output) and trigger_script (a URScript statement), got "
                              f"{brief(self.trigger_output)} and {brief(self.trigger_script)}")
        for key in ("trigger_output", "done_input"):
            value = getattr(self, key)
            if value is not None and not 0 <= value <= 7:
                raise ConfigError(f"cell.program.{key} must be a standard digital I/O in 0..7, "
                                  f"got {brief(value)}")
        if self.trigger_script is not None and (not self.trigger_script.strip() or any(
                char in self.trigger_script for char in "\n\r\0")):
            raise ConfigError(f"cell.program.trigger_script must be one non-empty line, got "
                              f"{brief(self.trigger_script)}")
        for key in ("done_timeout_s", "path_tolerance_rad", "goal_tolerance_rad",
                    "goal_time_tolerance_s"):
            value = getattr(self, key)
            if not 0.0 < value < math.inf:
                raise ConfigError(f"cell.program.{key} must be > 0, got {brief(value)}")


def check_static_objects(objects: tuple[StaticObject, ...]) -> None:
    """Raise ConfigError if there are too many or two share a name."""
    if len(objects) > MAX_STATIC_OBJECTS:
        raise ConfigError(f"cell.static_objects: at most {MAX_STATIC_OBJECTS} objects, got "
                          f"{len(objects)}")
    names = [item.name for item in objects]
    for name in names:
        if names.count(name) > 1:
            raise ConfigError(f"cell.static_objects: the name {brief(name)} is given twice")


def cell_file(name: str | Path) -> Path:
    """The file of a bundled cell (`configs/cells/`) or a cell file's path.

    Raises:
        ConfigError: If it is neither (the message lists the bundled cells).
    """
    bundled = {cell: CELLS_DIR / f"{cell}.yaml" for cell in available_cells()}
    try:
        return bundled_or_path(name, bundled, "cell", "YAML file")
    except (ValueError, TypeError):
        raise ConfigError(f"cell must name a bundled cell ({', '.join(bundled)}) or a cell "
                          f"file, got {brief(str(name))}") from None


def _anchored(section: Any, folder: Path) -> Any:
    """`section` with every relative mesh path made relative to `folder` (the file's)."""
    if isinstance(section, Mapping):
        return {key: (str(folder / value) if key in MESH_KEYS and isinstance(value, str)
                      and not Path(value).expanduser().is_absolute()
                      else _anchored(value, folder))
                for key, value in section.items()}
    if isinstance(section, list):
        return [_anchored(item, folder) for item in section]
    return section


def read_cell_file(name: str | Path) -> dict[str, Any]:
    """The `cell` and `sensor` sections of a cell file, mesh paths made absolute.

    Raises:
        ConfigError: If the file is not a mapping of those sections (naming the file).
    """
    path = cell_file(name)
    data = read_yaml(path) or {}
    if not isinstance(data, Mapping) or not data:
        raise ConfigError(f"{path}: a cell file is a mapping of the sections "
                          f"{', '.join(CELL_FILE_SECTIONS)}")
    unknown = sorted(set(data) - set(CELL_FILE_SECTIONS))
    if unknown:
        raise ConfigError(f"{path}: unknown section {brief(unknown[0])}; a cell file has "
                          f"{', '.join(CELL_FILE_SECTIONS)} (the other sections belong in a "
                          f"config)")
    return {key: _anchored(value, path.parent) for key, value in data.items()}


def with_cell_file(data: Mapping[str, Any], source: Path | None) -> dict[str, Any]:
    """A config mapping with its `cell: NAME` (a bundled cell or a cell file) read in.

    The cell file gives the `cell` section and the sensor; a `sensor` section of the config
    itself then changes the cell file's sensor key by key (or replaces it, when a preset name).
    Mesh paths of an inline `cell` section are read relative to the config file `source`.
    """
    merged = dict(data)
    cell = merged.get("cell")
    if isinstance(cell, str | Path):
        document = read_cell_file(cell)
        merged["cell"] = document.get("cell", {})
        own_sensor = merged.get("sensor")
        cell_sensor = document.get("sensor")
        if isinstance(own_sensor, Mapping) and isinstance(cell_sensor, Mapping) and (
                "preset" not in own_sensor):
            merged["sensor"] = {**cell_sensor, **own_sensor}
        elif own_sensor is None and cell_sensor is not None:
            merged["sensor"] = cell_sensor
    elif isinstance(cell, Mapping) and source is not None:
        merged["cell"] = _anchored(cell, source.parent)
    return merged
