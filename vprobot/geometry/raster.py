"""Scan conversion of triangles onto a pinhole grid of pixel centres.

Both the sensor (`vprobot.cell.sensor`) and the planners' visibility prediction
(`vprobot.planners.visibility`) find, per triangle, the pixel centres (u_j, v_i) it covers. Each
triangle comes as three edge functions e(u, v) = a u + b v + c, oriented so that a centre is
covered when all three are >= 0; the users build them differently (3D edge planes through the
optical centre, or 2D edges of the projected triangle) and keep their own depth test.
"""

from __future__ import annotations

import numpy as np

Edge = tuple[np.ndarray, np.ndarray, np.ndarray]
"""(a, b, c) per triangle of one edge function a u + b v + c, inside where >= 0."""


def min3(values: list[np.ndarray]) -> np.ndarray:
    """Elementwise minimum of three arrays (numpy's axis reductions over three are slower)."""
    return np.minimum(np.minimum(values[0], values[1]), values[2])


def max3(values: list[np.ndarray]) -> np.ndarray:
    """Elementwise maximum of three arrays."""
    return np.maximum(np.maximum(values[0], values[1]), values[2])


def ranks(counts: np.ndarray) -> np.ndarray:
    """0, 1, ..., counts[k] - 1 for every k, concatenated."""
    starts = np.cumsum(counts) - counts
    return np.arange(int(counts.sum())) - np.repeat(starts, counts)


def index_range(low: np.ndarray, high: np.ndarray, centres: np.ndarray,
                slack: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """First and last index of the evenly spaced `centres` within [low, high], per entry.

    Empty ranges have last < first. `slack` (in units of the spacing) widens every range.
    """
    if len(centres) == 1:
        inside = (low <= centres[0]) & (high >= centres[0])
        return np.zeros(len(low), dtype=np.int64), np.where(inside, 0, -1)
    step = (centres[-1] - centres[0]) / (len(centres) - 1)
    with np.errstate(invalid="ignore"):
        # Clamping first keeps unbounded ranges finite.
        first = np.ceil((np.maximum(low, centres[0] - step) - centres[0]) / step - slack)
        last = np.floor((np.minimum(high, centres[-1] + step) - centres[0]) / step + slack)
    return (np.clip(first, 0, len(centres)).astype(np.int64),
            np.clip(last, -1, len(centres) - 1).astype(np.int64))


def covered_pixels(edges: list[Edge], row_lo: np.ndarray, row_hi: np.ndarray, u: np.ndarray,
                   v: np.ndarray, slack: float = 0.0) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray]:
    """Every (triangle, row, column) whose pixel centre lies inside the triangle.

    Args:
        edges: The triangles' three edge functions.
        row_lo: First pixel row to scan per triangle (e.g. from the triangle's v-range).
        row_hi: Last pixel row to scan; triangles with row_hi < row_lo cover nothing.
        u: Evenly spaced pixel-column centres.
        v: Pixel-row centres.
        slack: Widens each row's column span by this much (in u units) on both sides, and
            the span's index range as in `index_range`, so that a centre on an edge shared by
            two triangles is not lost to rounding.

    Returns:
        Triangle index, row and column of every covered pixel centre.
    """
    rows_per_triangle = np.maximum(row_hi - row_lo + 1, 0)
    triangle_of_row = np.repeat(np.arange(len(rows_per_triangle)), rows_per_triangle)
    row = row_lo[triangle_of_row] + ranks(rows_per_triangle)
    row_v = v[row]
    # On a pixel row each edge bounds u from one side.
    low = np.full(len(row), -np.inf)
    high = np.full(len(row), np.inf)
    feasible = np.ones(len(row), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a, b, c in edges:
            slope = a[triangle_of_row]
            intercept = b[triangle_of_row] * row_v + c[triangle_of_row]
            crossing = -intercept / slope
            low = np.where(slope > 0, np.maximum(low, crossing), low)
            high = np.where(slope < 0, np.minimum(high, crossing), high)
            feasible &= (slope != 0) | (intercept >= 0)
    column_lo, column_hi = index_range(low - slack, high + slack, u, slack)
    columns_per_row = np.where(feasible, np.maximum(column_hi - column_lo + 1, 0), 0)
    entry = np.repeat(np.arange(len(row)), columns_per_row)
    return triangle_of_row[entry], row[entry], column_lo[entry] + ranks(columns_per_row)
