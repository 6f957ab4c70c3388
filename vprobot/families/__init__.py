"""Seeded, parametric families of mechanical parts besides starter motors (issue 20).

Each family is one module with a `PartFamily` subclass; registering it here is one line.
An instance is fixed by (family, seed): `FAMILIES[name].instance(seed)`.
"""

from vprobot.families.base import Instance, Parameter, PartFamily, family_rng
from vprobot.families.bracket import Bracket
from vprobot.families.flange import Flange
from vprobot.families.housing import Housing
from vprobot.families.lever import Lever
from vprobot.families.pipe_fitting import PipeFitting
from vprobot.families.pulley import Pulley
from vprobot.families.spur_gear import SpurGear
from vprobot.families.stepped_shaft import SteppedShaft
from vprobot.families.valve_body import ValveBody
from vprobot.families.writer import family, generate_instances, instance_stem

FAMILIES: dict[str, PartFamily] = {
    f.name: f
    for f in (
        Bracket(),
        Flange(),
        Housing(),
        Lever(),
        PipeFitting(),
        Pulley(),
        SpurGear(),
        SteppedShaft(),
        ValveBody(),
    )
}
"""Every family by name, in alphabetical order."""

__all__ = [
    "FAMILIES",
    "Instance",
    "Parameter",
    "PartFamily",
    "family",
    "family_rng",
    "generate_instances",
    "instance_stem",
]
