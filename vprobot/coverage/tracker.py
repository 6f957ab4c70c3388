"""Coverage of the ground truth by the clouds acquired so far
(docs/ground-truth-and-coverage.md#coverage).

Everything lives in the object's mesh frame, the frame of P_GT, so that coverage does not depend
on how an episode poses the object: a world-frame cloud is brought there by the object's pose
(`Acquisition.points_mesh`, or `to_mesh_frame`).

A GT point is covered once an acquired point lies within ε of it. ε scales with the GT density:
ε = `EPSILON_PER_SPACING` x the GT spacing (mean nearest-neighbour distance of P_GT). The paper
uses ε = 2 mm at its density; the bundled motors have a GT spacing of about 4.5 mm, so the factor
0.44 reproduces 2 mm for them and keeps the same ratio for larger or smaller objects. Matching
uses the acquired points themselves (coverage is monotone, so matching each new cloud is the same
as matching the accumulated one). The accumulated cloud P_cov is kept voxel-downsampled to the GT
density (one centroid per voxel of the GT's voxel size) as the compact state the agent sees; it
is not used for matching, because its centroids sit up to half a voxel (about 3 mm) away from
the measured surface, more than ε.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from vprobot.coverage.ground_truth import GroundTruth
from vprobot.geometry.poses import Pose

EPSILON_PER_SPACING = 0.44

# Voxel keys are packed into one int64: 21 bits per axis, offset to be non-negative.
_KEY_BITS = 21
_KEY_OFFSET = 1 << (_KEY_BITS - 1)


def to_mesh_frame(points_world: np.ndarray, object_pose: Pose) -> np.ndarray:
    """Points (n, 3) from the world into the mesh frame of an object at `object_pose`."""
    return (np.asarray(points_world, dtype=float) - object_pose.position) @ object_pose.rotation


@dataclasses.dataclass(frozen=True)
class CoverageStep:
    """What one acquisition added.

    Attributes:
        step: t, counting acquisitions from 1.
        coverage: COV_t = n_t / n_GT.
        delta: ΔCOV_t = COV_t - COV_{t-1}.
        remaining_before: COV_rem,t-1 = 1 - COV_{t-1}.
        remaining: COV_rem,t = 1 - COV_t.
        newly_covered: GT points covered by this acquisition for the first time.
        points: Points in the acquired cloud.
    """

    step: int
    coverage: float
    delta: float
    remaining_before: float
    remaining: float
    newly_covered: int
    points: int


class CoverageTracker:
    """Accumulates acquired clouds and tracks which ground-truth points they cover.

    Args:
        gt_points: P_GT (n_GT, 3) in the mesh frame.
        spacing: GT spacing (m); sets ε and, by default, the voxel size of P_cov.
        voxel_size: Voxel size (m) of the accumulated cloud P_cov; `spacing` when omitted.
        epsilon: Matching distance (m); `EPSILON_PER_SPACING * spacing` when omitted.

    Raises:
        ValueError: If gt_points is not a non-empty finite (n, 3) array, or a length is not
            positive and finite.
    """

    def __init__(self, gt_points: np.ndarray, spacing: float, voxel_size: float | None = None,
                 epsilon: float | None = None):
        gt_points = np.array(gt_points, dtype=float)
        if gt_points.ndim != 2 or gt_points.shape[1] != 3 or len(gt_points) == 0:
            raise ValueError(f"gt_points must have shape (n, 3) with n >= 1, got "
                             f"{gt_points.shape}")
        if not np.all(np.isfinite(gt_points)):
            raise ValueError("gt_points must be finite")
        lengths = {"spacing": spacing, "voxel_size": voxel_size, "epsilon": epsilon}
        for name, value in lengths.items():
            if value is not None and not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite length in metres, got "
                                 f"{value!r}")
        gt_points.setflags(write=False)
        self.gt_points = gt_points
        self.spacing = float(spacing)
        self.voxel_size = float(voxel_size) if voxel_size is not None else self.spacing
        self.epsilon = float(epsilon) if epsilon is not None else EPSILON_PER_SPACING * spacing
        # Only points near the GT's bounding box can cover anything.
        self._near_low = gt_points.min(axis=0) - self.epsilon
        self._near_high = gt_points.max(axis=0) + self.epsilon
        self.reset()

    @classmethod
    def from_ground_truth(cls, ground_truth: GroundTruth) -> CoverageTracker:
        """A tracker for a `GroundTruth`, P_cov at the GT's own voxel size."""
        return cls(ground_truth.points, ground_truth.spacing_m,
                   voxel_size=ground_truth.voxel_size_m)

    def reset(self) -> None:
        """Forget all acquisitions (a new episode)."""
        self._covered = np.zeros(len(self.gt_points), dtype=bool)
        self._voxel_keys = np.zeros(0, dtype=np.int64)
        self._voxel_sums = np.zeros((0, 3))
        self._voxel_counts = np.zeros(0, dtype=np.int64)
        self._previous_accumulated = np.zeros((0, 3))
        self.steps: list[CoverageStep] = []
        self.poses: list[Pose | None] = []
        self.clouds: list[np.ndarray] = []

    def update(self, points: np.ndarray, sensor_pose: Pose | None = None) -> CoverageStep:
        """Add one acquired cloud (mesh frame) and the sensor pose it was taken from.

        Raises:
            ValueError: If points is not a finite (n, 3) array.
        """
        points = np.asarray(points, dtype=float)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {points.shape}")
        if not np.all(np.isfinite(points)):
            raise ValueError("points must be finite")
        before = self.coverage
        newly = self._match(points)
        self._covered[newly] = True
        self._previous_accumulated = self.accumulated_cloud
        self._accumulate(points)
        self.poses.append(sensor_pose)
        self.clouds.append(points)
        coverage = self.coverage
        step = CoverageStep(step=len(self.steps) + 1, coverage=coverage, delta=coverage - before,
                            remaining_before=1.0 - before, remaining=1.0 - coverage,
                            newly_covered=len(newly), points=len(points))
        self.steps.append(step)
        return step

    def match(self, points: np.ndarray) -> np.ndarray:
        """Which GT points one cloud (mesh frame) covers on its own; the state is unchanged."""
        covered = np.zeros(len(self.gt_points), dtype=bool)
        covered[self._match(points, np.arange(len(self.gt_points)))] = True
        return covered

    def _match(self, points: np.ndarray, candidates: np.ndarray | None = None) -> np.ndarray:
        """Indices of the candidate GT points (the uncovered ones by default) within ε of some
        point."""
        if candidates is None:
            candidates = np.flatnonzero(~self._covered)
        if len(points) == 0 or len(candidates) == 0:
            return np.zeros(0, dtype=np.int64)
        points = points[np.all((points >= self._near_low) & (points <= self._near_high), axis=1)]
        if len(points) == 0:
            return np.zeros(0, dtype=np.int64)
        tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
        distance, _ = tree.query(self.gt_points[candidates], distance_upper_bound=self.epsilon)
        return candidates[distance <= self.epsilon]

    def _accumulate(self, points: np.ndarray) -> None:
        """Merge the points into the voxel sums behind P_cov."""
        if len(points) == 0:
            return
        keys = np.floor(points / self.voxel_size).astype(np.int64) + _KEY_OFFSET
        packed = (keys[:, 0] << (2 * _KEY_BITS)) | (keys[:, 1] << _KEY_BITS) | keys[:, 2]
        merged, voxel = np.unique(np.concatenate([self._voxel_keys, packed]),
                                  return_inverse=True)
        old = len(self._voxel_keys)
        sums = np.zeros((len(merged), 3))
        for axis in range(3):
            sums[:, axis] = np.bincount(voxel[old:], weights=points[:, axis],
                                        minlength=len(merged))
        sums[voxel[:old]] += self._voxel_sums
        counts = np.bincount(voxel[old:], minlength=len(merged))
        counts[voxel[:old]] += self._voxel_counts
        self._voxel_keys, self._voxel_sums, self._voxel_counts = merged, sums, counts

    @property
    def covered(self) -> np.ndarray:
        """Which GT points are covered (a copy)."""
        return self._covered.copy()

    @property
    def covered_count(self) -> int:
        return int(self._covered.sum())

    @property
    def coverage(self) -> float:
        """COV_t, in [0, 1]."""
        return self.covered_count / len(self.gt_points)

    @property
    def remaining(self) -> float:
        """COV_rem,t = 1 - COV_t."""
        return 1.0 - self.coverage

    @property
    def inverted_cloud(self) -> np.ndarray:
        """P_inv: the GT points not covered yet."""
        return self.gt_points[~self._covered]

    @property
    def accumulated_cloud(self) -> np.ndarray:
        """P_cov,t: all points so far, one centroid per voxel."""
        return self._voxel_sums / self._voxel_counts[:, None]

    @property
    def previous_accumulated_cloud(self) -> np.ndarray:
        """P_cov,t-1: the accumulated cloud before the latest acquisition."""
        return self._previous_accumulated
