"""Steps per second of the candidate-view env (`s_grid` state, `A_view` actions, the robot, the
training resolution) as `vprobot benchmark env` measures `steps_per_s_grid_train` (random offered
candidates from seed 0, resets excluded), for any vprobot checkout: issue 45 timed the code before
it with this (`PYTHONPATH=CHECKOUT python scripts/grid_env_rate.py configs/cell_real.yaml 60`, run
from that checkout), whose env benchmark does not measure this env.

Usage: python scripts/grid_env_rate.py CONFIG STEPS
"""

from __future__ import annotations

import sys
import time

import numpy as np

from vprobot.cell.sensor import TRAINING_RESOLUTION
from vprobot.config import load_config, replace
from vprobot.env.inspect_env import InspectEnv


def main(config_path: str, steps: int) -> float:
    config = replace(load_config(config_path), "env", state="s_grid", action="A_view",
                     reward="R2", parts="train", resolution=TRAINING_RESOLUTION)
    env = InspectEnv(config)
    for path in env.part_files:
        env.scene(path)
    rng = np.random.default_rng(0)
    observation, _ = env.reset(seed=0)
    stepping = 0.0
    for _ in range(steps):
        action = int(rng.choice(np.flatnonzero(observation["mask"] > 0.5)))
        start = time.perf_counter()
        observation, _, terminated, truncated, _ = env.step(action)  # type: ignore[arg-type]
        stepping += time.perf_counter() - start
        if terminated or truncated:
            observation, _ = env.reset()
    return steps / stepping


if __name__ == "__main__":
    print(f"steps_per_s_grid_train {main(sys.argv[1], int(sys.argv[2])):.2f}")
