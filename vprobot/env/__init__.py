"""The gymnasium environment `vprobot/Inspect-v0` (`inspect_env.InspectEnv`) and its parts
(actions, rewards, states).

The package imports none of them: the environment builds on the config, which checks
`env.reward` against the low `vprobot.rewards` without bringing the environment (MuJoCo, the
robot).
"""

ENV_ID = "vprobot/Inspect-v0"
