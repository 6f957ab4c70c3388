"""The planner interface: a next view from the current state of an episode, or a whole plan.

A `Planner` is asked for one `ViewRequest` at a time for an `Episode` (robot in the loop or
free-flying sensor, `vprobot.episode`) until it returns None or the runner stops it (coverage
goal, view budget); planners that compute a whole plan up front (`PlanPlanner`) hand it out
view by view.

Every planner registers its class in `PLANNERS` under its `name` (`register_planner`): a bundled
one is a module of this package, declared in `PLANNERS` with what listing it needs and imported
on the first lookup of its name; the runner builds planners by name from there
(`vprobot.planners.runner.make_planner`).

What only some planners have, the runner reads off the small classes they also derive from: the
episode's initial view (`initial_view.InitialViewPlanner`), a stop of their own
(`self_stopping.SelfStopping`, `self_stopping.LearnedStop`), the candidate views they chose from
(`candidates.ModelBasedPlanner`) and an exact planner's proof (`proof.ExactPlanner`).
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, ClassVar

from vprobot.extensions.registry import Bundled, Registry

if TYPE_CHECKING:
    # Types only: the planners' names are listed (`vprobot plan --help`) without the episode's
    # simulation.
    import numpy as np

    from vprobot.config import Config
    from vprobot.episode import Episode, ViewRequest


MAX_VIEWS = 100
"""Most views a plan may be asked for (`--views`, `bscp<N>`, `agent<N>`, `uniform<k>`): ten
times the view budget of an episode (`env.max_acquisitions`, 10), and at a policy step or a
greedy pick per view still a run of minutes, where a count of millions ran for days."""


def check_views(views: int, what: str = "views") -> None:
    """Raise ValueError unless a fixed view count lies in 1..MAX_VIEWS."""
    if not 1 <= views <= MAX_VIEWS:
        raise ValueError(f"{what} must lie in 1..{MAX_VIEWS}, got {views}")


class Planner(abc.ABC):
    """Chooses the views of an episode.

    Attributes:
        name: Its name in `PLANNERS` (`random1`, `hrec`, `uniform`, `nbv`, ...).
        pattern: What may follow `name` in a planner name, a regular expression whose named
            groups are passed to `from_name` (`uniform` takes `(?P<count>[1-9][0-9]*)`:
            `uniform12`); empty: the bare name only.
        usage: The planner name as messages list it (`uniform<k>`); empty: `name`.
        counted: Whether a fixed number of views may be given (`bscp5`, `--views 5`).
        evaluated: The names of it that `vprobot evaluate` runs by default (`uniform4`,
            `uniform5`, `uniform6`); empty: none.

    `pattern`, `usage`, `counted` and `evaluated` are what the registry lists without importing
    a bundled planner (`PLANNERS` declares them); a plugin's are read off its class. A planner
    that derives from nothing more starts its episodes with its own first request, and the runner
    stops it at the coverage goal or the view budget (under `--stop goal`); the small classes
    named in the module's docstring add the rest.
    """

    name: ClassVar[str]
    pattern: ClassVar[str] = ""
    usage: ClassVar[str] = ""
    counted: ClassVar[bool] = False
    evaluated: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        """The planner a name selects: `views` is given only to a `counted` planner, `params`
        are the groups of `pattern` that matched (the default takes neither)."""
        return cls()

    @abc.abstractmethod
    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        """Prepare for a new episode (before its first view); `rng` drives any randomness."""

    @abc.abstractmethod
    def next_view(self, episode: Episode) -> ViewRequest | None:
        """The next view given the episode so far; None when the planner has nothing to add."""


class PlanPlanner(Planner):
    """A planner that computes a whole plan at reset and hands it out in order."""

    def __init__(self) -> None:
        self._queue: list[ViewRequest] = []

    @abc.abstractmethod
    def plan(self, episode: Episode) -> list[ViewRequest]:
        """The whole plan for the episode, in execution order."""

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._queue = list(self.plan(episode))

    def next_view(self, episode: Episode) -> ViewRequest | None:
        return self._queue.pop(0) if self._queue else None


_NBV_PATTERN = r"(?::(?P<gain>\w+))?(?:@(?P<stop>.+))?"

PLANNERS: Registry[type[Planner]] = Registry(
    "planner",
    facts={"pattern": "", "usage": "", "counted": False, "evaluated": ()},
    bundled={
        "agent": Bundled("vprobot.planners.agent:AgentPlanner",
                         pattern=r"(?:~(?P<nearest>[1-9]\d*))?(?::(?P<source>.+))?",
                         usage="agent, agent:NAME, agent:PATH, agent~K", counted=True,
                         evaluated=("agent",)),
        "bscp": Bundled("vprobot.planners.bscp:SetCoverPlanner", counted=True,
                        evaluated=("bscp", "bscp4", "bscp5")),
        "hrec": Bundled("vprobot.planners.hrec:BoxFacesPlanner", evaluated=("hrec",)),
        "nbv": Bundled("vprobot.planners.nbv:VolumetricPlanner", pattern=_NBV_PATTERN,
                       evaluated=("nbv", "nbv@grid")),
        "nbv_camera": Bundled("vprobot.planners.nbv_camera:CameraVolumetricPlanner",
                              pattern=_NBV_PATTERN),
        "optimum": Bundled("vprobot.planners.optimum:OptimumPlanner", counted=True),
        "oracle": Bundled("vprobot.planners.oracle:OraclePlanner", evaluated=("oracle",)),
        "random1": Bundled("vprobot.planners.random_views:Random1Planner",
                           evaluated=("random1",)),
        "random2": Bundled("vprobot.planners.random_views:Random2Planner",
                           evaluated=("random2",)),
        "uniform": Bundled("vprobot.planners.uniform:UniformPlanner",
                           pattern=r"(?P<count>[1-9]\d*)", usage="uniform<k>",
                           evaluated=("uniform4", "uniform5", "uniform6")),
    })
"""Every planner class by name, in name order: the bundled ones (declared here, each a module of
this package; tests/test_registries.py checks this index against the modules) and those of
plugins."""

register_planner = PLANNERS.register_named
"""Class decorator: registers a planner under its `name`."""


def planner_names() -> list[str]:
    """The planners as messages list them, in name order (`uniform<k>` stands for uniform1,
    uniform2, ...: k fixed views); imports no planner."""
    return [PLANNERS.fact(name, "usage") or name for name in PLANNERS]


def counted_planners() -> list[str]:
    """The planners that take a fixed number of views (`bscp5`, `--views 5`)."""
    return [name for name in PLANNERS if PLANNERS.fact(name, "counted")]


def evaluated_planners() -> list[str]:
    """What `vprobot evaluate` runs by default: each planner's `evaluated` names, in the
    planners' name order."""
    return list(dict.fromkeys(default for name in PLANNERS
                              for default in PLANNERS.fact(name, "evaluated")))
