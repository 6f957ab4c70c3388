"""Splits v1 and v2: what trains, selects and tests agents never overlaps; generated objects;
lists; v2 is v1 with the procedural family added."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from vprobot.config import Config, ConfigError, replace
from vprobot.episode import EpisodeSpec, read_episode_list
from vprobot.episode.specs import (
    bundled_episode_list,
    part_name,
    split_lists,
    validation_episodes,
)
from vprobot.families import FAMILIES
from vprobot.files.paths import MOTORS_DIR
from vprobot.parts.generated import family_of, generated_path, motor_object
from vprobot.parts.splits import MOTORS, Split, split_versions

CONFIG = Config()
SPLIT = Split.load()
ALL_SOURCES = (MOTORS, *SPLIT.training_families)
SPLITS = {version: Split.bundled(version) for version in split_versions()}


@pytest.fixture
def cache(session_cache: Path) -> Path:
    """Where generated objects go: the session's cache (`conftest.py`)."""
    return session_cache


def names(objects: list) -> set[str]:
    # Each object once: a training list repeats every source to the size of the largest (5000
    # procedural instances), and each name resolves the path.
    return {part_name(item) for item in set(objects)}


def episode_key(spec: EpisodeSpec) -> tuple:
    return spec.part, spec.object_quaternion


@pytest.mark.parametrize("version", sorted(SPLITS))
def test_no_test_object_family_or_episode_reaches_training_or_validation(version: int) -> None:
    split = SPLITS[version]
    training = names(split.training_objects((MOTORS, *split.training_families)))
    validation = read_episode_list(bundled_episode_list(split.validation_list))
    tests = [spec for name in split.test_lists
             for spec in read_episode_list(bundled_episode_list(name))]
    test_objects = {spec.part for spec in tests}
    assert not test_objects & training
    assert not test_objects & {spec.part for spec in validation}
    assert not {episode_key(spec) for spec in tests} & {episode_key(s) for s in validation}
    # Families: the test families are never trained on or validated on, and the test lists'
    # generated objects all belong to test families.
    assert not set(split.test_families) & set(split.training_families)
    trained_families = {family_of(name) for name in training} - {None}
    assert trained_families == set(split.training_families)
    assert {family_of(spec.part) for spec in validation} <= {*split.training_families, "motor"}
    assert {family_of(spec.part) for spec in tests} - {None} <= set(split.test_families)
    # Validation objects are not training objects either (held-out instances, new motors).
    assert not {spec.part for spec in validation} & training
    # The non-motor shapes are kinds of parts held out of training (a bracket, a pipe tee).
    assert {"bracket", "pipe_fitting"} <= set(split.test_families)
    assert set(split.test_families) | set(split.training_families) <= set(FAMILIES)


@pytest.mark.parametrize("version", sorted(SPLITS))
def test_calibration_objects_are_new_parts_of_the_training_families_no_other_list_holds(
        version: int) -> None:
    split = SPLITS[version]
    calibration = split.calibration_objects()
    assert len(set(calibration)) == len(calibration) == (
        split.calibration_motor_count
        + len(split.training_families) * len(split.calibration_instances))
    others = names(split.training_objects((MOTORS, *split.training_families))) | {
        spec.part for name in (split.validation_list, *split.test_lists)
        for spec in read_episode_list(bundled_episode_list(name))}
    assert not set(calibration) & others
    assert {family_of(name) or "motor" for name in calibration} == {
        "motor", *split.training_families}


@pytest.mark.parametrize("version", sorted(SPLITS))
def test_split_lists_are_what_the_sampler_draws(version: int) -> None:
    for name, specs in split_lists(CONFIG, SPLITS[version]).items():
        assert read_episode_list(bundled_episode_list(name)) == specs


def test_split_v2_is_v1_with_thousands_of_procedural_instances_added() -> None:
    v1, v2 = SPLITS[1], SPLITS[2]
    assert SPLIT == v1 and v2.version == 2
    assert v2.training_families == (*v1.training_families, "procedural")
    assert all(v2.instances_of(family) == v1.instances_of(family) == range(200)
               for family in v1.training_families)
    assert v2.instances_of("procedural") == range(5000)
    for field in ("test_families", "test_instances", "test_poses", "test_lists",
                  "validation_motor_seed", "validation_motor_count", "validation_instances",
                  "validation_poses"):
        assert getattr(v2, field) == getattr(v1, field)
    # A run on v1's sources validates on the same episodes under either split.
    first = read_episode_list(bundled_episode_list(v1.validation_list))
    second = read_episode_list(bundled_episode_list(v2.validation_list))
    assert [spec for spec in second if family_of(spec.part) != "procedural"] == first
    assert sorted(spec.part for spec in second if family_of(spec.part) == "procedural") == [
        f"generated/procedural_{seed}.stl" for seed in range(10000, 10004)]


def test_a_split_giving_seeds_to_a_family_it_does_not_train_on_is_refused(
        tmp_path: Path) -> None:
    from vprobot.parts.splits import split_file

    path = tmp_path / "v9.yaml"
    path.write_text(split_file(2).read_text().replace("procedural: [0, 5000]",
                                                      "pulley: [0, 5000]"))
    with pytest.raises(ValueError, match=r"not a split file \(family_instances names "
                                         r"\['pulley'\], not training families\)"):
        Split.load(path)


def test_env_split_picks_the_split_that_training_and_validation_draw_from() -> None:
    from vprobot.env.inspect_env import part_files

    config = replace(CONFIG, "env", objects=("motors", "procedural"), split=2)
    objects = part_files(config)
    assert len(objects) == 2 * 5000
    assert {family_of(str(item)) for item in objects} == {None, "procedural"}
    assert "generated/procedural_4999.stl" in objects
    episodes = validation_episodes(config)
    assert [family_of(spec.part) for spec in episodes] == ["motor"] * 5 + ["procedural"] * 4
    with pytest.raises(ConfigError, match="unknown source 'procedural'; training sources: "
                                          "motors, flange, housing"):
        replace(CONFIG, "env", objects=("procedural",))
    with pytest.raises(ConfigError, match="'pulley' is a test family of split v2"):
        replace(CONFIG, "env", objects=("pulley",), split=2)
    with pytest.raises(ConfigError, match=r"^env.split: no split version 4; bundled: 1, 2, 3$"):
        replace(CONFIG, "env", split=4)


def test_validation_episodes_are_those_of_the_trained_sources() -> None:
    motors_only = validation_episodes(CONFIG)
    assert {family_of(spec.part) for spec in motors_only} == {"motor"}
    assert len(motors_only) == SPLIT.validation_motor_count
    mixed = validation_episodes(replace(CONFIG, "env", objects=("motors", "flange")))
    assert {family_of(spec.part) for spec in mixed} == {"motor", "flange"}
    assert len(mixed) == SPLIT.validation_motor_count + len(SPLIT.validation_instances)


def test_training_draws_every_source_equally_often() -> None:
    objects = SPLIT.training_objects((MOTORS, "flange"))
    motors = [item for item in objects if not str(item).startswith("generated/")]
    assert len(motors) == len(objects) - len(motors) == len(SPLIT.training_instances)
    assert len(set(motors)) == 20


def test_a_generated_motor_of_seed_0_is_the_bundled_training_motor_byte_for_byte(
        cache: Path) -> None:
    path = generated_path(motor_object(0, 3))
    assert path.is_relative_to(cache)
    assert path.read_bytes() == (MOTORS_DIR / "train" / "motor_003.stl").read_bytes()


def test_a_generated_instance_is_made_once_then_read_back(cache: Path) -> None:
    spec = read_episode_list(bundled_episode_list("families-test-v1"))[0]
    first = spec.part_path
    made = first.stat().st_mtime_ns
    assert spec.part_path == first and first.stat().st_mtime_ns == made
    family, seed = first.stem.rsplit("_", 1)
    expected = FAMILIES[family].instance(int(seed)).mesh.export(file_type="stl")
    assert first.read_bytes() == expected


def test_bad_training_sources_are_one_line_config_errors() -> None:
    with pytest.raises(ConfigError, match="'pulley' is a test family of split v1"):
        replace(CONFIG, "env", objects=("motors", "pulley"))
    with pytest.raises(ConfigError, match="unknown source 'gears'; training sources: motors"):
        replace(CONFIG, "env", objects=("gears",))
    with pytest.raises(ConfigError, match="applies to training"):
        replace(CONFIG, "env", objects=("flange",), parts="test")
    with pytest.raises(ValueError, match="is not a generated object"):
        generated_path("generated/nothing.stl")


def test_env_draws_family_instances_and_builds_them_on_first_use(cache: Path) -> None:
    from vprobot.env.inspect_env import InspectEnv

    env = InspectEnv(replace(CONFIG, "env", objects=("spur_gear",), resolution=(64, 45),
                             state_points=64))
    env.reset(seed=0)
    assert family_of(env.spec_of_episode.part) == "spur_gear"
    assert env.spec_of_episode.part_path.is_relative_to(cache)
    observation, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert np.isfinite(observation).all()


def test_training_evaluates_on_the_validation_list_and_never_reads_a_test_list(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import vprobot.episode.specs as specs
    import vprobot.training.train as training
    from vprobot.files.paths import CONFIGS_DIR, MOTORS_DIR

    read: list[Path] = []

    def recording(path: str | Path) -> list[EpisodeSpec]:
        read.append(Path(path))
        return read_episode_list(path)

    monkeypatch.setattr(specs, "read_episode_list", recording)
    monkeypatch.setattr(training, "read_episode_list", recording)
    # One training motor: the validation list is that of the `motors` source all the same, and
    # every other motor drawn would cost its ground truth.
    config = training.profile_config(CONFIGS_DIR / "agents" / "cpu.yaml", [
        "env.parts=mesh", f"env.mesh={MOTORS_DIR / 'train' / 'motor_000.stl'}",
        "env.resolution=[64,45]", "env.state_points=64", "agent.learning_starts=20",
        "agent.batch_size=16", "agent.buffer_size=200", "agent.eval_freq=30",
        "agent.eval_episodes=1", "agent.checkpoint_freq=1000", "agent.net_arch=[16,16]"],
        steps=30)
    training.train(config, tmp_path / "run", progress=False)
    assert read and set(read) == {bundled_episode_list(SPLIT.validation_list)}
    rows = (tmp_path / "run" / "evaluations.csv").read_text().splitlines()
    assert len(rows) >= 2


PINNED_SHA256 = {
    "bracket": "aacec58c042cd363", "flange": "c9e9cae60cda6379", "housing": "ffa5cb5974f36a97",
    "lever": "dadd1e244fd4f1d9", "manifold": "8c50def59c9b8479",
    "pipe_fitting": "0a38250d4bac1bf7",
    "procedural": "2dd98189bc5e515b", "pulley": "85d3eb1371153e3d",
    "spur_gear": "80872660f6236cf2", "stepped_shaft": "92c102d6c4b503e0",
    "valve_body": "643fd0356dc084ed",
}
"""sha256 (first 16 hex digits) of instance 0 of each family the splits name (those whose
instances the bundled episode lists and the committed results use; a family that none names
needs no pin), as `vprobot.parts.generated.VERSION` 1 makes them. Cached files are never checked
again: if this test fails, a generator changed and `VERSION` must be bumped (then update the
digests)."""
PINNED_MOTOR_SHA256 = "1e00ba74d244f0a2"
"""The same of motor 0 of generator seed 2."""


def test_every_family_a_split_names_is_pinned() -> None:
    named = {family for split in SPLITS.values()
             for family in (*split.training_families, *split.test_families)}
    assert named <= set(PINNED_SHA256)


def test_generators_still_make_the_pinned_objects_of_this_cache_version(cache: Path) -> None:
    from vprobot.parts.generated import VERSION, family_object

    assert VERSION == 1
    made = {family: generated_path(family_object(family, 0)) for family in PINNED_SHA256}
    assert {key: hashlib.sha256(path.read_bytes()).hexdigest()[:16]
            for key, path in made.items()} == PINNED_SHA256
    motor = generated_path(motor_object(2, 0))
    assert hashlib.sha256(motor.read_bytes()).hexdigest()[:16] == PINNED_MOTOR_SHA256
