"""Objects made on demand from a seed: part-family instances and extra starter motors.

An episode spec names such an object `generated/<family>_<SSSS>.stl` (instance SSSS of a part
family, `vprobot.families`) or `generated/motor_<seed>_<iii>.stl` (motor iii that the motor
generator draws with `seed`; the bundled training motors are seed 0, the test motors seed 1).
The file is written on first use into `cache_root()/objects/v<VERSION>` (atomically) and is the
same byte for byte on every machine, so lists of thousands of instances cost nothing until an
episode draws one, and the ground truth of each is then built once and cached as for any mesh.
A cached file is never checked again: a change to a family or the motor generator must bump
`VERSION` (a test pins the bytes of one instance of each, and fails until it is bumped).
"""

from __future__ import annotations

import re
from pathlib import Path

from vprobot.files import atomic_output
from vprobot.paths import cache_root

VERSION = 1
"""Version of what the generators make; part of the cache folder."""
PREFIX = "generated/"
_FAMILY = re.compile(r"^generated/(?P<family>[a-z_]+?)_(?P<seed>\d{4,})\.stl$")
_MOTOR = re.compile(r"^generated/motor_(?P<seed>\d+)_(?P<index>\d{3,})\.stl$")


def family_object(family: str, seed: int) -> str:
    """The name of instance `seed` of a part family."""
    # Imported here: the generators need trimesh; the split and the config read names here.
    from vprobot.families import instance_stem

    return f"{PREFIX}{instance_stem(family, seed)}.stl"


def motor_object(seed: int, index: int) -> str:
    """The name of motor `index` drawn by the motor generator with `seed`."""
    return f"{PREFIX}motor_{seed}_{index:03d}.stl"


def is_generated(name: str) -> bool:
    return str(name).startswith(PREFIX)


def family_of(name: str) -> str | None:
    """The part family a generated name belongs to; `motor` for a generated motor; None for
    any other name."""
    if _MOTOR.match(name):
        return "motor"
    match = _FAMILY.match(name)
    return match["family"] if match else None


def generated_path(name: str) -> Path:
    """The file of a generated object, written first if it is not there yet.

    Raises:
        ValueError: If the name is not a generated object's, or names an unknown family.
    """
    path = cache_root() / "objects" / f"v{VERSION}" / name.removeprefix(PREFIX)
    if path.is_file():
        return path
    if (motor := _MOTOR.match(name)) is not None:
        # Imported here: the generators need trimesh; the split and the config read names here.
        from vprobot.motors import build_motor, motor_rng, sample_parameters

        mesh = build_motor(sample_parameters(motor_rng(int(motor["seed"]),
                                                       int(motor["index"]))))
    elif (part := _FAMILY.match(name)) is not None:
        # Imported here: the generators need trimesh; the split and the config read names here.
        from vprobot.families import FAMILIES

        mesh = FAMILIES[part["family"]].instance(int(part["seed"])).mesh
    else:
        raise ValueError(f"{name!r} is not a generated object: expected "
                         f"generated/<family>_<SSSS>.stl or generated/motor_<seed>_<iii>.stl")
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as temporary:
        temporary.write_bytes(mesh.export(file_type="stl"))
    return path
