"""The agents' encoders by name (`agent.encoder`, docs/agents.md#encoders).

An entry says which network an encoder is, the dataclass of its settings
(`agent.encoder_settings.<name>`), how they become the network's arguments and which algorithms it
serves. A bundled encoder is a module of `vprobot.agents.extractors` holding its network and
its registration (declared in `ENCODERS`, which imports the module, and with it torch, on the
first lookup of its name); one from outside is a plugin (`vprobot.extensions.plugins`). This module
itself imports no torch, and the config does not read `ENCODERS`: `check_encoder` checks
`agent.encoder` wherever the agent section is used, before any work starts.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from vprobot.config import check_registered
from vprobot.extensions.registry import Bundled, Registry
from vprobot.files.schema import ConfigError, brief, from_mapping

if TYPE_CHECKING:
    from vprobot.config import AgentConfig


@dataclasses.dataclass(frozen=True)
class Scaled:
    """The setting of an encoder of published widths (`pcn`, `pointnet`).

    Attributes:
        scale: Multiplies the widths (1: the published sizes).
    """

    scale: float = 1.0

    def __post_init__(self) -> None:
        if not self.scale > 0:
            raise ConfigError(f"scale must be > 0, got {self.scale}")


@dataclasses.dataclass(frozen=True)
class NoSettings:
    """The settings of an encoder that has none of its own."""


def as_arguments(agent: AgentConfig, settings: Any) -> dict[str, Any]:
    """The network's keyword arguments: its settings' fields."""
    return dataclasses.asdict(settings)


@dataclasses.dataclass(frozen=True)
class Encoder:
    """An encoder as `agent.encoder` names it, with its settings (`agent.encoder_settings`
    under its name).

    Attributes:
        network: With `sac` and `ppo` the policy's features extractor (a
            `vprobot.agents.extractors.PointCloudExtractor` subclass), with `dqn` its policy
            class.
        settings: The dataclass of its settings (`agent.encoder_settings.<name>`: defaults,
            checks in its `__post_init__`), declared beside the network: a setting of a new
            encoder is a field there, not in the config.
        arguments: The network's keyword arguments from the agent section and the settings.
        algorithms: The values of `agent.algorithm` it serves.
    """

    network: type
    settings: type = Scaled
    arguments: Callable[[AgentConfig, Any], dict[str, Any]] = as_arguments
    algorithms: tuple[str, ...] = ("sac", "ppo")


ENCODERS: Registry[Encoder] = Registry("encoder", bundled={
    "candidates": Bundled("vprobot.agents.extractors.candidates:CANDIDATES"),
    "pcn": Bundled("vprobot.agents.extractors.pcn:PCN"),
    "pointnet": Bundled("vprobot.agents.extractors.pointnet:POINTNET"),
    "sphere": Bundled("vprobot.agents.extractors.sphere_map:SPHERE"),
})
"""Every encoder by name, one module each in `vprobot.agents.extractors`."""


def check_encoder(agent: AgentConfig) -> None:
    """Raise ConfigError unless `agent.encoder` is registered and serves `agent.algorithm`, and
    `agent.encoder_settings` holds settings of registered encoders that they take (the
    messages name the encoders, those that serve the algorithm, or the settings allowed)."""
    check_registered(agent.encoder, ENCODERS, "agent.encoder")
    encoder = ENCODERS[agent.encoder]
    if agent.algorithm not in encoder.algorithms:
        serving = [name for name, other in ENCODERS.items() if agent.algorithm in other.algorithms]
        raise ConfigError(f"agent.encoder {agent.encoder!r} serves agent.algorithm "
                          f"{list(encoder.algorithms)}, got {agent.algorithm!r}; "
                          f"agent.algorithm {agent.algorithm!r} takes agent.encoder {serving}")
    for name in agent.encoder_settings:
        check_registered(name, ENCODERS, "a key of agent.encoder_settings")
        encoder_settings(agent, name)


def encoder_settings(agent: AgentConfig, name: str | None = None) -> Any:
    """The settings of encoder `name` (default: `agent.encoder`) as its settings dataclass:
    `agent.encoder_settings.<name>`, defaults for the keys not given.

    Raises:
        ConfigError: For a key the encoder does not take or a bad value (naming it).
    """
    name = name or agent.encoder
    key = f"agent.encoder_settings.{name}"
    given = agent.encoder_settings.get(name) or {}
    if not isinstance(given, Mapping):
        raise ConfigError(f"{key} must be a mapping of settings, got {brief(given)}")
    return from_mapping(ENCODERS[name].settings, given, key)


def network_arguments(agent: AgentConfig) -> dict[str, Any]:
    """The keyword arguments of the encoder's network (`build_model`)."""
    return ENCODERS[agent.encoder].arguments(agent, encoder_settings(agent))
