"""Kinematics benchmark: IK speed and success, unreachable verdicts, view-sphere reachability."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from tqdm import tqdm

from vprobot.config import Config
from vprobot.kinematics import UNSOLVED, RobotArm, SensorTarget
from vprobot.kinematics.survey import (
    VIEW_SPHERE_CANDIDATES,
    default_cell,
    view_sphere_survey,
    view_sphere_targets,
)
from vprobot.robots import available_robots


def _random_reachable_targets(arm: RobotArm, count: int, seed: int) -> list[SensorTarget]:
    """Sensor poses of random collision-free configurations (reachable by construction)."""
    rng = np.random.default_rng(seed)
    roll_free = arm.settings.roll == "free"
    targets: list[SensorTarget] = []
    while len(targets) < count:
        q = rng.uniform(np.maximum(arm.joints.lower, -np.pi), np.minimum(arm.joints.upper, np.pi))
        if not arm.collisions.in_collision(q):
            targets.append(SensorTarget(arm.fk(q), roll_free=roll_free))
    return targets


def run_kinematics_benchmark(
    config: Config,
    robots: Sequence[str] | None = None,
    samples: int = 200,
    progress: bool = True,
) -> dict[str, Any]:
    """Measure the kinematics targets of the cell described by `config`.

    Returns:
        `ik_reachable_median_ms` / `_p95_ms` (reach verdicts from home on fk of random
        collision-free configurations), `ik_success_rate` (IK converged on those),
        `unreachable_verdict_median_ms` (view-sphere candidates found unreachable with the
        default robot), `out_of_reach_verdict_median_ms` (targets 2-3 m away),
        `view_sphere_reachable` (robot -> fraction of the 900 candidates; all bundled robots
        unless `robots` names some), `view_sphere_verdict_median_ms` (robot -> median verdict
        times of its reachable and unreachable candidates) and `default_robot`.
    """
    default_robot = config.cell.robot
    robots = available_robots() if robots is None else robots
    arm = RobotArm(default_cell(config))
    ik_ms, converged = [], 0
    for target in tqdm(_random_reachable_targets(arm, samples, seed=11), desc="IK",
                       disable=not progress, leave=False):
        start = time.perf_counter()
        result = arm.reach(target, arm.joints.start)
        ik_ms.append((time.perf_counter() - start) * 1e3)
        converged += result.reason not in UNSOLVED

    rng = np.random.default_rng(12)
    far_ms = []
    for _ in range(samples):
        direction = rng.normal(size=3)
        direction *= rng.uniform(2.0, 3.0) / np.linalg.norm(direction)
        position = arm.shoulder_position + direction
        start = time.perf_counter()
        arm.reach(SensorTarget.look_at(position, arm.cell.object_center), arm.joints.start)
        far_ms.append((time.perf_counter() - start) * 1e3)

    surveys = {}
    for robot in robots:
        robot_arm = arm if robot == default_robot else RobotArm(default_cell(config, robot))
        surveys[robot] = view_sphere_survey(robot_arm, view_sphere_targets(robot_arm.cell),
                                            progress, robot)
    default_survey = surveys.get(default_robot) or view_sphere_survey(
        arm, view_sphere_targets(arm.cell), progress, default_robot
    )
    return {
        "default_robot": default_robot,
        "ik_reachable_median_ms": float(np.median(ik_ms)),
        "ik_reachable_p95_ms": float(np.percentile(ik_ms, 95)),
        "ik_success_rate": converged / samples,
        "unreachable_verdict_median_ms": float(np.median(default_survey["unreachable_ms"]))
        if default_survey["unreachable_ms"] else None,
        "out_of_reach_verdict_median_ms": float(np.median(far_ms)),
        "view_sphere_reachable_verdict_median_ms": float(np.median(default_survey["reachable_ms"])),
        "view_sphere_reachable": {robot: survey["fraction"] for robot, survey in surveys.items()},
        "view_sphere_failures": {robot: survey["reasons"] for robot, survey in surveys.items()},
        "view_sphere_verdict_median_ms": {
            robot: {kind: float(np.median(survey[f"{kind}_ms"])) if survey[f"{kind}_ms"] else None
                    for kind in ("reachable", "unreachable")}
            for robot, survey in surveys.items()},
        "samples": samples,
        "view_sphere_candidates": VIEW_SPHERE_CANDIDATES,
    }
