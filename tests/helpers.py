"""Helpers shared by several test modules (test modules never import each other)."""

from __future__ import annotations

import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import trimesh
from scipy.spatial.distance import pdist

from vprobot.config import Config
from vprobot.families import FAMILIES
from vprobot.files.paths import DEFAULT_MOTOR, MOTORS_DIR, OBJECTS_DIR


def _add_mesh(spec: mujoco.MjSpec, name: str, mesh: trimesh.Trimesh) -> None:
    asset = spec.add_mesh(name=name,
                          uservert=np.asarray(mesh.vertices, np.float32).ravel().tolist(),
                          userface=np.asarray(mesh.faces, np.int32).ravel().tolist())
    asset.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL


def make_scene(mesh: trimesh.Trimesh, boxes: tuple = (), mesh_boxes: tuple = ()
               ) -> tuple[types.SimpleNamespace, mujoco.MjData]:
    """A bare cell: the object at the origin, a free-floating sensor and optional plates.

    `boxes` are primitive box geoms (cast by MuJoCo), `mesh_boxes` box-shaped mesh geoms
    (scan converted), each as (centre, half sizes).
    """
    spec = mujoco.MjSpec()
    sensor_body = spec.worldbody.add_body(name="sensor_body", mocap=True)
    sensor_body.add_site(name="sensor")
    _add_mesh(spec, "object_mesh", mesh)
    spec.worldbody.add_body(name="object", mocap=True).add_geom(
        name="object", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="object_mesh", group=1)
    for index, (center, half) in enumerate(boxes):
        spec.worldbody.add_geom(name=f"box{index}", type=mujoco.mjtGeom.mjGEOM_BOX,
                                pos=list(center), size=list(half), group=0)
    for index, (center, half) in enumerate(mesh_boxes):
        _add_mesh(spec, f"plate{index}", trimesh.creation.box(2.0 * np.asarray(half)))
        spec.worldbody.add_geom(name=f"mesh_box{index}", type=mujoco.mjtGeom.mjGEOM_MESH,
                                meshname=f"plate{index}", pos=list(center), group=2)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    scene = types.SimpleNamespace(
        model=model, config=Config(), sensor_site_id=model.site("sensor").id,
        sensor_body_id=model.body("sensor_body").id, object_body_id=model.body("object").id,
        object_geom_ids=np.array([model.geom("object").id]))
    return scene, data


# How far a coverage may move between CPUs whose BLAS kernels vprobot does not pin (no AVX2,
# vprobot/compute/kernels.py): the same views' coverage differs by up to 3 of the 2048 GT points
# (0.15 pp) between OpenBLAS's kernels (results/cpu_spread/: last-bit differences in the GT's
# sensed points move points across the voxel and ε boundaries). A test comparing a coverage
# with a threshold keeps this margin.
COVERAGE_CPU_MARGIN = 5 / 2048


SERIAL_EVALUATION = ("evaluate", "--planners", "hrec", "random2", "--parts", str(DEFAULT_MOTOR),
                     "--seeds", "0", "1", "2")
"""`vprobot evaluate` (without --out) of two planners, three seeds and both carriers: 12
episodes. The `serial_evaluation` fixture of conftest.py holds its tables, run once per session
in the test process."""


TINY_TRAINING = (
    # Training draws from one motor (its ground truth is built once per session, not that of
    # all 20 training motors).
    "env.parts=mesh", f"env.mesh={MOTORS_DIR / 'train' / 'motor_000.stl'}",
    "env.resolution=[64,45]", "env.state_points=64", "agent.learning_starts=50",
    "agent.batch_size=32", "agent.buffer_size=400", "agent.eval_freq=100",
    "agent.checkpoint_freq=100", "agent.eval_episodes=1", "agent.net_arch=[16,16]",
    "agent.encoder_settings.pcn.scale=0.05", "agent.encoder_settings.pointnet.scale=0.05",
    "agent.n_steps=64", "agent.n_epochs=1",
    # Random early actions ask for many moves around the fixture; a search that cannot connect
    # gives up after 2 000 collision checks instead of 20 000.
    "kinematics.path_planning_checks=2000")
"""`--set` overrides of the CPU profile for training runs of a few seconds."""

SmokeRuns = Callable[[str, str, bool], tuple[Config, dict[str, Any], Path]]
"""conftest's `smoke_runs`: (algorithm, encoder, robot state) -> the run's config, its result
and its folder."""


def shape_descriptor(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation-invariant shape statistics from 512 surface points (Osada et al. 2002): the
    distribution of pair distances over their mean (D2), the distribution of |cos| between the
    pairs' normals, and the log of seven linear sizes (cube root of volume and of hull volume,
    square root of area, the three principal spreads of the points)."""
    points, faces = trimesh.sample.sample_surface(mesh, 512, seed=0)
    distances = pdist(points)
    d2 = np.histogram(distances / distances.mean(), bins=32, range=(0, 3))[0]
    # Clipped: rounding puts the |cos| of parallel faces a hair above 1, out of the range.
    cosines = np.clip(np.abs(1 - pdist(mesh.face_normals[faces], "cosine")), 0, 1)
    angles = np.histogram(cosines, bins=16, range=(0, 1))[0]
    spreads = np.sqrt(np.clip(np.linalg.eigvalsh(np.cov(points.T)), 0, None))
    sizes = np.log([np.cbrt(mesh.volume), np.sqrt(mesh.area), np.cbrt(mesh.convex_hull.volume),
                    *spreads])
    return d2 / d2.sum(), angles / angles.sum(), sizes


def likeness(a: tuple[np.ndarray, ...], b: tuple[np.ndarray, ...]) -> float:
    """Below 1 when two shapes are near-duplicates: D2 within 0.05 (L1), the normal-angle
    distribution within 0.1 (L1), and every linear size within 15 %."""
    return max(np.abs(a[0] - b[0]).sum() / 0.05, np.abs(a[1] - b[1]).sum() / 0.1,
               np.abs(a[2] - b[2]).max() / np.log(1.15))


HELD_OUT_FAMILIES = ("bracket", "pipe_fitting", "pulley", "valve_body")
HELD_OUT_SEEDS = range(20000, 20008)


def held_out_test_objects() -> list[trimesh.Trimesh]:
    """The held-out test objects that no training part may nearly duplicate (`likeness`):
    instances 20000-20007 of each test family and the three test shapes (the first: instance
    20000 of the first family). Their descriptors: conftest's `held_out_descriptors`."""
    tests = [FAMILIES[family].instance(seed).mesh
             for family in HELD_OUT_FAMILIES for seed in HELD_OUT_SEEDS]
    return tests + [trimesh.load(OBJECTS_DIR / f"{name}.stl")
                    for name in ("bracket", "pipe_tee", "torus")]
