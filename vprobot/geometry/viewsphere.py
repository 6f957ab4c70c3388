"""Candidate sensor positions spread evenly on a sphere around the object."""

from __future__ import annotations

import numpy as np

GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def sphere_directions(count: int, max_polar_rad: float = np.pi) -> np.ndarray:
    """Unit vectors (count, 3) spread evenly over the cap with polar angle <= `max_polar_rad`.

    A Fibonacci lattice: equal-area bands in z, golden-angle steps in azimuth.

    Raises:
        ValueError: If count < 1 or the polar limit is outside (0, pi].
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    if not 0.0 < max_polar_rad <= np.pi:
        raise ValueError(f"max_polar_rad must lie in (0, pi], got {max_polar_rad}")
    z_min = np.cos(max_polar_rad)
    index = np.arange(count) + 0.5
    z = 1.0 - index / count * (1.0 - z_min)
    radius = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    azimuth = GOLDEN_ANGLE * index
    return np.column_stack([radius * np.cos(azimuth), radius * np.sin(azimuth), z])
