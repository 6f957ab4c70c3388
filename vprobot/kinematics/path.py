"""Joint-space paths: straight lines in joint space, sampled for collision checking."""

from __future__ import annotations

import math

import numpy as np


def joint_path(q_from: np.ndarray, q_to: np.ndarray, max_joint_step_rad: float) -> np.ndarray:
    """Configurations along the straight joint-space line from `q_from` to `q_to`.

    Args:
        q_from: Start configuration.
        q_to: End configuration.
        max_joint_step_rad: No joint moves more than this between consecutive samples.

    Returns:
        Array (n, dof) including both ends exactly, n >= 2.
    """
    if max_joint_step_rad <= 0:
        raise ValueError(f"max_joint_step_rad must be > 0, got {max_joint_step_rad}")
    steps = max(1, math.ceil(float(np.max(np.abs(q_to - q_from))) / max_joint_step_rad))
    fractions = np.linspace(0.0, 1.0, steps + 1)[:, None]
    path = q_from + fractions * (q_to - q_from)
    path[-1] = q_to  # exactly, not up to rounding: a path's corners are configurations asked for
    return path
