"""Ground truth P_GT: exactly 2048 points spread evenly over a mesh's inspectable surface.

The inspectable surface is the part of the surface that some sensor pose can measure. It is
found with the sensor model itself, with the object placed upright in the configured cell (its
mesh frame parallel to the world, the fixture plate under its lowest point):

1. Candidate views: `VIEW_COUNT` sensor poses spread evenly (Fibonacci lattice) over the view
   sphere at the sensor's working distance around the object centre, from the top down to
   `MAX_POLAR_DEG` = 120° (30° below the equator, the view band of
   docs/ground-truth-and-coverage.md#the-view-band), each looking at
   the centre.
2. From every view the sensor (at the coarser `RESOLUTION`, same opening angles and range)
   measures the object with the fixture plate, pedestal, floor and robot stand occluding; the
   robot arm is left out, since its configuration differs from view to view. A surface point
   is inspectable when some view measures it within [near, far]: the face resting on the fixture
   plate and cavities no view reaches get no points. The views measure under the sensor's
   sensing model without its noise and dropout (`gt_sensing`): under `structured_light` a point
   must also be lit by the projector and within both incidence limits in some view, so that
   the inspectable surface is what the modelled sensor can measure and 90 % stays reachable.
3. The union of the measured points, in the mesh frame, is voxel-downsampled to exactly
   N_GT = 2048 points: the voxel size is found by bisection as the largest size for which at
   least 2048 voxels are occupied; each voxel is represented by its measured point nearest the
   voxel's centroid (so that every GT point lies on the surface), and farthest-point sampling,
   started from the point nearest the centroid of all, keeps exactly 2048 of them.
4. The GT spacing is the mean nearest-neighbour distance of P_GT; coverage scales its matching
   distance with it (see `vprobot.coverage.tracker`).

P_GT lives in the mesh frame, so it turns with the object when an episode re-poses it; its
inspectability is that of the upright placement. The result is deterministic and cached in
memory and on disk (an `.npz` per mesh under `default_cache_dir()`, written atomically), keyed
by the mesh hash (sha256 of its vertices and faces) and the settings that shape it (with the
robot folder's description and MJCF files, whose scene and base placement occlude, and a
sensing model other than `ideal` with what of it shapes the GT, `ground_truth_key`: for
`structured_light` its baseline and incidence limits). A cache
file that does not hold a valid GT of the mesh is recomputed and replaced; a cache directory
that cannot be written draws one warning per process and the GT is then only kept in memory.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import DepthSensor
from vprobot.config import Config, SensorConfig
from vprobot.files.atomic import read_cached_arrays, write_cached_arrays
from vprobot.files.paths import cache_root
from vprobot.files.progress import stage
from vprobot.geometry.poses import Pose
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.robots import robot_folder
from vprobot.robots.description import DESCRIPTION_FILE
from vprobot.sensing import SensingModel

N_GT = 2048
VIEW_COUNT = 120
MAX_POLAR_DEG = 120.0
RESOLUTION = (143, 100)
ENVIRONMENT_GROUP = 0
"""Geom group of the fixture, floor and robot stand (see `vprobot.cell.scene`)."""
_METHOD_VERSION = 1
_BISECTION_STEPS = 24
_FINE_VOXELS = 400
"""The union of views is first thinned to voxels of 1/400 of the object's extent."""


@dataclasses.dataclass(frozen=True)
class GroundTruth:
    """The ground-truth cloud of one mesh.

    Attributes:
        points: The N_GT points (N_GT, 3) in the mesh frame (read-only).
        spacing_m: Mean distance from a point to its nearest neighbour.
        voxel_size_m: Voxel size of the downsampling that produced the points.
        mesh_hash: sha256 of the mesh's vertices and faces.
        views: Candidate views that measured some of the object.
    """

    points: np.ndarray
    spacing_m: float
    voxel_size_m: float
    mesh_hash: str
    views: int


_MEMORY_CACHE: dict[str, GroundTruth] = {}


def mesh_hash(mesh: trimesh.Trimesh) -> str:
    """sha256 of a mesh's geometry (float64 vertices, int64 faces)."""
    digest = hashlib.sha256(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return digest.hexdigest()


def default_cache_dir() -> Path:
    """`$VPROBOT_CACHE_DIR/ground_truth`, or `~/.cache/vprobot/ground_truth`."""
    return cache_root() / "ground_truth"


def ground_truth(mesh: trimesh.Trimesh, config: Config, cache_dir: str | Path | None = None,
                 use_cache: bool = True) -> GroundTruth:
    """The GT of `mesh`, from the memory or disk cache when it was computed before.

    Args:
        mesh: The object, centred at its bounding-box centre, in metres.
        config: Cell and sensor settings.
        cache_dir: Where the `.npz` files live; `default_cache_dir()` when omitted.
        use_cache: False always recomputes and stores nothing.

    A cache file that does not hold a valid GT of `mesh` (truncated, garbage, wrong contents)
    is recomputed and replaced. When the cache directory cannot be written, a RuntimeWarning
    says so once per process and directory, and the GT is returned uncached on disk.

    Raises:
        ValueError: If the mesh has no faces or no view measures any of it.
    """
    if not use_cache:
        return build_ground_truth(mesh, config)
    key = _cache_key(mesh, config)
    if key in _MEMORY_CACHE:
        return _MEMORY_CACHE[key]
    path = Path(cache_dir if cache_dir is not None else default_cache_dir()) / f"{key}.npz"
    result = _read(path, mesh_hash(mesh))
    if result is None:
        result = build_ground_truth(mesh, config)
        _write(path, result)
    _MEMORY_CACHE[key] = result
    return result


def build_ground_truth(mesh: trimesh.Trimesh, config: Config) -> GroundTruth:
    """Compute the GT of `mesh` (no cache); see the module docstring for the method.

    Raises:
        ValueError: If the mesh has no faces or no view measures any of it.
    """
    if len(mesh.faces) == 0:
        raise ValueError("mesh has no faces: no ground truth")
    points, views = inspectable_points(mesh, config)
    if len(points) < N_GT:
        raise ValueError(f"the sensor measures only {len(points)} points of the mesh from "
                         f"{VIEW_COUNT} views, fewer than N_GT = {N_GT}; is it far larger "
                         f"than the frustum or hidden by the fixture?")
    voxel_size, representatives = _downsample_to_at_least(points, N_GT)
    chosen = representatives[_farthest_point_order(representatives, N_GT)]
    chosen.setflags(write=False)
    distances, _ = cKDTree(chosen).query(chosen, k=2)
    return GroundTruth(points=chosen, spacing_m=float(np.asarray(distances)[:, 1].mean()),
                       voxel_size_m=voxel_size, mesh_hash=mesh_hash(mesh), views=views)


def inspectable_points(mesh: trimesh.Trimesh, config: Config) -> tuple[np.ndarray, int]:
    """All points the candidate views measure on the upright mesh, in the mesh frame.

    Returns:
        The points (n, 3) and the number of views that measured any.
    """
    cell = Cell(config, mesh)
    data = cell.make_data()
    sensor = DepthSensor(cell, resolution=RESOLUTION, workers=1, groups=(
        ENVIRONMENT_GROUP, *{int(g) for g in cell.model.geom_group[cell.object_geom_ids]}),
        sensing=gt_sensing(config.sensor))
    directions = sphere_directions(VIEW_COUNT, np.deg2rad(MAX_POLAR_DEG))
    center = cell.object_center
    clouds = []
    for direction in stage("ground truth", len(directions), "view", directions):
        pose = Pose.look_at(center + sensor.sensor.working_distance_m * direction, center)
        acquisition = sensor.acquire_from_pose(data, pose)
        if len(acquisition):
            clouds.append(acquisition.points_mesh)
    points = np.concatenate(clouds) if clouds else np.zeros((0, 3))
    return points, len(clouds)


def gt_sensing(sensor: SensorConfig) -> SensingModel:
    """The sensing model the GT views measure with: the sensor's, without its random draws
    (`SensingModel.deterministic`).

    A point some view measures with a probability above 0 is inspectable (dropout is drawn per
    frame, and noise moves a point without losing it), so only the model's deterministic limits
    (for `structured_light`, the projector's shadow and the incidence limits) shape the
    inspectable surface.
    """
    return sensor.sensing_model.deterministic()


def _packed_voxel_keys(points: np.ndarray, voxel_size: float) -> np.ndarray:
    """One int64 per point naming its voxel on a grid anchored at the origin."""
    packed = np.zeros(len(points), dtype=np.int64)
    # Column by column: numpy's reductions over rows of three are slow.
    for axis in range(3):
        keys = np.floor(points[:, axis] / voxel_size).astype(np.int64)
        keys -= keys.min()
        packed = packed * (int(keys.max()) + 1) + keys
    return packed


def voxel_indices(points: np.ndarray, voxel_size: float) -> tuple[np.ndarray, int]:
    """Voxel of every point on a grid anchored at the origin, numbered 0..count-1.

    Returns:
        The voxel index (n,) of every point, in sorted voxel order, and the voxel count.
    """
    occupied, inverse = np.unique(_packed_voxel_keys(points, voxel_size), return_inverse=True)
    return inverse, len(occupied)


def nearest_to_centroids(points: np.ndarray, voxel: np.ndarray, count: int) -> np.ndarray:
    """Per voxel, the index of its point nearest the centroid of its points."""
    sizes = np.bincount(voxel, minlength=count)
    gap = np.zeros(len(points))
    for axis in range(3):
        centroid = np.bincount(voxel, weights=points[:, axis], minlength=count) / sizes
        gap += (points[:, axis] - centroid[voxel]) ** 2
    smallest = np.full(count, np.inf)
    np.minimum.at(smallest, voxel, gap)
    nearest = np.flatnonzero(gap == smallest[voxel])
    # Ties keep the voxel's first point.
    _, first = np.unique(voxel[nearest], return_index=True)
    return nearest[first]


def _downsample_to_at_least(points: np.ndarray, count: int) -> tuple[float, np.ndarray]:
    """Largest voxel size (by bisection) leaving >= `count` voxels; one point per voxel.

    Each voxel is represented by its point nearest the centroid of its points.
    """
    extent = float(np.ptp(points, axis=0).max())
    # The views overlap a lot: thin the union on a fine grid first, which keeps the bisection
    # cheap and moves a representative by at most a fine voxel.
    points = points[nearest_to_centroids(points, *voxel_indices(points, extent / _FINE_VOXELS))]
    small, large = extent / _FINE_VOXELS, extent
    for _ in range(_BISECTION_STEPS):
        middle = np.sqrt(small * large)
        if len(np.unique(_packed_voxel_keys(points, middle))) >= count:
            small = middle
        else:
            large = middle
    return small, points[nearest_to_centroids(points, *voxel_indices(points, small))]


def _farthest_point_order(points: np.ndarray, count: int) -> np.ndarray:
    """Indices of `count` points by farthest-point sampling, from the one nearest the centroid."""
    columns = np.ascontiguousarray(points.T)

    def squared_distances(point: np.ndarray) -> np.ndarray:
        # Column by column: numpy's reductions over rows of three are slow.
        return ((columns[0] - point[0]) ** 2 + (columns[1] - point[1]) ** 2
                + (columns[2] - point[2]) ** 2)

    chosen = np.empty(count, dtype=np.int64)
    chosen[0] = int(np.argmin(squared_distances(points.mean(axis=0))))
    nearest = squared_distances(points[chosen[0]])
    for index in range(1, count):
        chosen[index] = int(np.argmax(nearest))
        np.minimum(nearest, squared_distances(points[chosen[index]]), out=nearest)
    return chosen


def _cache_key(mesh: trimesh.Trimesh, config: Config) -> str:
    """`<mesh hash>-<settings hash>`: the mesh, plus everything that shapes its GT."""
    settings: tuple[Any, ...] = (_METHOD_VERSION, N_GT, VIEW_COUNT, MAX_POLAR_DEG, RESOLUTION,
                ENVIRONMENT_GROUP, dataclasses.astuple(config.cell),
                _sensor_settings(config.sensor), robot_digest(config.cell.robot))
    # Only a model other than the ideal one joins the key (`ground_truth_key`): the ideal GTs
    # keep the keys they always had, and their caches stay valid.
    settings += gt_sensing(config.sensor).ground_truth_key()
    text = repr(settings)
    return f"{mesh_hash(mesh)[:32]}-{hashlib.sha256(text.encode()).hexdigest()[:16]}"


def _sensor_settings(sensor: SensorConfig) -> tuple[Any, ...]:
    """The sensor's settings as the GT key has always held them: all but the sensing model, which
    `_cache_key` adds where it is not the ideal one, and the acquisition time, which does not
    shape the GT."""
    return tuple(getattr(sensor, field.name) for field in dataclasses.fields(sensor)
                 if field.name not in ("sensing", "structured_light", "acquisition_time_s"))


def robot_digest(robot: str) -> str:
    """sha256 of the robot folder's description and MJCF files: the robot's name alone does not
    fix its scene (floor, fixture plate, pedestal) or its own base placement (the stand), which
    occlude in the GT and may differ between versions or be edited in a user's folder."""
    folder = robot_folder(robot)
    digest = hashlib.sha256()
    for path in sorted([folder / DESCRIPTION_FILE, *folder.glob("*.xml")]):
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


_SCALAR_KINDS = {"spacing_m": "f", "voxel_size_m": "f", "mesh_hash": "U", "views": "iu"}
"""numpy dtype kinds of the scalars stored beside the points."""


def _read(path: Path, expected_hash: str) -> GroundTruth | None:
    """The GT cached at `path`, or None when there is none or it is not a valid GT of the mesh.

    Args:
        path: The `.npz` file.
        expected_hash: `mesh_hash` of the mesh the file must belong to.
    """
    arrays = read_cached_arrays(path)
    if arrays is None or set(arrays) != {"points", *_SCALAR_KINDS}:
        return None
    points = arrays["points"]
    if points.dtype != np.float64 or points.shape != (N_GT, 3) or not np.isfinite(points).all():
        return None
    if any(arrays[name].shape != () or arrays[name].dtype.kind not in kinds
           for name, kinds in _SCALAR_KINDS.items()):
        return None
    result = GroundTruth(points=points, spacing_m=float(arrays["spacing_m"]),
                        voxel_size_m=float(arrays["voxel_size_m"]),
                        mesh_hash=str(arrays["mesh_hash"]), views=int(arrays["views"]))
    if (result.mesh_hash != expected_hash or not 1 <= result.views <= VIEW_COUNT
            or not (np.isfinite(result.spacing_m) and result.spacing_m > 0)
            or not (np.isfinite(result.voxel_size_m) and result.voxel_size_m > 0)):
        return None
    points.setflags(write=False)
    return result


def _write(path: Path, result: GroundTruth) -> None:
    """Store in the cache (`write_cached_arrays`)."""
    write_cached_arrays(path, {"points": result.points, "spacing_m": result.spacing_m,
                               "voxel_size_m": result.voxel_size_m,
                               "mesh_hash": result.mesh_hash, "views": result.views},
                        "ground truths", stacklevel=4)
