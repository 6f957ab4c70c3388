"""The gymnasium environment `vprobot/Inspect-v0` (`inspect_env.InspectEnv`) and its parts
(actions, rewards, states).

The package imports none of them: the config validates its names against `rewards`, which must
not bring the environment (MuJoCo, the robot), and the environment builds on the config.
"""

ENV_ID = "vprobot/Inspect-v0"
