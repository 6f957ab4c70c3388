"""vprobot: robot-guided visual inspection planning in MuJoCo."""

import os

# Offscreen rendering must work headless; MuJoCo reads this when it is first imported.
os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium

__version__ = "0.1.0"

gymnasium.register(id="vprobot/Inspect-v0", entry_point="vprobot.env.inspect_env:InspectEnv")
