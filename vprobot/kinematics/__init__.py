"""Robot kinematics of the inspection cell: FK, IK, collisions, joint-space paths, travel."""

from vprobot.kinematics.arm import (
    FAILURE_REASONS,
    OUT_OF_REACH,
    UNSOLVED,
    ReachResult,
    RobotArm,
)
from vprobot.kinematics.ik import IKAttempt, IKSolver, SensorTarget
from vprobot.kinematics.travel import TRAVEL_COSTS, TravelCost

__all__ = [
    "FAILURE_REASONS",
    "OUT_OF_REACH",
    "TRAVEL_COSTS",
    "UNSOLVED",
    "IKAttempt",
    "IKSolver",
    "ReachResult",
    "RobotArm",
    "SensorTarget",
    "TravelCost",
]
