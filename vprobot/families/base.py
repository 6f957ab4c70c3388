"""What a part family is: named parameters with ranges, and a builder of closed meshes.

An instance is fixed by (family, seed): its parameters are drawn uniformly within their ranges
from a generator seeded by the seed and the family's name, so instances of different families
never share a random stream and any number of them can be drawn in any order.
"""

from __future__ import annotations

import abc
import hashlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar, TypeVar

import numpy as np
import trimesh

from vprobot.extensions.registry import Bundled, Registry

Values = Mapping[str, float]
"""Parameter values of one instance by name (integer parameters hold ints)."""


@dataclass(frozen=True)
class Parameter:
    """One shape parameter, drawn uniformly from [low, high].

    Attributes:
        name: Identifier; `_m` marks metres, `_count` an integer, `_ratio` a fraction of
            another size named in the description.
        low: Smallest value.
        high: Largest value.
        description: What it sets, a few words.
        integer: Drawn as an integer in low .. high, both included.
    """

    name: str
    low: float
    high: float
    description: str
    integer: bool = False

    def range_text(self) -> str:
        """The range as `vprobot objects list` shows it."""
        unit = " m" if self.name.endswith("_m") else ""
        if self.integer:
            return f"{int(self.low)} .. {int(self.high)}"
        return f"{self.low:g} .. {self.high:g}{unit}"


@dataclass(frozen=True)
class Instance:
    """One generated part.

    Attributes:
        family: Family name.
        seed: Seed within the family.
        parameters: The drawn parameter values.
        mesh: Closed mesh in metres, its bounding box centred at the origin.
    """

    family: str
    seed: int
    parameters: dict[str, float]
    mesh: trimesh.Trimesh


def family_rng(name: str, seed: int) -> np.random.Generator:
    """The random generator of instance `seed` of family `name`, the same in every process
    (Python's `hash` of a string is salted per process, a digest is not)."""
    key = int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "little")
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(key,)))


class PartFamily(abc.ABC):
    """A kind of mechanical part; subclasses set the class attributes and `build`."""

    name: ClassVar[str]
    description: ClassVar[str]
    """One line for `vprobot objects list`."""
    parameters: ClassVar[tuple[Parameter, ...]]

    def sample(self, rng: np.random.Generator) -> dict[str, float]:
        """Draw every parameter uniformly within its range, in declaration order."""
        return {
            p.name: int(rng.integers(int(p.low), int(p.high) + 1)) if p.integer
            else float(rng.uniform(p.low, p.high))
            for p in self.parameters
        }

    @abc.abstractmethod
    def build(self, values: Values) -> trimesh.Trimesh:
        """The part's mesh for these parameter values, in metres, anywhere in space."""

    def instance(self, seed: int) -> Instance:
        """Instance `seed` of this family.

        Raises:
            ValueError: If seed < 0.
            RuntimeError: If the build did not give one closed solid (a bug of the family).
        """
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        values = self.sample(family_rng(self.name, seed))
        mesh = self.build(values)
        if not mesh.is_watertight or mesh.volume <= 0 or mesh.body_count != 1:
            raise RuntimeError(f"{self.name} seed {seed} is not one closed solid: {values}")
        mesh.apply_translation(-mesh.bounds.mean(axis=0))
        return Instance(self.name, seed, values, mesh)


FAMILIES: Registry[PartFamily] = Registry("part family", bundled={
    "bracket": Bundled("vprobot.families.bracket:Bracket"),
    "flange": Bundled("vprobot.families.flange:Flange"),
    "housing": Bundled("vprobot.families.housing:Housing"),
    "lever": Bundled("vprobot.families.lever:Lever"),
    "manifold": Bundled("vprobot.families.manifold:Manifold"),
    "pipe_fitting": Bundled("vprobot.families.pipe_fitting:PipeFitting"),
    "procedural": Bundled("vprobot.families.procedural:Procedural"),
    "pulley": Bundled("vprobot.families.pulley:Pulley"),
    "spur_gear": Bundled("vprobot.families.spur_gear:SpurGear"),
    "stepped_shaft": Bundled("vprobot.families.stepped_shaft:SteppedShaft"),
    "valve_body": Bundled("vprobot.families.valve_body:ValveBody"),
})
"""Every family by name (one instance each), in name order: the bundled ones (declared here,
each a module of this package; tests/test_registries.py checks this index against the modules)
and those of plugins."""

F = TypeVar("F", bound=type[PartFamily])


def register_family(cls: F) -> F:
    """Class decorator: registers an instance of a family under its `name`.

    Raises:
        ValueError: If a family of that name is already registered.
        TypeError: If the family is abstract.
    """
    FAMILIES.check_concrete(cls.name, cls)
    FAMILIES.register(cls.name, cls())
    return cls
