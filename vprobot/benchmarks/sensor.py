"""Sensor benchmark: acquisition speed against trimesh and under the structured-light model, GT
build time, training resolution."""

from __future__ import annotations

import time
from typing import Any

import mujoco
import numpy as np
import trimesh
import trimesh.ray.ray_triangle
from tqdm import tqdm

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import TRAINING_RESOLUTION, DepthSensor
from vprobot.config import Config, sensor_preset
from vprobot.coverage.ground_truth import build_ground_truth
from vprobot.coverage.tracker import CoverageTracker
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.poses import Pose
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.parts.loading import load_mesh
from vprobot.sensing import IDEAL, StructuredLight

MAX_POLAR_DEG = 120.0
"""Views come from the top down to 30 degrees below the equator
(docs/ground-truth-and-coverage.md#the-view-band)."""
OTHER_RESOLUTIONS = ((215, 150),)
"""Coarser frames whose coverage error is reported next to the training resolution's."""
STRUCTURED_LIGHT_PRESET = "zivid2plus_mr60"
"""Whose structured-light figures are timed on a sensor that has none (the paper's)."""


def _structured_light(config: Config) -> tuple[StructuredLight, str]:
    """The structured-light figures to time, and where they come from."""
    if config.sensor.structured_light is not None:
        return config.sensor.structured_light, "the config's sensor"
    figures = sensor_preset(STRUCTURED_LIGHT_PRESET).structured_light
    assert figures is not None  # the preset is a structured-light sensor's
    return figures, STRUCTURED_LIGHT_PRESET


def _random_reachable_views(arm: RobotArm, count: int, seed: int,
                            progress: bool) -> list[np.ndarray]:
    """Configurations reaching random views: direction on the view sphere, distance in
    [0.40, 0.50] m, aimed within 2 cm of the object centre."""
    rng = np.random.default_rng(seed)
    center = arm.cell.object_center
    min_z = np.cos(np.deg2rad(MAX_POLAR_DEG))
    configurations: list[np.ndarray] = []
    with tqdm(total=count, desc="reachable views", disable=not progress, leave=False) as bar:
        while len(configurations) < count:
            z = rng.uniform(min_z, 1.0)
            azimuth = rng.uniform(-np.pi, np.pi)
            direction = np.array([np.sqrt(1 - z * z) * np.cos(azimuth),
                                  np.sqrt(1 - z * z) * np.sin(azimuth), z])
            target = SensorTarget.look_at(center + rng.uniform(0.40, 0.50) * direction,
                                          center + rng.uniform(-0.02, 0.02, 3))
            result = arm.reach(target, arm.joints.start)
            if result.reachable:
                configurations.append(result.q)
                bar.update()
    return configurations


def _time_ms(function: Any, repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append((time.perf_counter() - start) * 1e3)
    return times


def _trimesh_frame_ms(intersector: Any, pose: Pose, directions: np.ndarray,
                      sample: np.ndarray | None) -> float:
    """Time of trimesh's first hits for the frame's rays, scaled up from `sample` if given."""
    rays = directions if sample is None else directions[sample]
    origins = np.tile(pose.position, (len(rays), 1))
    start = time.perf_counter()
    intersector.intersects_location(origins, rays, multiple_hits=False)
    elapsed = (time.perf_counter() - start) * 1e3
    return elapsed * len(directions) / len(rays)


def run_sensor_benchmark(config: Config, views: int = 20, coverage_views: int = 60,
                         trimesh_sample: int = 1000, progress: bool = True) -> dict[str, Any]:
    """Measure the sensor, ground-truth and coverage targets on the bundled test motor.

    Args:
        config: Cell and sensor settings (the full resolution is the sensor's).
        views: Reachable views for the acquisition timings.
        coverage_views: Random reachable views for the training-resolution comparison.
        trimesh_sample: Rays per frame timed with trimesh's default intersector (scaled up).
        progress: Show progress bars.

    Returns:
        `acquire_full_median_ms` (full frame in the full cell, ideal sensing),
        `acquire_full_p95_ms`, `structured_light_median_ms` and `structured_light_ratio` (the
        same frames under the structured-light model, timed alternately with the ideal ones,
        over the ideal median; the figures of the config's sensor, or of
        `STRUCTURED_LIGHT_PRESET` where it has none), `structured_light_points_fraction`,
        `trimesh_frame_median_ms` and `trimesh_speedup` (the same rays, object mesh only, with
        `trimesh.ray.ray_triangle.RayMeshIntersector`, over ours), `embree_frame_median_ms`
        and `embree_ratio` (ours over trimesh with embree; None without embreex),
        `gt_build_s` (GT of the motor, no cache), `training_resolution` [w, h],
        `training_acquire_median_ms`, `training_resolution_coverage_mae_pp` (mean absolute
        difference of single-view coverage against full resolution, percentage points) and
        `coverage_mae_pp_by_resolution` for further coarser frames.
    """
    mesh = load_mesh(DEFAULT_MOTOR).mesh
    cell = Cell(config, mesh)
    arm = RobotArm(cell)
    data = cell.make_data()
    # Ideal explicitly: a real-device preset's own default is the structured-light model.
    sensor = DepthSensor(cell, sensing=IDEAL)
    light, light_source = _structured_light(config)
    structured = DepthSensor(cell, sensing=light)
    configurations = _random_reachable_views(arm, max(views, coverage_views), seed=7,
                                             progress=progress)

    def pose_at(q: np.ndarray) -> Pose:
        data.qpos[:] = q
        mujoco.mj_kinematics(cell.model, data)
        site = cell.sensor_site_id
        return Pose(data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy())

    placed = mesh.copy()
    placed.apply_translation(cell.object_center)
    default_intersector = trimesh.ray.ray_triangle.RayMeshIntersector(placed)
    embree_intersector = None
    if trimesh.ray.has_embree:
        from trimesh.ray import ray_pyembree

        embree_intersector = ray_pyembree.RayMeshIntersector(placed)
    rng = np.random.default_rng(8)
    ours_ms, structured_ms, trimesh_ms, embree_ms, points, structured_points = ([] for _ in
                                                                                range(6))
    for q in tqdm(configurations[:views], desc="acquisition", disable=not progress,
                  leave=False):
        pose = pose_at(q)
        for _ in range(5):  # alternately, so that both see the same machine
            ours_ms += _time_ms(lambda: sensor.acquire(data), repeats=1)
            structured_ms += _time_ms(lambda: structured.acquire(data), repeats=1)
        points.append(len(sensor.acquire(data)))
        structured_points.append(len(structured.acquire(data)))
        directions = sensor.directions @ pose.rotation.T
        sample = rng.choice(len(directions), size=min(trimesh_sample, len(directions)),
                            replace=False)
        trimesh_ms.append(_trimesh_frame_ms(default_intersector, pose, directions, sample))
        if embree_intersector is not None:
            embree_ms.append(_trimesh_frame_ms(embree_intersector, pose, directions, None))
    ours_median = float(np.median(ours_ms))
    trimesh_median = float(np.median(trimesh_ms))
    embree_median = float(np.median(embree_ms)) if embree_ms else None

    start = time.perf_counter()
    ground_truth = build_ground_truth(mesh, config)
    gt_build_s = time.perf_counter() - start

    resolutions = (TRAINING_RESOLUTION, *OTHER_RESOLUTIONS)
    coarse = {resolution: DepthSensor(cell, resolution=resolution, sensing=IDEAL)
              for resolution in resolutions}
    differences: dict[tuple[int, int], list[float]] = {r: [] for r in resolutions}
    coarse_ms: list[float] = []
    for q in tqdm(configurations[:coverage_views], desc="training resolution",
                  disable=not progress, leave=False):
        pose_at(q)
        full = CoverageTracker.from_ground_truth(ground_truth)
        full.update(sensor.acquire(data).points_mesh)
        for resolution, coarse_sensor in coarse.items():
            tracker = CoverageTracker.from_ground_truth(ground_truth)
            start = time.perf_counter()
            acquisition = coarse_sensor.acquire(data)
            if resolution == TRAINING_RESOLUTION:
                coarse_ms.append((time.perf_counter() - start) * 1e3)
            tracker.update(acquisition.points_mesh)
            differences[resolution].append(abs(tracker.coverage - full.coverage) * 100.0)

    return {
        "motor": DEFAULT_MOTOR.name,
        "full_resolution": list(sensor.resolution),
        "views": views,
        "acquire_full_median_ms": ours_median,
        "acquire_full_p95_ms": float(np.percentile(ours_ms, 95)),
        "points_per_frame_median": float(np.median(points)),
        "structured_light_figures": light_source,
        "structured_light_median_ms": float(np.median(structured_ms)),
        "structured_light_ratio": float(np.median(structured_ms)) / ours_median,
        "structured_light_points_fraction": float(np.sum(structured_points) / np.sum(points)),
        "trimesh_frame_median_ms": trimesh_median,
        "trimesh_speedup": trimesh_median / ours_median,
        "trimesh_rays_timed_per_frame": int(min(trimesh_sample, sensor.rays_per_frame)),
        "embree_frame_median_ms": embree_median,
        "embree_ratio": ours_median / embree_median if embree_median else None,
        "gt_build_s": gt_build_s,
        "gt_spacing_mm": ground_truth.spacing_m * 1e3,
        "training_resolution": list(TRAINING_RESOLUTION),
        "training_acquire_median_ms": float(np.median(coarse_ms)),
        "training_resolution_coverage_mae_pp": float(np.mean(differences[TRAINING_RESOLUTION])),
        "coverage_views": coverage_views,
        "coverage_mae_pp_by_resolution": {
            f"{w}x{h}": float(np.mean(values)) for (w, h), values in differences.items()
        },
    }


TARGETS = {
    "acquire_full_median_ms": ("<=", 50.0),
    "structured_light_ratio": ("<=", 2.0),
    "trimesh_speedup": (">=", 100.0),
    "gt_build_s": ("<=", 2.0),
    "training_resolution_coverage_mae_pp": ("<=", 1.0),
}


def print_table(results: dict[str, Any]) -> None:
    """Print the results as a two-column table, with the target next to the targeted ones."""
    width = max(len(key) for key in results)
    for key, value in results.items():
        text = f"{value:.3g}" if isinstance(value, float) else str(value)
        if key in TARGETS:
            relation, bound = TARGETS[key]
            met = value <= bound if relation == "<=" else value >= bound
            text += f"   (target {relation} {bound:g}: {'met' if met else 'MISSED'})"
        print(f"{key:<{width}}  {text}")
