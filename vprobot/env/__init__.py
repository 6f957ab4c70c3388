"""The gymnasium environment `vprobot/Inspect-v0` and its parts (actions, rewards, states)."""

from vprobot.env.inspect_env import InspectEnv

ENV_ID = "vprobot/Inspect-v0"

__all__ = ["ENV_ID", "InspectEnv"]
