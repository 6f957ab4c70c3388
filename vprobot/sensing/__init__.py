"""How a sensor turns what its rays reach into points: the sensing models
(docs/sensor.md#sensing), one module each registering itself in `SENSING_MODELS` (`models`).

A low layer: the config checks `sensor.sensing` against the registry, and the sensor
(`vprobot.cell.sensor`) measures through the model's methods. `ideal` keeps every hit, exactly;
`structured_light` models a camera and a projector a baseline apart.

The package's names are imported on first use (PEP 562): `--help` lists the models through
`SENSING_MODELS` without importing NumPy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vprobot.sensing.base import CameraHits, SensingModel, frame_generator
    from vprobot.sensing.ideal import IDEAL, IdealSensing
    from vprobot.sensing.models import SENSING_MODELS, check_sensing
    from vprobot.sensing.structured_light import StructuredLight

_MODULES = {"SENSING_MODELS": "models", "CameraHits": "base", "SensingModel": "base",
            "check_sensing": "models", "frame_generator": "base", "IDEAL": "ideal",
            "IdealSensing": "ideal", "StructuredLight": "structured_light"}

__all__ = ["IDEAL", "SENSING_MODELS", "CameraHits", "IdealSensing", "SensingModel",
           "StructuredLight", "check_sensing", "frame_generator"]


def __getattr__(name: str) -> Any:
    if name not in _MODULES:
        raise AttributeError(f"module 'vprobot.sensing' has no attribute {name!r}")
    return getattr(importlib.import_module(f"vprobot.sensing.{_MODULES[name]}"), name)
