"""Reading a plan JSON (docs/plan-format.md): the document, and the cell, robot, sensor and
object it was made for, as settings of this version's config.

Plans written by earlier versions lack some blocks and fields; each is read as the version
that wrote it meant (`plan_carrier`, `plan_config`): the config's value where the plan has none.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config, replace
from vprobot.config.cell import rotation_rpy_deg
from vprobot.episode import CARRIERS, CarrierName
from vprobot.files.paths import MOTORS_DIR
from vprobot.files.schema import ConfigError, brief
from vprobot.geometry.poses import quat_to_matrix, rotation_about_y, rotation_about_z
from vprobot.parts.loading import LoadedMesh, load_mesh
from vprobot.plan.fields import plan_field, plan_number, plan_quaternion, plan_vector

BASE_ROTATION_TOLERANCE = 1e-6
"""How far the plan's robot base may deviate from a yaw about the world z axis followed by a
tilt about the base's y axis (the only base rotations the cell composes)."""


def read_plan(path: str | Path) -> dict[str, Any]:
    """Load a plan JSON document.

    The document is returned as it is: what a caller needs of it (the object block to render
    or check, the robot's moves to export) that caller asks for.

    Raises:
        ValueError: If the file is missing, not JSON, or not a plan (no views).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"plan file {path} does not exist")
    try:
        document = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"cannot read plan {path}: {error}") from error
    except RecursionError:
        # json decodes nested arrays and objects recursively.
        raise ValueError(f"cannot read plan {path}: nested too deeply") from None
    if not isinstance(document, dict) or not isinstance(document.get("views"), list):
        raise ValueError(f"{path} is not a plan: expected an object with a 'views' list")
    return document


def plan_carrier(document: dict[str, Any]) -> CarrierName:
    """The plan's carrier; `robot` for a plan written before the carrier was.

    Raises:
        ValueError: For a carrier that is not one of `CARRIERS`.
    """
    carrier = document.get("carrier", "robot")
    if carrier not in CARRIERS:
        raise ValueError(f"plan carrier must be one of {list(CARRIERS)}, got {carrier!r}")
    return carrier


def _locate(recorded: str, plan_path: Path, what: str, found: Callable[[Path], bool],
            bundled: Path | None = None) -> Path:
    """A file or folder the plan names: as written, else beside the plan (by name), else in
    `bundled`."""
    candidates = [Path(recorded), plan_path.parent / Path(recorded).name]
    if bundled is not None and not Path(recorded).is_absolute():
        candidates.append(bundled / recorded)
    for candidate in candidates:
        if found(candidate):
            return candidate
    among = " and among the bundled motors" if bundled is not None else ""
    raise ValueError(f"plan's {what} {recorded} not found (also looked beside the plan{among})")


def plan_robot(block: Any, plan_path: Path) -> str:
    """The robot of the plan's `robot` block: a bundled robot's name, else the recorded robot
    folder (as `cell.robot` takes them)."""
    folder = block.get("folder")
    if folder is None:
        return str(plan_field(block, "name", "robot"))
    return str(_locate(str(folder), plan_path, "robot folder", Path.is_dir))


def _base_yaw_tilt_deg(quaternion: np.ndarray) -> tuple[float, float]:
    """The cell's base yaw and tilt (deg) that give the plan's base rotation.

    The cell rotates the base by Rz(yaw) Ry(tilt): its y axis stays horizontal and carries the
    yaw, its bottom row the tilt.
    """
    rotation = quat_to_matrix(quaternion)
    yaw = float(np.arctan2(-rotation[0, 1], rotation[1, 1]))
    tilt = float(np.arctan2(-rotation[2, 0], rotation[2, 2]))
    composed = rotation_about_z(yaw) @ rotation_about_y(tilt)
    if np.max(np.abs(rotation - composed)) > BASE_ROTATION_TOLERANCE:
        raise ValueError(f"plan robot.base_quaternion {quaternion.tolist()} is not a yaw about the "
                         f"vertical followed by a tilt about the base's y axis, the base "
                         f"rotations the cell supports")
    return float(np.rad2deg(yaw)), float(np.rad2deg(tilt))


def _plan_mesh(entry: Any, plan_path: Path, what: str) -> Any:
    """A shape entry of the plan's cell block with its mesh file located (`_locate`), so a plan
    moved with its files replays; anything else as it is (`from_mapping` judges it)."""
    if isinstance(entry, dict) and isinstance(entry.get("mesh"), str):
        return {**entry, "mesh": str(_locate(entry["mesh"], plan_path, what, Path.is_file))}
    return entry


def _plan_cell(block: Any, plan_path: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    """The cell settings and the sensor's housing and mass of a plan's `cell` block, as the
    config's `cell` and `sensor` keys (docs/plan-format.md#cell)."""
    settings = plan_field(block, "settings", "cell")
    if not isinstance(settings, dict):
        raise ValueError(f"plan cell.settings must be an object, got {brief(settings)}")
    objects = settings.get("static_objects")
    if isinstance(objects, list):
        settings = {**settings, "static_objects": [
            _plan_mesh(entry, plan_path, "static object mesh") for entry in objects]}
    housing = plan_field(block, "housing", "cell")
    if not isinstance(housing, dict):
        raise ValueError(f"plan cell.housing must be an object, got {brief(housing)}")
    rotation = quat_to_matrix(plan_quaternion(housing, "quaternion_wxyz", "cell.housing"))
    # The plan states the housing's pose as a quaternion, the config as roll, pitch, yaw.
    solid = {key: value for key, value in _plan_mesh(housing, plan_path, "housing mesh").items()
             if key not in ("parent", "quaternion_wxyz", "sha256")}
    sensor = {"housing": {**solid, "rpy_deg": list(rotation_rpy_deg(rotation))},
              "mass_kg": plan_field(block, "payload_kg", "cell")}
    return settings, sensor


def plan_config(config: Config, document: dict[str, Any], object_center: np.ndarray,
                plan_path: Path) -> Config:
    """`config` with the cell and sensor the plan at `plan_path` was made for: the plan's
    robot, base, sensor mount and sensor, and, from its `cell` block, the cell's settings
    (static objects, fixture, start pose, safety, program) and the sensor's housing and mass;
    a plan without a `cell` block (before issue 43) keeps the config's."""
    robot = plan_field(document, "robot", "")
    mount = plan_field(robot, "sensor_mount", "robot")
    yaw_deg, tilt_deg = _base_yaw_tilt_deg(plan_quaternion(robot, "base_quaternion", "robot"))
    settings, sensor = ({}, {}) if document.get("cell") is None else _plan_cell(
        document["cell"], plan_path)
    try:
        config = replace(config, "cell", **{
            **settings, "robot": plan_robot(robot, plan_path),
            "robot_base_position_m": tuple(plan_vector(robot, "base_position", 3, "robot")),
            "robot_base_yaw_deg": yaw_deg, "robot_base_tilt_deg": tilt_deg,
            "object_center_m": tuple(float(x) for x in object_center)})
    except ConfigError as error:
        raise ValueError(f"plan cell.settings: {error}") from None
    sensor.update({
        "mount_position_m": tuple(plan_vector(mount, "position", 3, "robot.sensor_mount")),
        "mount_quaternion_wxyz": tuple(plan_quaternion(mount, "quaternion",
                                                       "robot.sensor_mount")),
    })
    block = document.get("sensor")
    if block is not None:
        near, far = plan_vector(block, "range", 2, "sensor")
        resolution = plan_vector(block, "resolution", 2, "sensor")
        sensor.update(resolution=tuple(int(x) for x in resolution),
                      fov_deg=tuple(plan_vector(block, "fov_deg", 2, "sensor")),
                      near_m=float(near), far_m=float(far))
        # Plans written before the working distance was exported keep the config's.
        if "working_distance_m" in block:
            sensor["working_distance_m"] = block["working_distance_m"]
        # ... and those written before the sensing model was, the config's model.
        if "sensing" in block:
            sensor["sensing"] = block["sensing"]
            sensor["structured_light"] = block.get("structured_light")
        # ... and those written before the acquisition time was, the config's.
        if "acquisition_time_s" in block:
            sensor["acquisition_time_s"] = block["acquisition_time_s"]
    try:
        return replace(config, "sensor", **sensor)
    except ConfigError as error:
        raise ValueError(f"plan: {error}") from None


def plan_object(config: Config, document: dict[str, Any], plan_path: Path
                ) -> tuple[Config, LoadedMesh, np.ndarray]:
    """The config of a plan's cell with its object where the plan put it, the object's mesh
    (loaded once: a dense mesh costs seconds of simplification) and its rotation.

    Raises:
        ValueError: If the object block is missing or incomplete, or its mesh is missing.
    """
    block = document.get("object")
    if block is None:
        raise ValueError(f"plan {plan_path} has no object block (mesh and pose)")
    mesh_path = _locate(str(plan_field(block, "mesh", "object")), plan_path, "object mesh",
                        Path.is_file, MOTORS_DIR)
    rotation = quat_to_matrix(plan_quaternion(block, "quaternion", "object"))
    mesh = load_mesh(mesh_path, plan_number(block.get("scale", 1.0), "object.scale",
                                            positive=True))
    # The block places the file's vertices; the cell places the centred mesh (see
    # PartScene.object_block), so the centre is the file origin moved by the centring offset.
    center = plan_vector(block, "position", 3, "object") + rotation @ mesh.offset
    return plan_config(config, document, center, plan_path), mesh, rotation
