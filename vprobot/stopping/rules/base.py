"""The stop-rule interface: when the runner ends a planner's episode (`--stop`).

Before each request the runner asks the episode's rule whether to stop now (`StopRule.check`);
a planner may still end its episode earlier (a fixed plan runs out, `nbv@RULE` stops itself
by a rule of its own), and the runner always stops at the view budget (`env.max_acquisitions`
requests after the initial view). Every rule registers its class in `STOPS` under its `name`
(`register_stop`); `vprobot.stopping.rules.make_stop_rule` builds rules by name from there.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from vprobot.extensions.registry import Bundled, Registry

if TYPE_CHECKING:
    # Types only: the rules are listed (`--help`) without the config's imports, and the
    # planners' runner builds on this interface.
    from vprobot.config import Config
    from vprobot.episode import Episode


@dataclasses.dataclass(frozen=True)
class StopSubject:
    """What a stop rule reads of the planner it stops: a read-only view, so that a rule neither
    changes the planner nor depends on the planners' layer above it (the planners build it:
    `vprobot.planners.self_stopping.stop_subject`).

    Attributes:
        name: The planner's name.
        stops_at_goal: Whether the runner stops it at the coverage goal (a fixed plan runs out).
        decides_stop: Whether it decides itself when to stop (an agent with a stop action).
    """

    name: str
    stops_at_goal: bool
    decides_stop: bool


class StopRule(abc.ABC):
    """Decides, from the episode so far, whether the runner stops the planner now.

    Attributes:
        name: Its name in `STOPS` (`goal`, `estimate`, `views`, ...).
        pattern: What may follow `name`, a regular expression whose named groups are passed to
            `options` (`views` takes `:(?P<count>.*)`: `views:5`); empty: the bare name only.
        usage: The rule as messages list it (`views:N (N >= 1)`); empty: `name`.
        description: When it stops, for `--help` (`after N acquisitions`).
        keeps_learned_stop: Whether a planner's learned stop action stays in use under the rule
            (`goal`, `agent`); under the others the rule decides, and the runner turns the
            planner's off.
    """

    name: ClassVar[str]
    pattern: ClassVar[str] = ""
    usage: ClassVar[str] = ""
    description: ClassVar[str] = ""
    keeps_learned_stop: ClassVar[bool] = False

    @classmethod
    def options(cls, **groups: str) -> dict[str, Any]:
        """The rule's options from the groups of `pattern` that matched.

        Raises:
            ValueError: For a value the rule does not take (the message says what it takes).
        """
        return {}

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        """The rule for a run of `config`; `estimator` is the coverage estimator file of the
        rules that estimate (None: the bundled one), `options` come from `options`."""
        return cls(**options)

    def applies_to(self, planner: StopSubject) -> bool:
        """Whether the rule can stop this planner (`agent` needs a learned stop)."""
        return True

    def bind(self, planner: StopSubject) -> None:
        """Take on a planner for its episodes: refuse one the rule cannot stop (a rule that
        keeps something of the planner notes it here).

        Raises:
            ValueError: If the rule does not apply to the planner.
        """
        if not self.applies_to(planner):
            raise ValueError(f"stop rule {self.name!r} does not apply to planner "
                             f"{planner.name!r}")

    def governs(self, planner: StopSubject) -> bool:
        """Whether the runner stops the planner (by this rule and the view budget) or leaves
        stopping to it."""
        return True

    def reset(self) -> None:  # noqa: B027 (a hook: rules that keep no episode state skip it)
        """A new episode."""

    @abc.abstractmethod
    def check(self, episode: Episode) -> str | None:
        """Why to stop now, else None; called before each request of a governed planner (and
        by `nbv@RULE` before each of its views)."""


STOPS: Registry[type[StopRule]] = Registry(
    "stop rule",
    facts={"pattern": "", "usage": "", "description": ""},
    bundled={
        "agent": Bundled("vprobot.stopping.rules.agent:AgentStop",
                         description="the agent's learned stop action"),
        "confident": Bundled(
            "vprobot.stopping.rules.confident:ConfidentStop", pattern=r"(?::(?P<probability>.*))?",
            usage="confident[:P] (0 < P < 1, default: the calibrated threshold)",
            description="the calibrated probability that the goal is reached reaches P"),
        "estimate": Bundled(
            "vprobot.stopping.rules.estimate:EstimateStop", pattern=r"(?::(?P<confidence>.*))?",
            usage="estimate[:C] (0 < C < 1, default 0.95)",
            description="the model-free coverage estimate reaches the goal with confidence C"),
        "goal": Bundled("vprobot.stopping.rules.goal:GoalStop",
                        description="the simulator's stop at the coverage goal"),
        "grid": Bundled("vprobot.stopping.rules.grid:GridStop",
                        description="the seen surface stops growing"),
        "measurable": Bundled(
            "vprobot.stopping.rules.measurable:MeasurableStop", pattern=r"(?::(?P<share>.*))?",
            usage="measurable[:S] (0 < S < 1, default 0.04)",
            description="what the reachable candidates would still measure falls to a share S"),
        "views": Bundled("vprobot.stopping.rules.views:ViewsStop",
                         pattern=r"(?::(?P<count>.*))?", usage="views:N (N >= 1)",
                         description="after N acquisitions"),
    })
"""Every stop rule class by name, in name order: the bundled ones (declared here, each a module
of this package; tests/test_registries.py checks this index against the modules) and those of
plugins."""

register_stop = STOPS.register_named
"""Class decorator: registers a stop rule under its `name`."""


def fraction_option(groups: Mapping[str, str], name: str, letter: str) -> dict[str, Any]:
    """The option `name` of a rule written `RULE:X`, a number in (0, 1) (`letter` names X in
    the message); {} where it is not written.

    Raises:
        ValueError: For anything but a number in (0, 1).
    """
    text = groups.get(name)
    if text is None:
        return {}
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise ValueError(f"{letter} must be a number in (0, 1)")
    return {name: value}
