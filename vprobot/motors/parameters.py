"""The 28 parameters of a synthetic starter motor, their allowed ranges and relations.

Every parameter has one rule that gives its allowed range from the parameters before it, so the
same table drives both sampling and validation and the two can never disagree. Lengths are in
metres. Positions along the motor axis (x) are measured from the rear face of the flange, where
the main housing ends and the drive end begins; the solenoid sits on the +z side.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

# The core (end cap + housing + flange + nose) is kept in this band; pinion and rear extras add
# 0.016-0.045 m, which puts the overall length inside the 0.15-0.30 m of real starter motors.
CORE_LENGTH_RANGE_M = (0.14, 0.25)

# Relative tolerance of the range checks, so values that went through JSON still validate.
_TOL = 1e-9

_Bounds = Callable[[Mapping[str, float]], tuple[float, float]]


@dataclass(frozen=True)
class _Rule:
    bounds: _Bounds
    description: str
    integer: bool = False


def _core_length_without_nose(p: Mapping[str, float]) -> float:
    return p["end_cap_length_m"] + p["housing_length_m"] + p["flange_thickness_m"]


# Insertion order is the sampling order: each rule only reads parameters listed above it.
_RULES: dict[str, _Rule] = {
    # Main housing (yoke).
    "housing_radius_m": _Rule(lambda p: (0.032, 0.048), "0.032 .. 0.048 m"),
    "housing_length_m": _Rule(lambda p: (0.07, 0.13), "0.07 .. 0.13 m"),
    # End cap and the through-bolts that clamp it to the drive end.
    "end_cap_length_m": _Rule(lambda p: (0.012, 0.035), "0.012 .. 0.035 m"),
    "bolt_count": _Rule(lambda p: (2, 4), "2 .. 4", integer=True),
    "bolt_radius_m": _Rule(lambda p: (0.0025, 0.004), "0.0025 .. 0.004 m"),
    # The bolts run along the housing surface; a cap narrower than this would leave them floating.
    "end_cap_radius_m": _Rule(
        lambda p: (p["housing_radius_m"] - 0.5 * p["bolt_radius_m"], 1.08 * p["housing_radius_m"]),
        "housing_radius_m - 0.5 * bolt_radius_m .. 1.08 * housing_radius_m",
    ),
    "bolt_length_m": _Rule(
        lambda p: (
            p["housing_length_m"] + p["end_cap_length_m"] + 0.002,
            p["housing_length_m"] + p["end_cap_length_m"] + 0.012,
        ),
        "housing_length_m + end_cap_length_m + 0.002 .. + 0.012 m (bolt heads stick out)",
    ),
    # Brush-holder cover on the rear face of the end cap; its half-diagonal stays on the cap.
    "brush_holder_width_m": _Rule(
        lambda p: (0.6 * p["end_cap_radius_m"], 1.2 * p["end_cap_radius_m"]),
        "0.6 .. 1.2 * end_cap_radius_m",
    ),
    "brush_holder_height_m": _Rule(
        lambda p: (0.4 * p["end_cap_radius_m"], 1.0 * p["end_cap_radius_m"]),
        "0.4 .. 1.0 * end_cap_radius_m",
    ),
    "brush_holder_depth_m": _Rule(lambda p: (0.004, 0.015), "0.004 .. 0.015 m"),
    # Mounting flange with its ears and holes.
    "flange_thickness_m": _Rule(lambda p: (0.008, 0.016), "0.008 .. 0.016 m"),
    "mounting_hole_count": _Rule(lambda p: (2, 3), "2 .. 3", integer=True),
    "mounting_hole_radius_m": _Rule(lambda p: (0.004, 0.0065), "0.004 .. 0.0065 m"),
    # Holes must clear the housing and the bolts running along it.
    "mounting_hole_pitch_radius_m": _Rule(
        lambda p: (
            p["housing_radius_m"] + 1.3 * p["bolt_radius_m"] + p["mounting_hole_radius_m"] + 0.002,
            p["housing_radius_m"] + 1.3 * p["bolt_radius_m"] + p["mounting_hole_radius_m"] + 0.010,
        ),
        "housing_radius_m + 1.3 * bolt_radius_m + mounting_hole_radius_m + 0.002 .. + 0.010 m",
    ),
    # Holes must lie inside the flange ears with a wall of 3-8 mm.
    "flange_radius_m": _Rule(
        lambda p: (
            p["mounting_hole_pitch_radius_m"] + p["mounting_hole_radius_m"] + 0.003,
            p["mounting_hole_pitch_radius_m"] + p["mounting_hole_radius_m"] + 0.008,
        ),
        "mounting_hole_pitch_radius_m + mounting_hole_radius_m + 0.003 .. + 0.008 m",
    ),
    # Gear housing (nose), tapering towards the pinion.
    "nose_length_m": _Rule(
        lambda p: (
            max(0.03, CORE_LENGTH_RANGE_M[0] - _core_length_without_nose(p)),
            min(0.07, CORE_LENGTH_RANGE_M[1] - _core_length_without_nose(p)),
        ),
        "0.03 .. 0.07 m and end_cap_length_m + housing_length_m + flange_thickness_m"
        f" + nose_length_m in {CORE_LENGTH_RANGE_M[0]} .. {CORE_LENGTH_RANGE_M[1]} m",
    ),
    "nose_base_radius_m": _Rule(
        lambda p: (0.7 * p["housing_radius_m"], 0.95 * p["housing_radius_m"]),
        "0.7 .. 0.95 * housing_radius_m",
    ),
    "nose_tip_radius_m": _Rule(
        lambda p: (0.6 * p["nose_base_radius_m"], 0.9 * p["nose_base_radius_m"]),
        "0.6 .. 0.9 * nose_base_radius_m",
    ),
    # Pinion (outer radius of the teeth) must be smaller than the nose it leaves from.
    "pinion_radius_m": _Rule(
        lambda p: (
            max(0.010, 0.45 * p["nose_tip_radius_m"]),
            min(0.022, 0.8 * p["nose_tip_radius_m"]),
        ),
        "max(0.010 m, 0.45 * nose_tip_radius_m) .. min(0.022 m, 0.8 * nose_tip_radius_m)",
    ),
    "pinion_length_m": _Rule(lambda p: (0.012, 0.03), "0.012 .. 0.03 m"),
    "pinion_tooth_count": _Rule(lambda p: (9, 13), "9 .. 13", integer=True),
    # Solenoid on top of the housing, parallel to the axis.
    "solenoid_radius_m": _Rule(
        lambda p: (0.018, min(0.032, 0.75 * p["housing_radius_m"])),
        "0.018 .. min(0.032 m, 0.75 * housing_radius_m)",
    ),
    "solenoid_length_m": _Rule(
        lambda p: (0.055, min(0.11, 0.9 * p["housing_length_m"])),
        "0.055 .. min(0.11 m, 0.9 * housing_length_m)",
    ),
    # Centre along the axis: the rear half rides on the housing, the terminals stay in front of
    # the housing's rear end and the front end stays behind the middle of the nose.
    "solenoid_offset_m": _Rule(
        lambda p: (
            -p["housing_length_m"] + 0.5 * p["solenoid_length_m"] + 0.02,
            min(
                0.0,
                p["flange_thickness_m"] + 0.6 * p["nose_length_m"] - 0.5 * p["solenoid_length_m"],
            ),
        ),
        "-housing_length_m + solenoid_length_m / 2 + 0.02 .. min(0, flange_thickness_m"
        " + 0.6 * nose_length_m - solenoid_length_m / 2)",
    ),
    # Height of the solenoid axis above the motor axis: sunk 25-65 % of its radius into the housing.
    "solenoid_height_m": _Rule(
        lambda p: (
            p["housing_radius_m"] + 0.35 * p["solenoid_radius_m"],
            p["housing_radius_m"] + 0.75 * p["solenoid_radius_m"],
        ),
        "housing_radius_m + 0.35 .. 0.75 * solenoid_radius_m",
    ),
    # Studs on the solenoid's rear cap.
    "terminal_count": _Rule(lambda p: (2, 3), "2 .. 3", integer=True),
    "terminal_radius_m": _Rule(
        lambda p: (0.002, min(0.005, 0.15 * p["solenoid_radius_m"])),
        "0.002 .. min(0.005 m, 0.15 * solenoid_radius_m)",
    ),
    "terminal_length_m": _Rule(lambda p: (0.006, 0.02), "0.006 .. 0.02 m"),
}


@dataclass(frozen=True)
class MotorParameters:
    """Shape of one starter motor; see the module docstring for the frame.

    Raises:
        ValueError: if a parameter lies outside the range allowed by its rule.
    """

    housing_radius_m: float
    housing_length_m: float
    end_cap_length_m: float
    bolt_count: int
    bolt_radius_m: float
    end_cap_radius_m: float
    bolt_length_m: float
    brush_holder_width_m: float
    brush_holder_height_m: float
    brush_holder_depth_m: float
    flange_thickness_m: float
    mounting_hole_count: int
    mounting_hole_radius_m: float
    mounting_hole_pitch_radius_m: float
    flange_radius_m: float
    nose_length_m: float
    nose_base_radius_m: float
    nose_tip_radius_m: float
    pinion_radius_m: float
    pinion_length_m: float
    pinion_tooth_count: int
    solenoid_radius_m: float
    solenoid_length_m: float
    solenoid_offset_m: float
    solenoid_height_m: float
    terminal_count: int
    terminal_radius_m: float
    terminal_length_m: float

    def __post_init__(self) -> None:
        values = vars(self)
        for name, rule in _RULES.items():
            value = values[name]
            if rule.integer:
                if isinstance(value, bool) or not isinstance(value, int | np.integer):
                    raise ValueError(f"{name}={value!r} must be an integer in {rule.description}")
            elif not isinstance(value, int | float | np.number) or not math.isfinite(value):
                raise ValueError(f"{name}={value!r} must be a finite number in {rule.description}")
            lo, hi = rule.bounds(values)
            tol = _TOL * max(1.0, abs(lo), abs(hi))
            if not lo - tol <= value <= hi + tol:
                raise ValueError(
                    f"{name}={value:.6g} is outside the allowed range [{lo:.6g}, {hi:.6g}]"
                    f" ({rule.description})"
                )

    @property
    def total_length_m(self) -> float:
        """Overall length along the axis, from the rearmost part to the pinion tip."""
        rear = max(
            self.housing_length_m + self.end_cap_length_m + self.brush_holder_depth_m,
            self.bolt_length_m,
        )
        return rear + self.flange_thickness_m + self.nose_length_m + self.pinion_length_m


def sample_parameters(rng: np.random.Generator) -> MotorParameters:
    """Draw one realistic motor, uniformly within each parameter's allowed range.

    Args:
        rng: Source of randomness; the result depends only on its state.

    Returns:
        Parameters that satisfy every range and relation.
    """
    # Keyword arguments of MotorParameters: ints for the integer rules, floats otherwise.
    values: dict[str, Any] = {}
    for name, rule in _RULES.items():
        lo, hi = rule.bounds(values)
        values[name] = (int(rng.integers(int(lo), int(hi) + 1)) if rule.integer
                        else float(rng.uniform(lo, hi)))
    return MotorParameters(**values)
