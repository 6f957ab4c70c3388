"""A cell's own check: what must hold before anything is planned in it, and its clearances.

`check_cell` refuses a cell whose static objects reach into the robot's base, whose part does
not rest in free space, or whose robot (sensor housing included) collides or leaves its limits
at the start pose. `clearances` measures the least distance from the robot to each object of
the cell, for `vprobot check` and `evaluate`.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from vprobot.cell.scene import (
    ENVIRONMENT_BIT,
    HOUSING_GEOM,
    OBJECT_GEOM,
    PLANNING_SLACK_M,
    STATIC_PREFIX,
    Cell,
)
from vprobot.config import Config, replace
from vprobot.parts.loading import LoadedMesh, load_mesh

PENETRATION_TOLERANCE_M = 0.001
"""Deepest overlap between cell objects that still counts as resting on each other (1 mm: a
part on its fixture, a base on its table, as measured to about that)."""
DISTANCE_HORIZON_M = 1.0
"""Farthest distance `clearances` resolves; an object farther than this reports this."""
CLEARANCE_RESOLUTION_M = 1e-4
"""How far above the true least distance `clearances` may report it (0.1 mm): it skips the
configurations that cannot come closer than that (`vprobot check` and the planners' collision
checks hold the margins exactly at every sample besides)."""


class CellError(ValueError):
    """The cell fails its own check; the message names the key and what is wrong."""


def placed_part(config: Config) -> tuple[Config, LoadedMesh]:
    """The cell's part (`cell.part`) loaded, and `config` with `object_center_m` where that
    pose puts the part's centre.

    Raises:
        FileNotFoundError, ValueError: For a missing or unusable mesh.
    """
    part = config.cell.part
    if part is None:
        raise ValueError("the cell has no part (cell.part)")
    mesh = load_mesh(part.mesh, part.scale, "cell.part.scale")
    center = part.center(np.asarray(mesh.offset, dtype=float))
    return replace(config, "cell", object_center_m=tuple(float(x) for x in center)), mesh


def geom_label(model: mujoco.MjModel, geom: int) -> str:
    """How messages and reports name a geom: a static object by its name, the housing, the
    part, else by its own name (`fixture_plate`, `pedestal`, `robot_stand`, as the plan's
    `cell.static_objects` name them) or its body's."""
    name = model.geom(geom).name
    if name.startswith(STATIC_PREFIX):
        return name.removeprefix(STATIC_PREFIX)
    if name == HOUSING_GEOM:
        return "the sensor housing"
    if name == OBJECT_GEOM:
        return "the part"
    return name or model.body(model.geom_bodyid[geom]).name


def _distance(model: mujoco.MjModel, data: mujoco.MjData, geom1: int, geom2: int) -> float:
    """Signed distance between two geoms (negative: penetration), up to the horizon."""
    return float(mujoco.mj_geomDistance(model, data, geom1, geom2, DISTANCE_HORIZON_M, None))


@dataclasses.dataclass(frozen=True)
class Clearance:
    """The least distance from the robot (sensor housing included) to one object of the cell.

    Attributes:
        name: The object (a static object's name, `the part`, `fixture`, the robot's column).
        distance_m: The least distance over the configurations measured (negative: overlap).
        margin_m: The clearance the cell demands from it.
    """

    name: str
    distance_m: float
    margin_m: float

    @property
    def holds(self) -> bool:
        return self.distance_m >= self.margin_m - 1e-9


def environment_geoms(cell: Cell) -> dict[str, list[int]]:
    """The cell's objects the robot keeps its clearance from, by label: static objects, the
    fixture, the robot's column, the part (not the floor, which a plane bounds below)."""
    model = cell.model
    found: dict[str, list[int]] = {}
    for geom in range(model.ngeom):
        if (model.geom_contype[geom] & ENVIRONMENT_BIT
                and model.geom_bodyid[geom] != cell.base_body_id
                and model.geom_type[geom] != mujoco.mjtGeom.mjGEOM_PLANE):
            found.setdefault(geom_label(model, geom), []).append(geom)
    return found


def _geom_motion(cell: Cell, data: mujoco.MjData, path: np.ndarray,
                 geoms: np.ndarray) -> np.ndarray:
    """How far any point of each geom of `geoms` has moved, at most, from the first
    configuration of `path` to each (n, len(geoms)): cumulative over consecutive
    configurations, each step the geom centre's move plus its bounding radius times the chord
    of its turn (|R1 v - R2 v| <= |R1 - R2| |v|, and |R1 - R2| = sqrt(3 - trace(R1^T R2)))."""
    model = cell.model
    centres = np.empty((len(path), len(geoms), 3))
    frames = np.empty((len(path), len(geoms), 9))
    for index, q in enumerate(path):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        centres[index] = data.geom_xpos[geoms]
        frames[index] = data.geom_xmat[geoms]
    shift = np.linalg.norm(np.diff(centres, axis=0), axis=2)
    chord = np.sqrt(np.maximum(3.0 - np.sum(frames[1:] * frames[:-1], axis=2), 0.0))
    steps = shift + chord * model.geom_rbound[geoms]
    return np.concatenate([np.zeros((1, len(geoms))), np.cumsum(steps, axis=0)])


def clearances(cell: Cell, data: mujoco.MjData, path: np.ndarray) -> list[Clearance]:
    """The least distance from the robot to each object of the cell along `path` (n, dof),
    with the object placed as `data` holds it, to within `CLEARANCE_RESOLUTION_M`.

    A distance is measured only where it could undercut the least one found so far by more
    than the resolution: from a configuration at distance d, the next is the first where the
    robot geom may have moved farther than d less that least distance (`_geom_motion`), so a
    path of thousands of samples costs a few hundred measurements.
    """
    model = cell.model
    safety = cell.config.cell.safety
    objects = environment_geoms(cell)
    # The base stands on the cell's objects; everything it carries keeps its clearance.
    moving = np.array([g for g in cell.robot_geom_ids
                       if model.geom_bodyid[g] != cell.base_body_id], dtype=int)
    reach = _geom_motion(cell, data, path, moving)
    least = dict.fromkeys(objects, DISTANCE_HORIZON_M)
    posed = -1
    for name, geoms in objects.items():
        for column, robot_geom in enumerate(moving):
            travelled = reach[:, column]
            for geom in geoms:
                index = 0
                while index < len(path):
                    if posed != index:
                        data.qpos[:] = path[index]
                        mujoco.mj_kinematics(model, data)
                        posed = index
                    distance = _distance(model, data, int(robot_geom), geom)
                    least[name] = min(least[name], distance)
                    # No configuration before travelled[index] + slack comes closer than
                    # least - resolution: skip to the first that may.
                    slack = distance - least[name] + CLEARANCE_RESOLUTION_M
                    index = int(np.searchsorted(travelled, travelled[index] + slack,
                                                side="right"))
    return [Clearance(name, distance, safety.part_clearance_m if name == "the part"
                      else safety.clearance_m) for name, distance in least.items()]


def check_cell(cell: Cell, data: mujoco.MjData) -> None:
    """Raise CellError unless the cell, with the object as `data` places it, holds: no static
    object reaches into the robot's base or the part, and the robot at its start pose is within
    its limits and keeps its clearances.

    Raises:
        CellError: Naming the key (`cell.static_objects`, `cell.part`, `cell.start_joints_rad`)
            and what is wrong.
    """
    model = cell.model
    joints = cell.joints
    start = joints.start
    outside = np.flatnonzero((start < joints.lower - 1e-9) | (start > joints.upper + 1e-9))
    if len(outside):
        index = int(outside[0])
        raise CellError(
            f"cell.start_joints_rad: joint {joints.names[index]} at {start[index]:.4g} rad lies "
            f"outside [{joints.lower[index]:.4g}, {joints.upper[index]:.4g}] rad, its limits "
            f"less cell.safety.joint_limit_margin_deg")
    data.qpos[:] = start
    mujoco.mj_kinematics(model, data)
    statics = [g for g in range(model.ngeom) if model.geom(g).name.startswith(STATIC_PREFIX)]
    base_geoms = [g for g in cell.robot_geom_ids if model.geom_bodyid[g] == cell.base_body_id]
    for static in statics:
        for other, what in ([(g, "the robot's base") for g in base_geoms]
                            + [(g, "the part") for g in cell.object_geom_ids]):
            depth = -_distance(model, data, static, other)
            if depth > PENETRATION_TOLERANCE_M:
                raise CellError(
                    f"cell.static_objects: {geom_label(model, static)} reaches {depth * 1e3:.1f} "
                    f"mm into {what}; objects may touch it but not overlap it (the part must "
                    f"rest in free space)")
    worst = min(clearances(cell, data, start[None]), key=lambda c: c.distance_m - c.margin_m,
                default=None)
    # Planning keeps its slack from the start on: a start pose inside it starts every move in
    # collision.
    if worst is not None and worst.distance_m < worst.margin_m + PLANNING_SLACK_M:
        raise CellError(
            f"cell.start_joints_rad: at the start pose the robot comes {worst.distance_m * 1e3:.1f}"
            f" mm from {worst.name}, within the clearance of {worst.margin_m * 1e3:g} mm "
            f"(cell.safety) and the {PLANNING_SLACK_M * 1e3:g} mm planning keeps beyond it; "
            f"choose a start pose clear of the cell")
    data.qpos[:] = start
    mujoco.mj_collision(model, data)
    contacts = data.contact[: data.ncon]
    for contact in contacts:
        if contact.dist < contact.includemargin:
            raise CellError(
                f"cell.start_joints_rad: at the start pose {geom_label(model, contact.geom1)} "
                f"collides with {geom_label(model, contact.geom2)}")
