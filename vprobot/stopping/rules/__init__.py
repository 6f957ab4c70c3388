"""Stop rules any planner can use (`--stop goal|estimate|confident|grid|measurable|views:N|agent`).

`goal` is the simulator's stop at the coverage goal (the default); `estimate` stops when the
model-free coverage estimate says the goal is reached with a chosen confidence; `confident` when
the calibrated probability that it is reaches a threshold certified for false stops; `grid` when the
surface seen stops growing; `measurable` when the reachable candidates would measure little more;
`views:N` after N acquisitions; `agent` leaves it to an agent's learned stop action. One module
per rule, registered in `STOPS` (`base`), which declares the bundled ones and imports a rule's
module on the first lookup of its name; the runner asks the rule before each request
(`vprobot.planners.runner`), and `nbv@RULE` asks its rule itself before each view
(`vprobot.planners.nbv`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vprobot.stopping.rules.base import STOPS, StopRule, StopSubject, register_stop

if TYPE_CHECKING:
    # Types only: the rules are listed (`--help`) without the config's imports.
    from vprobot.config import Config

__all__ = ["STOPS", "StopRule", "StopSubject", "make_stop_rule", "parse_stop", "register_stop",
           "stop_names"]


def stop_names() -> list[str]:
    """The stop rules as messages list them, in name order."""
    return [STOPS.fact(name, "usage") or name for name in STOPS]


def parse_stop(text: str) -> tuple[type[StopRule], dict[str, Any]]:
    """The rule class a stop rule names (`estimate:0.9`) and its validated options.

    Raises:
        ValueError: For an unknown rule or a bad value; the message names it and lists the
            accepted forms.
    """
    for name in STOPS:
        match = re.fullmatch(re.escape(name) + STOPS.fact(name, "pattern"), text)
        if match is None:
            continue
        cls = STOPS[name]
        groups = {key: value for key, value in match.groupdict().items() if value is not None}
        try:
            return cls, cls.options(**groups)
        except ValueError as error:
            raise ValueError(f"bad stop rule {text!r}: {error}; allowed: "
                             f"{', '.join(stop_names())}") from None
    raise ValueError(f"unknown stop rule {text!r}; allowed: {', '.join(stop_names())}")


def make_stop_rule(text: str, config: Config, estimator: str | Path | None = None) -> StopRule:
    """A stop rule by name for runs of `config`; `estimator` is the coverage estimator file of
    `estimate` (None: the bundled one).

    Raises:
        ValueError: For an unknown rule, a bad value or an estimator that cannot be read.
    """
    cls, options = parse_stop(text)
    return cls.build(config, estimator, **options)
