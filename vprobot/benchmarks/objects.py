"""Generated objects benchmark: what a new part-family instance costs before training can use it.

For `per_family` instances of every family (seeds from 100 000 on, far from any list of split
v1) and as many new motors, it times building the mesh and then its ground truth, in a cache
folder of its own, and extrapolates to the training objects of split v1 (a one-off cost: both
are cached).
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from typing import Any

from tqdm import tqdm

from vprobot.config import Config
from vprobot.coverage.ground_truth import ground_truth
from vprobot.families import FAMILIES
from vprobot.files.paths import CACHE_ENV_VAR
from vprobot.parts.generated import family_object, generated_path, motor_object
from vprobot.parts.loading import load_mesh
from vprobot.parts.splits import Split

FIRST_SEED = 100_000
MOTOR_SEED = 99


def run_objects_benchmark(config: Config, per_family: int = 3,
                          progress: bool = True) -> dict[str, Any]:
    """Time new instances: `build_s` and `ground_truth_s` medians per family (and `motor`),
    `instance_s_median` over all, and `split_training_hours` (the split's training instances
    of every family at the median cost, on one core).

    Raises:
        ValueError: If per_family < 1.
    """
    if per_family < 1:
        raise ValueError(f"per_family must be >= 1, got {per_family}")
    names = {family: [family_object(family, FIRST_SEED + k) for k in range(per_family)]
             for family in FAMILIES}
    names["motor"] = [motor_object(MOTOR_SEED, k) for k in range(per_family)]
    build: dict[str, list[float]] = {key: [] for key in names}
    truth: dict[str, list[float]] = {key: [] for key in names}
    previous = os.environ.get(CACHE_ENV_VAR)
    with tempfile.TemporaryDirectory() as cache:
        os.environ[CACHE_ENV_VAR] = cache
        try:
            jobs = [(key, name) for key, group in names.items() for name in group]
            for key, name in tqdm(jobs, desc="objects", disable=not progress):
                start = time.perf_counter()
                path = generated_path(name)
                build[key].append(time.perf_counter() - start)
                mesh = load_mesh(path).mesh
                start = time.perf_counter()
                ground_truth(mesh, config)
                truth[key].append(time.perf_counter() - start)
        finally:
            if previous is None:
                os.environ.pop(CACHE_ENV_VAR, None)
            else:
                os.environ[CACHE_ENV_VAR] = previous
    per_instance = [b + t for key in names for b, t in zip(build[key], truth[key], strict=True)]
    split = Split.load()
    training = len(split.training_families) * len(split.training_instances)
    median = statistics.median(per_instance)
    return {
        "build_s": {key: statistics.median(values) for key, values in build.items()},
        "ground_truth_s": {key: statistics.median(values) for key, values in truth.items()},
        "instance_s_median": median,
        "split_training_instances": training,
        "split_training_hours": training * median / 3600.0,
    }
