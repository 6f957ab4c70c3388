"""Travel costs between consecutive views (docs/states-actions-rewards.md#travel-costs)."""

from __future__ import annotations

import dataclasses

import numpy as np

TRAVEL_COSTS = ("joint_time", "joint_path", "cartesian", "paper", "cycle_time")


@dataclasses.dataclass(frozen=True)
class TravelCost:
    """All travel costs of one move.

    Attributes:
        joint_time: Synchronous point-to-point time, max_i |dq_i| / v_max_i (s).
        joint_path: Sum of absolute joint changes (rad).
        cartesian: Length of the path the sensor traces along the joint-space line (m).
        paper: The paper's approximation: great-circle arc about the object centre on the
            smaller sphere plus the radius difference (m).
        cycle_time: What the move adds to the cell's cycle time (s): its duration under the
            robot's velocity, acceleration and jerk limits (docs/motion.md), plus the
            acquisition at its end when it ends at a view.
    """

    joint_time: float = 0.0
    joint_path: float = 0.0
    cartesian: float = 0.0
    paper: float = 0.0
    cycle_time: float = 0.0

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)

    def __add__(self, other: TravelCost) -> TravelCost:
        # Spelled out: summed every env step, where dataclasses.asdict costs more than the rest.
        return TravelCost(self.joint_time + other.joint_time, self.joint_path + other.joint_path,
                          self.cartesian + other.cartesian, self.paper + other.paper,
                          self.cycle_time + other.cycle_time)


def joint_time(q_from: np.ndarray, q_to: np.ndarray, velocity_limits: np.ndarray) -> float:
    """Time of a synchronous joint move at the joints' velocity limits (s)."""
    return float(np.max(np.abs(q_to - q_from) / velocity_limits))


def joint_path_length(q_from: np.ndarray, q_to: np.ndarray) -> float:
    """Sum of the absolute joint changes (rad)."""
    return float(np.sum(np.abs(q_to - q_from)))


def polyline_length(points: np.ndarray) -> float:
    """Length of the polyline through `points` (n, 3)."""
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def paper_travel(position_from: np.ndarray, position_to: np.ndarray, center: np.ndarray) -> float:
    """The paper's travel approximation between two sensor positions around `center` (m).

    A great-circle arc on the smaller of the two spheres about `center` through the positions,
    between one position and the radial projection of the other, plus the radius difference:
    min(r_from, r_to) * angle + |r_to - r_from| (docs/states-actions-rewards.md#travel-costs). The
    paper draws the case
    r_from < r_to and computes the other "the other way around", so the cost is symmetric.
    """
    offset_from = np.asarray(position_from, dtype=float) - center
    offset_to = np.asarray(position_to, dtype=float) - center
    radius_from = float(np.linalg.norm(offset_from))
    radius_to = float(np.linalg.norm(offset_to))
    if radius_from < 1e-12 or radius_to < 1e-12:
        return abs(radius_to - radius_from)
    cosine = np.clip(np.dot(offset_from, offset_to) / (radius_from * radius_to), -1.0, 1.0)
    return float(min(radius_from, radius_to) * np.arccos(cosine) + abs(radius_to - radius_from))
