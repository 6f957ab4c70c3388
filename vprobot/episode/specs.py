"""Episode specs: everything random about an episode, drawn once from a seed and then fixed.

A spec names the part's mesh file, the object's rotation and the initial view, so that the env,
every planner and every agent can be run on exactly the same episodes
(docs/evaluation.md#episode-lists). `sample_episode` is the one sampler: the env draws from its
`np_random`, and `episode_list` draws a fixed list over given parts and seeds for
`vprobot evaluate`. The list format is versioned (`EPISODE_LIST_VERSION`); the bundled lists
(`BUNDLED_EPISODE_LISTS`) are `configs/episodes/test-v1.json` over the test motors and
`configs/episodes/shapes-v1.json` over the non-motor objects, and a test checks that the sampler
still reproduces them.
"""

from __future__ import annotations

import dataclasses
import json
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config, EnvConfig
from vprobot.episode.records import ViewRequest
from vprobot.files.atomic import write_text
from vprobot.files.paths import ASSETS_DIR, BUNDLED_EPISODE_LISTS, EPISODES_DIR, MOTORS_DIR
from vprobot.files.schema import Quat
from vprobot.geometry.poses import (
    matrix_to_quat,
    quat_to_matrix,
    rotation_about_x,
    rotation_about_y,
    rotation_about_z,
    spherical_position,
)
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics import SensorTarget
from vprobot.parts.generated import family_of, generated_path, is_generated
from vprobot.parts.splits import MOTORS, Split

EPISODE_LIST_VERSION = 1
BUNDLED_TEST_EPISODES = EPISODES_DIR / "test-v1.json"
"""The evaluation episodes over the bundled test motors: 3 seeds each (0, 1, 2)."""
BUNDLED_SHAPE_EPISODES = EPISODES_DIR / "shapes-v1.json"
"""The evaluation episodes over the bundled non-motor objects: 5 seeds each (0 to 4)."""


def bundled_episode_list(name: str) -> Path:
    """The file of a bundled episode list.

    Raises:
        ValueError: For an unknown name; the message lists the bundled ones.
    """
    if name not in BUNDLED_EPISODE_LISTS:
        raise ValueError(f"no bundled episode list {name!r}; bundled: "
                         f"{', '.join(BUNDLED_EPISODE_LISTS)}")
    return BUNDLED_EPISODE_LISTS[name]
RANDOM_INITIAL_VIEWS = 50
"""Initial view directions a `random` initial view draws; the first one reached is taken."""
RANDOM_INITIAL_MAX_POLAR_RAD = float(np.deg2rad(120.0))
FALLBACK_INITIAL_VIEWS = 24
"""Directions tried after an episode's own initial views, nearest the first of them first: a
robot that reaches none of those (the UR5 misses the paper's fixed view) starts from the nearest
view it reaches instead of failing the episode."""


def random_object_rotation(env: EnvConfig, rng: np.random.Generator) -> np.ndarray:
    """An episode's object rotation (docs/episodes-and-carriers.md#object-pose): about the
    vertical by U[-yaw, yaw], then tilted by U[-tilt, tilt] about the world x or y axis (equally
    likely), drawn in that order."""
    yaw = np.deg2rad(rng.uniform(-env.object_yaw_range_deg, env.object_yaw_range_deg))
    tilt = np.deg2rad(rng.uniform(-env.object_tilt_range_deg, env.object_tilt_range_deg))
    tilt_about = rotation_about_x if rng.integers(2) == 0 else rotation_about_y
    return tilt_about(tilt) @ rotation_about_z(yaw)


_BUNDLED_MESH_DIRS = (MOTORS_DIR, ASSETS_DIR)
"""Where a spec's relative mesh name is looked up, in this order (first match names it)."""


def part_name(path: str | Path) -> str:
    """How a spec names a mesh file: relative to the bundled motors folder when inside it
    (`test/motor_000.stl`), else relative to the bundled assets (`objects/bracket.stl`), so that
    a list of bundled meshes works from any folder; any other file keeps the path as given."""
    path = Path(path)
    for folder in _BUNDLED_MESH_DIRS:
        try:
            return path.resolve().relative_to(folder.resolve()).as_posix()
        except ValueError:
            continue
    return str(path)


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One episode, fixed.

    Attributes:
        part: The mesh file; `generated/...` names a generated object (`vprobot.parts.generated`),
            another relative name is looked up in the bundled motors folder
            (`test/motor_000.stl`), then in the bundled assets (`objects/bracket.stl`), then
            taken as a path.
        object_quaternion: Rotation (w, x, y, z) of the object about its centre.
        initial_views: Look-at directions (phi, theta) in rad at the working distance, tried in
            order: the first the carrier reaches is the initial view (one for `fixed`).
        seed: The seed the spec was drawn from; it also seeds random planners.
        scale: Factor from the file's units to metres.
    """

    part: str
    object_quaternion: tuple[float, float, float, float]
    initial_views: tuple[tuple[float, float], ...]
    seed: int
    scale: float = 1.0

    @property
    def rotation(self) -> np.ndarray:
        return quat_to_matrix(self.object_quaternion)

    @property
    def part_path(self) -> Path:
        """The mesh file: a generated object (made on first use), a bundled motor or object,
        else the path as given."""
        if is_generated(self.part):
            return generated_path(self.part)
        if not Path(self.part).is_absolute():
            for folder in _BUNDLED_MESH_DIRS:
                if (folder / self.part).is_file():
                    return folder / self.part
        return Path(self.part)

    def initial_requests(self, center: np.ndarray, distance: float) -> list[ViewRequest]:
        """The initial view candidates as look-at requests around `center`: the spec's own
        views, then the `FALLBACK_INITIAL_VIEWS` directions (of the `random` initial views'
        band) nearest its first view, nearest first."""
        own = np.array([spherical_position(phi, theta, 1.0) for phi, theta in self.initial_views])
        band = sphere_directions(4 * RANDOM_INITIAL_VIEWS, RANDOM_INITIAL_MAX_POLAR_RAD)
        nearest = np.argsort(-(band @ own[0]), kind="stable")[:FALLBACK_INITIAL_VIEWS]
        return [ViewRequest(SensorTarget.look_at(center + distance * direction, center))
                for direction in (*own, *band[nearest])]

    def as_dict(self) -> dict[str, Any]:
        return {"part": self.part, "scale": self.scale, "seed": self.seed,
                "object_quaternion": list(self.object_quaternion),
                "initial_views": [list(view) for view in self.initial_views]}

    @classmethod
    def from_dict(cls, block: Mapping[str, Any]) -> EpisodeSpec:
        """A spec from its JSON form.

        Raises:
            ValueError: For a missing or malformed field, naming it.
        """
        if not isinstance(block, Mapping):
            raise ValueError(f"an episode spec must be a mapping, got {block!r}")
        if "motor" in block and "part" not in block:
            # The key's name before vprobot called any object a part; lists on file keep it.
            block = {("part" if key == "motor" else key): value for key, value in block.items()}
        fields = {"part", "object_quaternion", "initial_views", "seed", "scale"}
        unknown = sorted(set(block) - fields)
        if unknown:
            raise ValueError(f"unknown episode spec key {unknown[0]!r}; allowed: "
                             f"{', '.join(sorted(fields))}")
        missing = sorted(fields - {"scale"} - set(block))
        if missing:
            raise ValueError(f"episode spec has no {missing[0]!r}")
        quaternion = _numbers(block["object_quaternion"])
        if quaternion.shape != (4,) or not np.all(np.isfinite(quaternion)) or not np.linalg.norm(
                quaternion) > 0:
            raise ValueError(f"episode spec object_quaternion must be 4 finite numbers, not all "
                             f"zero; got {block['object_quaternion']!r}")
        views = _numbers(block["initial_views"])
        if views.ndim != 2 or views.shape[1] != 2 or len(views) == 0 or not np.all(
                np.isfinite(views)):
            raise ValueError(f"episode spec initial_views must be a non-empty list of "
                             f"[phi, theta] pairs; got {block['initial_views']!r}")
        seed, scale = block["seed"], block.get("scale", 1.0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"episode spec seed must be a non-negative integer, got {seed!r}")
        if isinstance(scale, bool) or not isinstance(scale, int | float) or not scale > 0:
            raise ValueError(f"episode spec scale must be a positive number, got {scale!r}")
        return cls(part=str(block["part"]),
                   object_quaternion=_quaternion(quaternion),
                   initial_views=tuple((float(phi), float(theta)) for phi, theta in views),
                   seed=seed, scale=float(scale))


def _quaternion(values: np.ndarray) -> Quat:
    """Four numbers (w, x, y, z) as a spec holds them."""
    w, x, y, z = (float(value) for value in values)
    return w, x, y, z


def _numbers(value: Any) -> np.ndarray:
    """A JSON list (of lists) of numbers as an array; anything else (a mapping, a string,
    ragged lists) as an empty one, which the caller's shape check refuses, naming the field."""
    if not isinstance(value, list | tuple):
        return np.empty(0)
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return np.empty(0)


def sample_episode(env: EnvConfig, parts: Sequence[str | Path], rng: np.random.Generator,
                   seed: int, part: int | None = None, scale: float = 1.0) -> EpisodeSpec:
    """Draw an episode: the part (unless given), the object rotation, the initial view(s).

    Args:
        env: Object rotation ranges and the initial view setting.
        parts: The mesh files to draw from.
        rng: The random stream, drawn from in this order: part, rotation, initial views.
        seed: Recorded in the spec (it seeds random planners).
        part: Index into `parts` instead of a random one.
        scale: Factor from the files' units to metres.

    Raises:
        ValueError: If there are no parts or the index is out of range.
    """
    if not parts:
        raise ValueError("no parts to draw an episode from")
    index = int(rng.integers(len(parts))) if part is None else part
    if not 0 <= index < len(parts):
        raise ValueError(f"part index must lie in 0..{len(parts) - 1}, got {index}")
    quaternion = matrix_to_quat(random_object_rotation(env, rng))
    views: tuple[tuple[float, float], ...]
    if env.initial_view == "fixed":
        views = ((env.initial_phi_rad, env.initial_theta_rad),)
    else:
        directions = sphere_directions(4 * RANDOM_INITIAL_VIEWS, RANDOM_INITIAL_MAX_POLAR_RAD)
        chosen = directions[rng.choice(len(directions), RANDOM_INITIAL_VIEWS, replace=False)]
        views = tuple((float(np.arctan2(y, x) % (2.0 * np.pi)),
                       float(np.arccos(np.clip(z, -1.0, 1.0)))) for x, y, z in chosen)
    return EpisodeSpec(part=part_name(parts[index]),
                       object_quaternion=_quaternion(quaternion),
                       initial_views=views, seed=seed, scale=scale)


def seeded_episode(env: EnvConfig, part: str | Path, seed: int,
                   scale: float = 1.0) -> EpisodeSpec:
    """The episode of (part, seed): the same for every planner, agent and run."""
    rng = np.random.default_rng([seed, zlib.crc32(Path(part).name.encode())])
    return sample_episode(env, [part], rng, seed, scale=scale)


def episode_list(config: Config, parts: Sequence[str | Path],
                 seeds: Sequence[int], scale: float = 1.0) -> list[EpisodeSpec]:
    """The episodes of every part and seed, part by part; `scale` multiplies the parts'
    coordinates (0.001 for meshes in millimetres).

    Raises:
        ValueError: If there are no parts or seeds, or a seed is negative.
    """
    if not parts or not seeds:
        raise ValueError("an episode list needs at least one part and one seed")
    bad = [seed for seed in seeds if seed < 0]
    if bad:
        raise ValueError(f"seeds must be non-negative integers, got {bad[0]}")
    return [seeded_episode(config.env, part, seed, scale) for part in parts for seed in seeds]


def write_episode_list(path: str | Path, specs: Sequence[EpisodeSpec]) -> Path:
    """Write a versioned episode list (JSON) atomically."""
    path = Path(path)
    # One episode per line: readable, and diffs show which episodes changed.
    episodes = ",\n  ".join(json.dumps(spec.as_dict()) for spec in specs)
    return write_text(path, f'{{"version": {EPISODE_LIST_VERSION}, "episodes": [\n  '
                            f'{episodes}\n]}}\n')


def read_episode_list(path: str | Path) -> list[EpisodeSpec]:
    """Read an episode list written by `write_episode_list`.

    Raises:
        ValueError: If the file is missing, not JSON, of another version, or a spec is bad.
    """
    path = Path(path)
    try:
        document = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"cannot read episode list {path}: {error}") from error
    if not isinstance(document, dict) or document.get("version") != EPISODE_LIST_VERSION:
        raise ValueError(f"{path} is not an episode list of version {EPISODE_LIST_VERSION}")
    episodes = document.get("episodes")
    if not isinstance(episodes, list) or not episodes:
        raise ValueError(f"{path} lists no episodes")
    specs = []
    for index, block in enumerate(episodes):
        try:
            specs.append(EpisodeSpec.from_dict(block))
        except ValueError as error:
            raise ValueError(f"{path} episodes[{index}]: {error}") from None
    return specs


def split_lists(config: Config, split: Split) -> dict[str, list[EpisodeSpec]]:
    """The episode lists the split defines, drawn by the shared sampler: its validation list
    (`validation-v1`, `validation-v2`, `validation-v3`) and `families-test-v1`."""
    return {
        split.validation_list: episode_list(config, split.validation_objects(),
                                            split.validation_poses),
        "families-test-v1": episode_list(config, split.test_family_objects(), split.test_poses),
    }


def validation_episodes(config: Config, split: Split | None = None) -> list[EpisodeSpec]:
    """The validation episodes of what a config trains on: those of its sources (new motors
    for `motors`, held-out instances for a family)."""
    split = split if split is not None else Split.bundled(config.env.split)
    sources = set(config.env.objects)
    wanted = {"motor" if source == MOTORS else source for source in sources}
    return [spec for spec in read_episode_list(bundled_episode_list(split.validation_list))
            if family_of(spec.part) in wanted]
