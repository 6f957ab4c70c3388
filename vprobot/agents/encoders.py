"""The agents' encoders by name (`agent.encoder`, docs/agents.md#encoders).

An entry says which network an encoder is, which of its settings it takes and which algorithms
it serves; a new encoder is a module with its network that registers an `Encoder` in
`ENCODERS`. This module imports no torch: the config checks names against it when it loads,
and the built-in networks are named by their paths, imported when a model is built.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from vprobot.registry import Registry

if TYPE_CHECKING:
    from vprobot.config import AgentConfig


def scaled(agent: AgentConfig) -> dict[str, Any]:
    """The settings of an encoder of published widths: `encoder_scale` multiplies them."""
    return {"scale": agent.encoder_scale}


@dataclasses.dataclass(frozen=True)
class Encoder:
    """An encoder as `agent.encoder` names it.

    Attributes:
        network: With `sac` and `ppo` the policy's features extractor (a
            `vprobot.agents.extractors.PointCloudExtractor` subclass), with `dqn` its policy
            class; or the `"module:Class"` path of one, imported by `load`.
        settings: The network's keyword arguments, from the agent's settings.
        algorithms: The values of `agent.algorithm` it serves.
    """

    network: type | str
    settings: Callable[[AgentConfig], dict[str, Any]] = scaled
    algorithms: tuple[str, ...] = ("sac", "ppo")

    def load(self) -> type:
        """The network class (imported from its path on first use)."""
        if isinstance(self.network, type):
            return self.network
        module, name = self.network.split(":")
        network: type = getattr(importlib.import_module(module), name)
        return network


ENCODERS: Registry[Encoder] = Registry("encoder")
"""Every encoder by name, in registration order."""

ENCODERS.register("pcn", Encoder("vprobot.agents.extractors.pcn:PCNExtractor"))
ENCODERS.register("pointnet", Encoder("vprobot.agents.extractors.pointnet:PointNetExtractor"))
ENCODERS.register("sphere", Encoder(
    "vprobot.agents.extractors.sphere_map:SphereMapExtractor",
    settings=lambda agent: {"bins": agent.sphere_bins, "features": agent.sphere_features}))
ENCODERS.register("candidates", Encoder(
    "vprobot.agents.candidate_q:CandidatePolicy",
    settings=lambda agent: {"net_arch": list(agent.net_arch)}, algorithms=("dqn",)))
