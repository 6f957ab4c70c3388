"""The registry of sensing models (`SENSING_MODELS`) and the check of a sensor against it, apart
from what a model is (`base`) so that listing their names imports neither a model nor NumPy
(`--help`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vprobot.extensions.registry import Bundled, Registry

if TYPE_CHECKING:
    from vprobot.sensing.base import SensingModel, SensorSettings

SENSING_MODELS: Registry[type[SensingModel]] = Registry("sensing model", bundled={
    "ideal": Bundled("vprobot.sensing.ideal:IdealSensing"),
    "structured_light": Bundled("vprobot.sensing.structured_light:StructuredLight"),
})
"""Every sensing model by name (`sensor.sensing`, `--sensing`), one module each here."""


def check_sensing(sensor: SensorSettings) -> None:
    """Raise ConfigError unless `sensor.sensing` names a sensing model that the sensor has what
    it needs for."""
    # Here: the schema imports PyYAML, which listing the names (`--help`) does not need.
    from vprobot.files.schema import ConfigError

    if sensor.sensing not in SENSING_MODELS:
        raise ConfigError(f"sensor.sensing must be one of {list(SENSING_MODELS)}, got "
                          f"{sensor.sensing!r}")
    SENSING_MODELS[sensor.sensing].of_sensor(sensor)
