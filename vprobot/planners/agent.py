"""A trained agent as a next-best-view planner (`--planner agent`, `agent:NAME`, `agent:PATH`).

Like the paper's agents it starts from the episode's initial view and chooses one view at a time
from what was acquired so far: the episode's state is built exactly as the env builds it for the
agent's training (`vprobot.env.observations.Observer`), so an `s_cov` agent is handed the
acquired cloud only, and an `s_grid` agent the features of the band candidates from the acquired
frames, never the mesh or the ground truth. It stops at the coverage goal (a simulation can
tell); given `views`, after that many views in all, the initial one included; an agent trained
with `stop_action` decides itself when to stop (a real cell, where coverage is unknown), unless
a stop rule takes charge (`--stop`, `vprobot.stopping.rules`).

Two configurations meet here. The agent's run config (`TrainedAgent.config`) says what the policy
was trained on: its state and action (`env`: `state`, `action`, `stop_action`, `state_scale_m`,
the step limit of its state and the `max_acquisitions` a self-stopping agent keeps to) and how its
views roll (`kinematics.roll`). The run's config gives everything else: the cell and robot the
episode runs in, the goal, the runner's view budget. Where the two must agree, `from_name` checks
it rather than take the agent's silently: the sensor and sensing model (`trained_with`; the
agent's views are taken at its working distance) and, for an `s_grid` agent, the occupancy grid
its state is read from (`GridSettings`: where the cell places an object and the largest it
takes). The agent then reads the episode's own grid, the one the coverage estimate reads too.

`agent~K` (`agent~K:NAME`, `agent~K:PATH`) takes, of a candidate-view agent's K best-scored
allowed candidates, the one the robot reaches with the least joint move from where it is (the
state's `joint_move`; the best-scored first among equals): a cover-fitted agent scores dozens of
candidates about equally (a state has about 30 of some smallest cover), and of those the nearest
costs the least cycle time.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from vprobot.config import Config
from vprobot.coverage.occupancy import GridSettings
from vprobot.env.actions import ActionMapping
from vprobot.env.grid_state import FEATURES
from vprobot.env.observations import Observer
from vprobot.episode import Episode, ViewRequest
from vprobot.files.progress import note
from vprobot.planners.base import Planner, check_views, register_planner
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.self_stopping import LearnedStop


@register_planner
class AgentPlanner(InitialViewPlanner, LearnedStop):
    """Plans with a trained policy (deterministic).

    Args:
        source: A bundled agent's name, a run directory, a model .zip in a run, or None for
            the default bundled agent.
        views: Stop after this many views in all (None: at the goal or the view budget).
        nearest: Of this many best-scored allowed candidates, take the one with the least
            joint move (`agent~K`; None: the best-scored); a candidate-view agent's only.

    Raises:
        ValueError: If views is not in 1..MAX_VIEWS, the agent cannot be loaded, or `nearest`
            is given for an agent that does not choose among candidate views.
    """

    name = "agent"
    pattern = r"(?:~(?P<nearest>[1-9]\d*))?(?::(?P<source>.+))?"
    usage = "agent, agent:NAME, agent:PATH, agent~K"
    counted = True
    evaluated = ("agent",)

    def __init__(self, source: str | Path | None = None, views: int | None = None,
                 nearest: int | None = None):
        if views is not None:
            check_views(views)
        note(f"loading agent {source or 'generalist (bundled)'} ...")
        # Imported here: the agent needs torch and stable-baselines3, the other planners do not.
        from vprobot.agents.trained import load_agent

        self.agent = load_agent(source)
        config = self.agent.config
        self.mapping = ActionMapping(config.env, config.sensor.working_distance_m)
        # The planner's episodes acquire at the sensor's own resolution, not at the coarser one
        # the agent may have trained at (`env.resolution`).
        self.observer = Observer(config)
        self.roll_free = config.kinematics.roll == "free"
        self.views = views
        self.decides_stop = config.env.stop_action
        self.stops_at_goal = views is None and not self.decides_stop
        self._rng = np.random.default_rng(0)
        if nearest is not None and config.env.action != "A_view":
            raise ValueError(f"agent~{nearest} takes the nearest of an agent's best-scored "
                             f"candidate views; agent {source or 'generalist (bundled)'} acts "
                             f"with env.action {config.env.action}, not A_view")
        self.nearest = nearest

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        """The agent of `agent:NAME` or `agent:PATH`, or the bundled one trained with the run's
        sensor (`agent`: `vprobot.agents.trained.default_agent`).

        Raises:
            ValueError: If `config`'s sensor or sensing model is not the one the agent was
                trained with (its observations are built from that sensor's frames, and what
                a view measures decides what it learned to request), or, for an `s_grid`
                agent, its cell gives another grid than the agent's cell.
        """
        # Imported here, as in `__init__`: the agent needs torch and stable-baselines3.
        from vprobot.agents.trained import default_agent, describe_sensor, trained_with

        source = params.get("source") or default_agent(config.sensor)
        nearest = params.get("nearest")
        planner = cls(source, views, None if nearest is None else int(nearest))
        trained = planner.agent.config.sensor
        if not trained_with(trained, config.sensor):
            raise ValueError(f"agent {source} was trained with the sensor "
                             f"{describe_sensor(trained)} and plans only with it; this run's "
                             f"sensor is {describe_sensor(config.sensor)}")
        grid_state, given = planner.observer.grid_state, GridSettings.of(config)
        if grid_state is not None and grid_state.settings != given:
            raise ValueError(
                f"agent {source} reads the occupancy grid of the cell it was trained in, "
                f"{_describe_grid(grid_state.settings)}; this run's cell gives "
                f"{_describe_grid(given)} (cell.object_center_m and the robot's placement "
                f"decide it)")
        return planner

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._rng = rng
        self.observer.reset()
        self.stop_reason = None

    def next_view(self, episode: Episode) -> ViewRequest | None:
        env = self.agent.config.env
        if self.views is not None and len(episode.views) >= self.views:
            return None
        if self.decides_stop and len(episode.views) > env.max_acquisitions:
            self.stop_reason = "max views"
            return None
        observation = self.observer.observe(episode, self._rng)
        with one_thread():
            action = (self.agent.model.predict(observation, deterministic=True)[0]
                      if self.nearest is None else np.array(self.nearest_of_best(observation)))
        if self.decides_stop and self.views is None and self.mapping.stops(action):
            self.stop_reason = "stop action"
            return None
        return self.observer.request(self.mapping, action, episode.center, self.roll_free)

    def nearest_of_best(self, observation: dict[str, np.ndarray]) -> int:
        """Of the `nearest` best-scored allowed candidates, the one with the least joint move
        (the best-scored first among equals)."""
        # Imported here, as in `__init__`: torch comes with the agent.
        import torch

        from vprobot.agents.candidate_q import CANDIDATES_KEY, CandidateQNetwork

        q_net = self.agent.model.policy.q_net
        assert isinstance(q_net, CandidateQNetwork)  # an A_view agent's (checked in __init__)
        with torch.no_grad():
            scores = q_net({key: torch.as_tensor(value)[None]
                            for key, value in observation.items()})[0]
        # Masked candidates score MASKED_Q, below every allowed one.
        best = np.argsort(-scores.numpy(), kind="stable")[:self.nearest]
        moves = observation[CANDIDATES_KEY][best, FEATURES.index("joint_move")]
        return int(best[np.argmin(moves)])


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """Torch on one thread inside: a decision is a few small products, which one thread does in
    about a millisecond, while handing them to two costs more than the work (several times more
    where another process holds the other core); evaluation workers run one thread anyway."""
    # Imported here, as in `__init__`: torch comes with the agent.
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _describe_grid(settings: GridSettings) -> str:
    """Where a grid stands, as the agent's messages name it."""
    center = ", ".join(f"{value:g}" for value in settings.center)
    return f"a cube about ({center}) m with a half edge of {settings.half_size_m:.3f} m"
