"""The agents' encoders by name (`agent.encoder`, docs/agents.md#encoders).

An entry says which network an encoder is, which of its settings it takes and which algorithms
it serves. A bundled encoder is a module of `vprobot.agents.extractors` holding its network and
its registration (declared in `ENCODERS`, which imports the module, and with it torch, on the
first lookup of its name); one from outside is a plugin (`vprobot.extensions.plugins`). This module
itself imports no torch, and the config does not read `ENCODERS`: `check_encoder` checks
`agent.encoder` wherever the agent section is used, before any work starts.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from vprobot.config import check_registered
from vprobot.extensions.registry import Bundled, Registry
from vprobot.files.schema import ConfigError

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
            class.
        settings: The network's keyword arguments, from the agent's settings.
        algorithms: The values of `agent.algorithm` it serves.
    """

    network: type
    settings: Callable[[AgentConfig], dict[str, Any]] = scaled
    algorithms: tuple[str, ...] = ("sac", "ppo")


ENCODERS: Registry[Encoder] = Registry("encoder", bundled={
    "candidates": Bundled("vprobot.agents.extractors.candidates:CANDIDATES"),
    "pcn": Bundled("vprobot.agents.extractors.pcn:PCN"),
    "pointnet": Bundled("vprobot.agents.extractors.pointnet:POINTNET"),
    "sphere": Bundled("vprobot.agents.extractors.sphere_map:SPHERE"),
})
"""Every encoder by name, one module each in `vprobot.agents.extractors`."""


def check_encoder(agent: AgentConfig) -> None:
    """Raise ConfigError unless `agent.encoder` is registered and serves `agent.algorithm` (the
    messages name the encoders, and those that serve the algorithm)."""
    check_registered(agent.encoder, ENCODERS, "agent.encoder")
    encoder = ENCODERS[agent.encoder]
    if agent.algorithm not in encoder.algorithms:
        serving = [name for name, other in ENCODERS.items() if agent.algorithm in other.algorithms]
        raise ConfigError(f"agent.encoder {agent.encoder!r} serves agent.algorithm "
                          f"{list(encoder.algorithms)}, got {agent.algorithm!r}; "
                          f"agent.algorithm {agent.algorithm!r} takes agent.encoder {serving}")
