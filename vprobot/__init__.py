"""vprobot: robot-guided visual inspection planning in MuJoCo."""

import os

from vprobot.compute import kernels

# Offscreen rendering must work headless; MuJoCo reads this when it is first imported.
os.environ.setdefault("MUJOCO_GL", "egl")
# Before numpy loads: the same arithmetic on every CPU with AVX2 (vprobot/compute/kernels.py).
kernels.pin()

import gymnasium  # noqa: E402 (after the kernels are pinned)

__version__ = "0.1.0"

gymnasium.register(id="vprobot/Inspect-v0", entry_point="vprobot.env.inspect_env:InspectEnv")
