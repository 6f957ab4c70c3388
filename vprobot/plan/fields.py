"""A plan JSON's fields read one by one, each bad value a ValueError naming its field
(docs/plan-format.md)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vprobot.files.schema import brief
from vprobot.geometry.poses import is_rotation_quaternion


def plan_field(block: Any, key: str, where: str) -> Any:
    """`block[key]`, or a ValueError naming the plan's field `where`.`key` as missing."""
    if not isinstance(block, dict) or key not in block:
        raise ValueError(f"plan has no {where}.{key}")
    return block[key]


def plan_array(value: Any, where: str, shape: tuple[int, ...]) -> np.ndarray:
    """`value` as an array of finite floats of `shape` (-1: any length), or a ValueError
    naming the plan's field `where`."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.zeros(0)
    if (array.ndim != len(shape)
            or any(n not in (-1, m) for n, m in zip(shape, array.shape, strict=True))
            or not np.all(np.isfinite(array))):
        wanted = " x ".join("m" if n == -1 else str(n) for n in shape)
        raise ValueError(f"plan {where} must be {wanted} finite numbers, got {brief(value)}")
    return array


def plan_vector(block: Any, key: str, size: int, where: str) -> np.ndarray:
    """The vector `where`.`key` of `size` finite numbers."""
    return plan_array(plan_field(block, key, where), f"{where}.{key}", (size,))


def plan_quaternion(block: Any, key: str, where: str) -> np.ndarray:
    """The quaternion (w, x, y, z) `where`.`key`: four finite numbers, not all zero."""
    value = plan_vector(block, key, 4, where)
    if not is_rotation_quaternion(value):
        raise ValueError(f"plan {where}.{key} must be a non-zero quaternion (w, x, y, z), got "
                         f"{value.tolist()}")
    return value


def plan_number(value: Any, where: str, positive: bool = False) -> float:
    """`value` as a finite number >= 0 (> 0 when `positive`), or a ValueError naming the plan's
    field `where`."""
    if (isinstance(value, bool) or not isinstance(value, int | float)
            or not (0 < value if positive else 0 <= value) or not math.isfinite(value)):
        raise ValueError(f"plan {where} must be a finite number {'>' if positive else '>='} 0, "
                         f"got {brief(value)}")
    return float(value)
