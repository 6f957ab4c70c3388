"""Record the training domain in an estimator fit before format 4 (same weights, same widening).

Reads the fit's folder (`training.csv`, the rows it was fit on; `dataset.json`, its planners)
and its estimator, and writes the estimator in format 4 with each feature's range over the
training rows, the sensor of the rollouts (`--sensor`, a preset; `vprobot stop fit` ran with the
default config's, `paper`), the planners, and the limits on unexplored space of the estimate's
claims on those rows (`claim_limits`, at the default goal and the rule's default confidence).
Deterministic: the same inputs give the same file.

    python scripts/record_training_domain.py results/stop_estimate
    cp results/stop_estimate/estimator.npz vprobot/assets/estimator/estimator.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from vprobot.config import Config, sensor_preset
from vprobot.stop_studies.dataset import read_dataset
from vprobot.stopping.estimator import CoverageEstimator, TrainingDomain, claim_limits
from vprobot.stopping.rules.estimate import DEFAULT_CONFIDENCE


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the folder of `vprobot stop fit`")
    parser.add_argument("--sensor", default="paper", help="the rollouts' sensor preset")
    args = parser.parse_args()
    path = args.folder / "estimator.npz"
    estimator = CoverageEstimator.load(path)
    training = read_dataset(args.folder / "training.csv")
    planners = json.loads((args.folder / "dataset.json").read_text())["planners"]
    limits = claim_limits(estimator, training.features, Config().env.coverage_goal,
                          DEFAULT_CONFIDENCE)
    domain = TrainingDomain.of(training.features, sensor_preset(args.sensor), planners, limits)
    print(f"wrote {dataclasses.replace(estimator, domain=domain).save(path)}")


if __name__ == "__main__":
    main()
