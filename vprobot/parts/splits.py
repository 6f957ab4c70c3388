"""The protocol's split: which objects train agents, which select them, which test them.

Written down in `configs/splits/v<N>.yaml` (versioned; `env.split` picks one, 1 by default).
In v1 the training objects are the bundled training motors and instances 0-199 of five part
families; the validation list (model selection only: best model, early stop, hyperparameters)
holds new motors and held-out instances of the same families; the test lists (reported numbers
only) are the bundled test motors, instances of four families never trained on, and the
non-motor shapes. Its calibration objects (new motors and new instances of the training
families) calibrate a stop rule on parts no fit saw (`vprobot stop calibrate`). v2 is v1 with
the `procedural` family added to training (instances 0-4999) and validation (4 held-out
instances); its test side is v1's. v3 is v2 with the `manifold` family added to training
(instances 0-299) and validation; its test side is v1's too.
`tests/test_splits.py` checks for every version that no test object, family or episode reaches
training or validation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vprobot.files.paths import MOTORS_DIR, SPLITS_DIR
from vprobot.files.schema import read_yaml
from vprobot.parts.generated import family_object, motor_object

SPLIT_FILE = SPLITS_DIR / "v1.yaml"
"""The default split (`env.split` 1): the committed tables were made with it."""
MOTORS = "motors"
"""The source name of the bundled training motors in `env.objects`."""


def _seeds(bounds: Sequence[int]) -> range:
    low, high = bounds
    return range(int(low), int(high))


def split_versions() -> list[int]:
    """The versions of the bundled splits, ascending."""
    return sorted(int(path.stem[1:]) for path in SPLITS_DIR.glob("v*.yaml")
                  if path.stem[1:].isdigit())


def split_file(version: int) -> Path:
    """The file of bundled split `version`.

    Raises:
        ValueError: For a version not bundled; the message lists the bundled ones.
    """
    path = SPLITS_DIR / f"v{version}.yaml"
    if not path.is_file():
        raise ValueError(f"no split version {version}; bundled: "
                         f"{', '.join(map(str, split_versions()))}")
    return path


@dataclasses.dataclass(frozen=True)
class Split:
    """A versioned split (see the module docstring and `configs/splits/v1.yaml`).

    `training_instances` are the training seeds of every training family but those that
    `family_instances` gives seeds of their own (`instances_of`).
    """

    version: int
    training_families: tuple[str, ...]
    training_instances: range
    validation_motor_seed: int
    validation_motor_count: int
    validation_instances: range
    validation_poses: tuple[int, ...]
    validation_list: str
    test_families: tuple[str, ...]
    test_instances: range
    test_poses: tuple[int, ...]
    test_lists: tuple[str, ...]
    family_instances: Mapping[str, range] = dataclasses.field(default_factory=dict)
    calibration_motor_seed: int | None = None
    calibration_motor_count: int = 0
    calibration_instances: range = range(0)

    @classmethod
    def bundled(cls, version: int = 1) -> Split:
        """Bundled split `version` (`split_file`).

        Raises:
            ValueError: For a version not bundled.
        """
        return cls.load(split_file(version))

    @classmethod
    def load(cls, path: str | Path = SPLIT_FILE) -> Split:
        """Read a split file.

        Raises:
            ValueError: If a field is missing or malformed.
        """
        try:
            data: dict[str, Any] = read_yaml(path)
            training, validation, test = data["training"], data["validation"], data["test"]
            calibration = data.get("calibration") or {"motors": {"count": 0}, "instances": [0, 0]}
            own = {str(name): _seeds(bounds)
                   for name, bounds in training.get("family_instances", {}).items()}
            strangers = sorted(set(own) - set(training["families"]))
            if strangers:
                raise ValueError(f"family_instances names {strangers}, not training families")
            return cls(
                version=int(data["version"]),
                training_families=tuple(training["families"]),
                training_instances=_seeds(training["instances"]),
                validation_motor_seed=int(validation["motors"]["seed"]),
                validation_motor_count=int(validation["motors"]["count"]),
                validation_instances=_seeds(validation["instances"]),
                validation_poses=tuple(int(s) for s in validation["poses"]),
                validation_list=str(validation["list"]),
                test_families=tuple(test["families"]),
                test_instances=_seeds(test["instances"]),
                test_poses=tuple(int(s) for s in test["poses"]),
                test_lists=tuple(test["lists"]),
                family_instances=own,
                calibration_motor_seed=calibration["motors"].get("seed"),
                calibration_motor_count=int(calibration["motors"]["count"]),
                calibration_instances=_seeds(calibration["instances"]),
            )
        except (AttributeError, KeyError, TypeError, ValueError) as error:
            raise ValueError(f"{path}: not a split file ({error})") from None

    def check_sources(self, sources: Sequence[str], key: str = "env.objects") -> None:
        """Refuse training sources that are not the split's training objects.

        Raises:
            ValueError: For an empty list, a test family or an unknown source; the message
                names `key` and lists the allowed sources.
        """
        allowed = (MOTORS, *self.training_families)
        if not sources:
            raise ValueError(f"{key} must name at least one source: {', '.join(allowed)}")
        for source in sources:
            if source in self.test_families:
                raise ValueError(f"{key}: {source!r} is a test family of split v{self.version} "
                                 f"(never trained on); training sources: {', '.join(allowed)}")
            if source not in allowed:
                raise ValueError(f"{key}: unknown source {source!r}; training sources: "
                                 f"{', '.join(allowed)}")

    def instances_of(self, family: str) -> range:
        """The training seeds of a training family."""
        return self.family_instances.get(family, self.training_instances)

    def training_objects(self, sources: Sequence[str]) -> list[str | Path]:
        """The objects training draws from (bundled motor files, generated names), each source
        repeated to the size of the largest, so that a uniform draw picks every source equally
        often (20 motors beside 200 instances of a family would otherwise be 1 draw in 11)."""
        self.check_sources(sources)
        groups = [sorted((MOTORS_DIR / "train").glob("*.stl")) if source == MOTORS else
                  [family_object(source, seed) for seed in self.instances_of(source)]
                  for source in sources]
        size = max(len(group) for group in groups)
        return [group[index % len(group)] for group in groups for index in range(size)]

    def validation_objects(self) -> list[str]:
        """Every object of the validation list: new motors, then held-out family instances."""
        motors = [motor_object(self.validation_motor_seed, index)
                  for index in range(self.validation_motor_count)]
        return motors + [family_object(family, seed) for family in self.training_families
                         for seed in self.validation_instances]

    def calibration_objects(self) -> list[str]:
        """The objects a calibrated stop is calibrated on (`vprobot stop calibrate`): new
        motors, then new instances of every training family, none of which any fit, selection
        or test list uses.

        Raises:
            ValueError: If the split names none.
        """
        motors = ([motor_object(self.calibration_motor_seed, index)
                   for index in range(self.calibration_motor_count)]
                  if self.calibration_motor_seed is not None else [])
        objects = motors + [family_object(family, seed) for family in self.training_families
                            for seed in self.calibration_instances]
        if not objects:
            raise ValueError(f"split v{self.version} names no calibration objects (its "
                             f"`calibration:` block)")
        return objects

    def test_family_objects(self) -> list[str]:
        """The instances of the test families on `families-test-v1`."""
        return [family_object(family, seed) for family in self.test_families
                for seed in self.test_instances]
