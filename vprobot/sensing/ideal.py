"""The `ideal` sensing model: every object point a camera ray meets first within range,
measured exactly (docs/sensor.md#sensing)."""

from __future__ import annotations

import dataclasses
from typing import Any

from vprobot.sensing.base import SensingModel, SensorSettings
from vprobot.sensing.models import SENSING_MODELS


@SENSING_MODELS.register_named
@dataclasses.dataclass(frozen=True)
class IdealSensing(SensingModel):
    """Every point a camera ray reaches first within range, measured exactly."""

    name = "ideal"

    @classmethod
    def of_sensor(cls, sensor: SensorSettings) -> SensingModel:
        return IDEAL

    def ground_truth_key(self) -> tuple[Any, ...]:
        # Nothing: the ideal GTs keep the keys they had before there were sensing models.
        return ()


IDEAL = IdealSensing()
