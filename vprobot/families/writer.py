"""Writing instances of a family to disk: `NAME_SSSS.stl` (binary, metres) + `NAME_SSSS.json`."""

from __future__ import annotations

import json
from pathlib import Path

import trimesh
from tqdm import tqdm

from vprobot.families.base import FAMILIES
from vprobot.files.atomic import atomic_output, batch_folder, write_text


def instance_stem(name: str, seed: int) -> str:
    """File name of instance `seed` of family `name`, without suffix."""
    return f"{name}_{seed:04d}"


def generate_instances(name: str, count: int, seed: int, out_dir: Path,
                       progress: bool = True) -> list[Path]:
    """Write instances seed, seed + 1, ..., seed + count - 1 of family `name` into `out_dir`.

    Each file depends only on (name, its seed), so sets of different sizes or starts agree
    where they overlap.

    Args:
        name: Family name.
        count: Number of instances, at least 1.
        seed: Seed of the first instance, at least 0.
        out_dir: Folder to write to; created if missing.
        progress: Show a progress bar.

    Returns:
        The STL paths, by seed.

    Raises:
        ValueError: If the family is unknown, count < 1 or seed < 0.
    """
    part = FAMILIES[name]
    out_dir = batch_folder(out_dir, count, seed)
    paths = []
    for s in tqdm(range(seed, seed + count), desc=name, unit="part", disable=not progress):
        instance = part.instance(s)
        stem = out_dir / instance_stem(name, s)
        with atomic_output(stem.with_suffix(".stl")) as temporary:
            temporary.write_bytes(trimesh.exchange.stl.export_stl(instance.mesh))
        meta = {"family": name, "seed": s, "parameters": instance.parameters}
        write_text(stem.with_suffix(".json"), json.dumps(meta, indent=2) + "\n")
        paths.append(stem.with_suffix(".stl"))
    return paths
