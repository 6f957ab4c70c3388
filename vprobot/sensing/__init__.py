"""How a sensor turns what its rays reach into points: the sensing models
(docs/sensor.md#sensing), one module each registering itself in `SENSING_MODELS` (`base`).

A low layer: the config checks `sensor.sensing` against the registry, and the sensor
(`vprobot.cell.sensor`) measures through the model's methods. `ideal` keeps every hit, exactly;
`structured_light` models a camera and a projector a baseline apart.
"""

from vprobot.sensing.base import (
    SENSING_MODELS,
    CameraHits,
    SensingModel,
    check_sensing,
    frame_generator,
)
from vprobot.sensing.ideal import IDEAL, IdealSensing
from vprobot.sensing.structured_light import StructuredLight

__all__ = ["IDEAL", "SENSING_MODELS", "CameraHits", "IdealSensing", "SensingModel",
           "StructuredLight", "check_sensing", "frame_generator"]
