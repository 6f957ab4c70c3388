"""Seeded, parametric families of mechanical parts besides starter motors (issue 20).

Each family is one module with a `PartFamily` subclass that registers itself in `FAMILIES`
(`@register_family`); the bundled ones are imported here, in alphabetical order. An instance is
fixed by (family, seed): `FAMILIES[name].instance(seed)`.
"""

# The bundled families register themselves when imported.
from vprobot.families import (  # noqa: F401
    bracket,
    flange,
    housing,
    lever,
    pipe_fitting,
    procedural,
    pulley,
    spur_gear,
    stepped_shaft,
    valve_body,
)
from vprobot.families.base import (
    FAMILIES,
    Instance,
    Parameter,
    PartFamily,
    family_rng,
    register_family,
)
from vprobot.families.writer import generate_instances, instance_stem

__all__ = [
    "FAMILIES",
    "Instance",
    "Parameter",
    "PartFamily",
    "family_rng",
    "generate_instances",
    "instance_stem",
    "register_family",
]
