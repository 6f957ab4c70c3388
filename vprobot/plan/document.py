"""Writing the plan JSON of an episode, for a real cell (docs/plan-format.md)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from vprobot.cell.scene import ENVIRONMENT_BIT, STATIC_PREFIX, Cell
from vprobot.config import config_document
from vprobot.config.cell import Solid
from vprobot.episode import EpisodeRecord, PartScene
from vprobot.files.atomic import file_sha256, write_text
from vprobot.geometry.poses import Pose, quat_to_matrix
from vprobot.kinematics import TravelCost
from vprobot.robots import is_bundled


def view_entry(pose: Pose, joints: np.ndarray | None, reachable: bool | None,
               reason: str | None = None, coverage: float | None = None,
               travel: TravelCost | None = None) -> dict[str, Any]:
    """One entry of the plan's `views` (docs/plan-format.md#views).

    Args:
        pose: Sensor pose in the world (reached pose when reachable, else the requested one).
        joints: Joint configuration reaching it (None when unreachable).
        reachable: Whether the robot reaches it collision-free; None when no robot was involved
            (a free-flying sensor).
        reason: Why not, when unreachable.
        coverage: Cumulative coverage after this view, when known.
        travel: Travel from the previous view, when known.
    """
    view: dict[str, Any] = {
        "position": _floats(pose.position),
        "quaternion": _floats(pose.quaternion),
        "joints": None if joints is None else _floats(joints),
        "reachable": reachable,
        "reason": reason,
    }
    if coverage is not None:
        view["coverage"] = float(coverage)
    if travel is not None:
        view["travel"] = travel.as_dict()
    return view


def _floats(values: np.ndarray) -> list[float]:
    return [float(value) for value in np.asarray(values).ravel()]


GT_DECIMALS = 6
"""Ground-truth coordinates in the plan are rounded to the micrometre (epsilon is millimetres)."""


def ground_truth_block(record: EpisodeRecord) -> dict[str, Any]:
    """What a third party needs to re-check the coverage with its own ray caster.

    The GT points in the world (as posed in the episode), epsilon (a GT point counts as covered
    when an acquired point lies within it) and, per point, the index into `views` of the view
    that first covered it (-1: never covered); the coverage after view k is the share of points
    whose index is at most k.
    """
    return {
        "points": np.round(record.gt_points_world, GT_DECIMALS).tolist(),
        "epsilon_m": float(record.epsilon_m),
        "first_covered_by_view": [int(index) for index in record.first_covered_by],
    }


def robot_block(cell: Cell) -> dict[str, Any]:
    """The robot: name (and folder, for a robot that is not bundled), base pose, joint names,
    the motion limits the plan was timed under (at the cell's speed scale) and the sensor mount
    on the flange frame."""
    base, mount, limits = cell.robot_base, cell.sensor_mount, cell.motion_limits
    # Like the mesh, a robot folder is recorded absolute, so the plan replays from anywhere.
    folder = {} if is_bundled(cell.robot) else {"folder": str(cell.robot.folder.resolve())}
    return {
        "name": cell.robot.name,
        **folder,
        "base_position": _floats(base.position),
        "base_quaternion": _floats(base.quaternion),
        "joint_names": list(cell.joints.names),
        "limits": {
            "velocity_rad_s": _floats(limits.velocity),
            "acceleration_rad_s2": _floats(limits.acceleration),
            "jerk_rad_s3": _floats(limits.jerk),
        },
        "sensor_mount": {
            "parent": cell.robot.flange,
            "position": _floats(mount.position),
            "quaternion": _floats(mount.quaternion),
        },
    }


def _solid_entry(solid: Solid, pose: Pose) -> dict[str, Any]:
    """A shape as the plan writes it: its geometry and its pose in its parent frame."""
    entry: dict[str, Any] = {"shape": solid.shape}
    if solid.shape == "box":
        entry["size_m"] = list(solid.size_m or ())
    elif solid.shape == "cylinder":
        entry.update(radius_m=solid.radius_m, length_m=solid.length_m)
    else:
        path = Path(solid.mesh or "").resolve()
        entry.update(mesh=str(path), scale=solid.scale, sha256=file_sha256(path))
    entry.update(position_m=_floats(pose.position), quaternion_wxyz=_floats(pose.quaternion))
    return entry


def _model_solid(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> dict[str, Any]:
    """A box or cylinder geom of the compiled cell (the fixture, the robot's column) as a
    world-frame shape."""
    size = model.geom_size[geom]
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX:
        solid = Solid(shape="box", size_m=(float(2 * size[0]), float(2 * size[1]),
                                           float(2 * size[2])))
    else:
        solid = Solid(shape="cylinder", radius_m=float(size[0]), length_m=float(2 * size[1]))
    pose = Pose(data.geom_xpos[geom].copy(), data.geom_xmat[geom].reshape(3, 3).copy())
    return _solid_entry(solid, pose)


def cell_block(cell: Cell, object_rotation: np.ndarray) -> dict[str, Any]:
    """What a checker outside vprobot needs to rebuild the cell (docs/plan-format.md#cell): every
    static collision object in the world frame (the cell file's, then the fixture and the
    robot's column as placed), the sensor housing in the sensor frame, the payload, the
    margins, the joint limits planned within, the start pose, the programs' I/O, and the
    cell's settings as given (`settings`, which `vprobot check` rebuilds the cell from)."""
    settings = cell.config.cell
    data = cell.make_data()
    cell.place_object(data, object_rotation)
    objects = [{"name": item.name, **_solid_entry(item, item.pose)}
               for item in settings.static_objects]
    model = cell.model
    for geom in range(model.ngeom):
        name = model.geom(geom).name
        body = model.geom_bodyid[geom]
        if name.startswith(STATIC_PREFIX) or not model.geom_contype[geom] & ENVIRONMENT_BIT:
            continue
        # int(): a pybind11 enum is not equal to a NumPy integer, so `in` would never match.
        if int(model.geom_type[geom]) in (mujoco.mjtGeom.mjGEOM_BOX,
                                          mujoco.mjtGeom.mjGEOM_CYLINDER):
            label = name or model.body(body).name
            objects.append({"name": label, **_model_solid(model, data, geom)})
    housing = cell.config.sensor.housing
    return {
        "static_objects": objects,
        "floor_z_m": 0.0,
        "housing": {"parent": "sensor", **_solid_entry(housing, housing.pose)},
        "payload_kg": cell.config.sensor.mass_kg,
        "tcp": "the sensor frame (robot.sensor_mount): the optical centre, +z viewing",
        "safety": dataclasses.asdict(settings.safety),
        "joint_limits_rad": {"lower": _floats(cell.joints.lower),
                             "upper": _floats(cell.joints.upper)},
        "start_joints": _floats(cell.joints.start),
        "program": dataclasses.asdict(settings.program),
        "settings": config_document(cell.config)["cell"],
    }


def sensor_block(cell: Cell) -> dict[str, Any]:
    sensor = cell.config.sensor
    return {
        "resolution": list(sensor.resolution),
        "fov_deg": list(sensor.fov_deg),
        "range": [sensor.near_m, sensor.far_m],
        "working_distance_m": sensor.working_distance_m,
        "frame": "+z viewing direction, +x image right, +y image down",
        "sensing": sensor.sensing,
        "structured_light": (dataclasses.asdict(sensor.structured_light)
                             if sensor.structured_light is not None else None),
        "acquisition_time_s": sensor.acquisition_time_s,
    }


def plan_document(
    cell: Cell,
    views: list[dict[str, Any]],
    object_block: dict[str, Any] | None = None,
    coverage: float | None = None,
) -> dict[str, Any]:
    """Assemble the plan JSON document.

    Args:
        cell: The cell the plan was made in.
        views: The views in execution order (`view_entry`).
        object_block: How the object's mesh file is placed in the world, when there is one.
        coverage: Final cumulative coverage, when known.
    """
    rotation = (quat_to_matrix(object_block["quaternion"]) if object_block is not None
                else np.eye(3))
    document: dict[str, Any] = {
        "object": object_block,
        "cell": cell_block(cell, rotation),
        "robot": robot_block(cell),
        "sensor": sensor_block(cell),
        "views": views,
        "coverage": coverage,
    }
    return document


def planned_views(record: EpisodeRecord) -> list[dict[str, Any]]:
    """The views of an episode as plan entries.

    A reached view carries the sensor pose it was acquired from and the joints that reach it; an
    unreached one its requested pose and no joints. With the robot each view also carries the
    corners of the move that led to it (`waypoints`, null where the robot stayed). Without the
    robot (a free-flying sensor) views carry their pose only and `reachable` is None.
    """
    robot = record.carrier == "robot"
    views = []
    for view in record.views:
        reached = robot and view.reachable
        pose = view.sensor_pose if view.sensor_pose is not None else view.requested
        views.append(view_entry(
            pose=pose,
            joints=view.joints if reached else None,
            reachable=view.reachable if robot else None,
            reason=view.reason if robot else None,
            coverage=view.coverage,
            travel=view.travel,
        ))
        if robot:
            views[-1]["waypoints"] = _corners(view.waypoints)
    return views


def _corners(waypoints: np.ndarray | None) -> list[list[float]] | None:
    return None if waypoints is None else [_floats(corner) for corner in waypoints]


NO_RETURN = "no_path_back"
"""`return.reason` when the path planner found no way back to the start."""
NOTHING_ACQUIRED = "nothing_acquired"
"""`return.reason` when the robot never left the start (no view was acquired)."""


def return_block(record: EpisodeRecord) -> dict[str, Any] | None:
    """The cycle's return to `start_joints` (docs/plan-format.md#top-level): its corners, or
    null corners and why there are none; None without a robot."""
    if record.carrier != "robot":
        return None
    reason = None
    if record.return_waypoints is None:
        reason = NO_RETURN if any(view.acquired for view in record.views) else NOTHING_ACQUIRED
    return {"waypoints": _corners(record.return_waypoints), "reason": reason}


def episode_document(scene: PartScene, record: EpisodeRecord,
                     metadata: dict[str, Any] | None = None,
                     estimates: np.ndarray | None = None,
                     ground_truth: bool = True) -> dict[str, Any]:
    """The plan JSON of an episode: object placement, robot, sensor, views, final coverage,
    travel, and the ground truth to re-check the coverage.

    `views[i].travel` is the move from the previous view (for the first view: the approach from
    `start_joints`); `approach` repeats the approach and `travel` sums the moves between views
    (k_cum, docs/states-actions-rewards.md#travel-costs), which exclude it. With the robot,
    `return` holds the way back to the start and `cycle_time` the cycle the episode timed
    (`EpisodeRecord.cycle`, docs/motion.md#cycle-time); null where the cycle cannot be closed.

    Args:
        scene: The part's scene the episode ran in.
        record: The episode.
        metadata: Extra top-level entries (planner, carrier, seed, ...).
        estimates: The model-free coverage estimate (mean, std) after each view, written as
            `views[i].estimate` when given; a third column, the calibrated probability that
            the goal is reached (`--stop confident`), as its `p_goal`.
        ground_truth: Whether to write the ground-truth block (a replay computes it again).
    """
    document = plan_document(scene.cell, planned_views(record),
                             scene.object_block(record.object_pose), record.coverage)
    document["carrier"] = record.carrier
    document["start_joints"] = _floats(record.start_joints)
    document["approach"] = record.approach.as_dict()
    document["travel_sum"] = record.travel_sum.as_dict()
    document["return"] = return_block(record)
    document["cycle_time"] = None if record.cycle is None else record.cycle.as_dict()
    if ground_truth:
        document["ground_truth"] = ground_truth_block(record)
    if estimates is not None:
        for view, (mean, std, *probability) in zip(document["views"], estimates, strict=True):
            # A refused estimate (NaN) is null: JSON has no NaN.
            view["estimate"] = (None if np.isnan(mean) else {
                "mean": float(mean), "std": float(std),
                **({"p_goal": float(probability[0])} if probability else {})})
    document.update(metadata or {})
    return document


def write_json(path: str | Path, document: dict[str, Any]) -> Path:
    """Write `document` to `path` atomically (no half-written file on error).

    Raises:
        ValueError: If the parent folder does not exist or `path` is a folder.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"output path {path} is a folder; give a file name such as plan.json")
    if not path.parent.is_dir():
        raise ValueError(f"output folder {path.parent} does not exist")
    return write_text(path, json.dumps(document, indent=2, allow_nan=False) + "\n")
