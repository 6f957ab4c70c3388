"""Seeded, parametric families of mechanical parts besides starter motors (issue 20).

Each family is one module with a `PartFamily` subclass that registers itself in `FAMILIES`
(`@register_family`), which declares them and imports one on the first lookup of its name. An
instance
is fixed by (family, seed): `FAMILIES[name].instance(seed)`.
"""

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
