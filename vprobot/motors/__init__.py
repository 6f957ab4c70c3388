"""Seeded, parametric synthetic starter motors (docs/episodes-and-carriers.md#starter-motors)."""

from vprobot.motors.generator import (
    BUNDLED_SETS,
    build_motor,
    generate_bundled_motors,
    generate_motors,
    motor_rng,
    motor_stem,
)
from vprobot.motors.parameters import MotorParameters, sample_parameters

__all__ = ["BUNDLED_SETS", "MotorParameters", "build_motor", "generate_bundled_motors",
           "generate_motors", "motor_rng", "motor_stem", "sample_parameters"]
