"""Objects made on demand from a seed: part-family instances and extra starter motors.

An episode spec names such an object `generated/<family>_<SSSS>.stl` (instance SSSS of a part
family, `vprobot.families`) or `generated/motor_<seed>_<iii>.stl` (motor iii that the motor
generator draws with `seed`; the bundled training motors are seed 0, the test motors seed 1).
The file is written on first use into `cache_root()/objects/v<VERSION>` (atomically) and is the
same byte for byte on every machine, so lists of thousands of instances cost nothing until an
episode draws one, and the ground truth of each is then built once and cached as for any mesh.
A cached file is only checked to be a whole STL (one cut short is built again): a change to a
family or the motor generator must bump `VERSION` (a test pins the bytes of one instance of
each, and fails until it is bumped). A cache that cannot be written draws a warning, and the
objects are then kept in a temporary folder for the process.
"""

from __future__ import annotations

import re
import tempfile
import warnings
from pathlib import Path

from vprobot.files.atomic import atomic_output
from vprobot.files.paths import CACHE_ENV_VAR, cache_root

VERSION = 1
"""Version of what the generators make; part of the cache folder."""
PREFIX = "generated/"
_FAMILY = re.compile(r"^generated/(?P<family>[a-z_]+?)_(?P<seed>\d{4,})\.stl$")
_MOTOR = re.compile(r"^generated/motor_(?P<seed>\d+)_(?P<index>\d{3,})\.stl$")

_UNCACHED: dict[Path, tempfile.TemporaryDirectory[str]] = {}
"""Cache folders this process could not write, with the temporary folder (removed when the
process ends) that holds their objects instead."""


def family_object(family: str, seed: int) -> str:
    """The name of instance `seed` of a part family."""
    # Imported here: the generators need trimesh; the split and the config read names here.
    from vprobot.families import instance_stem

    return f"{PREFIX}{instance_stem(family, seed)}.stl"


def motor_object(seed: int, index: int) -> str:
    """The name of motor `index` drawn by the motor generator with `seed`."""
    # Imported here: the generators need trimesh; the split and the config read names here.
    from vprobot.motors import motor_stem

    return f"{PREFIX}{motor_stem(seed, index)}.stl"


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
    """The file of a generated object, written first if it is not there yet or is not whole.

    A cached file that is not a complete binary STL (cut short by a full disk, say) is built
    again and replaced. When the cache cannot be written, a RuntimeWarning says so once per
    process and folder, and the object goes into a temporary folder of this process instead.

    Raises:
        ValueError: If the name is not a generated object's, or names an unknown family.
    """
    folder, file = cache_root() / "objects" / f"v{VERSION}", name.removeprefix(PREFIX)
    for candidate in (folder, _uncached_folder(folder)):
        if candidate is not None and _complete(candidate / file):
            return candidate / file
    data = _build(name)
    try:
        return _store(folder / file, data)
    except OSError as error:
        if folder not in _UNCACHED:
            _UNCACHED[folder] = tempfile.TemporaryDirectory(prefix="vprobot-objects-")
            warnings.warn(f"cannot write the generated-objects cache {folder} ({error}); this "
                          f"run keeps them in {_UNCACHED[folder].name} and later runs build them "
                          f"again; set ${CACHE_ENV_VAR} to a writable directory",
                          RuntimeWarning, stacklevel=2)
        return _store(Path(_UNCACHED[folder].name) / file, data)


def _uncached_folder(folder: Path) -> Path | None:
    return Path(_UNCACHED[folder].name) if folder in _UNCACHED else None


def _complete(path: Path) -> bool:
    """Whether `path` is a whole binary STL (the generators write nothing else)."""
    # Imported here: mesh loading needs trimesh; the split and the config read names here.
    from vprobot.parts.loading import is_binary_stl

    return path.is_file() and is_binary_stl(path.read_bytes())


def _build(name: str) -> bytes:
    """The binary STL of a generated object.

    Raises:
        ValueError: If the name is not a generated object's, or names an unknown family.
    """
    # Imported here: the generators need trimesh; the split and the config read names here.
    from trimesh.exchange.stl import export_stl

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
    return export_stl(mesh)


def _store(path: Path, data: bytes) -> Path:
    """Write `data` to `path` atomically, its folder created."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as temporary:
        temporary.write_bytes(data)
    return path
