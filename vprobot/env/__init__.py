"""The gymnasium environment `vprobot/Inspect-v0` and its parts (actions, rewards, states)."""

from __future__ import annotations

from typing import Any

ENV_ID = "vprobot/Inspect-v0"

__all__ = ["ENV_ID", "InspectEnv"]


def __getattr__(name: str) -> Any:
    if name == "InspectEnv":
        # The env (MuJoCo, the robot) is imported on first use: the config validates its
        # names against vprobot.env.rewards, which must stay light to import.
        from vprobot.env.inspect_env import InspectEnv

        return InspectEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
