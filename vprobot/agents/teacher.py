"""The teacher of the candidate-view agent: what each candidate would pay, known from the model.

Simulation only, during training: like the `oracle` planner it renders the object's ground truth
from every band candidate of the episode (`vprobot.planners.candidates.candidate_views`, with
the robot: the candidates the IK reaches from the episode's start, others unusable), so it knows
the coverage each candidate would add now, and confirms the best ones by simulated acquisitions
(`CandidateViews.next_best`). The value of a candidate is the reward R2 would pay
for requesting it: that gain, or -1 where it adds nothing or the robot cannot take it. The agent
never sees it at run time; `vprobot.agents.pretrain` fits the Q-network to it before RL.
"""

from __future__ import annotations

import numpy as np

from vprobot.config import ConfigError, EnvConfig
from vprobot.episode import Episode
from vprobot.planners.candidates import BAND_COUNT, CandidateViews, candidate_views

WASTED = -1.0
"""R2's reward for a request that adds nothing (unreachable, or nothing new to see)."""


def check_teacher_reward(env: EnvConfig) -> None:
    """The teacher's values are R2's rewards: refuse another reward.

    Raises:
        ConfigError: Naming the reward and what pretraining needs.
    """
    if env.reward != "R2":
        raise ConfigError(f"agent.pretrain_episodes needs env.reward R2 (the teacher's values "
                          f"are R2's rewards), got env.reward {env.reward!r}")


class CandidateTeacher:
    """Values of the band candidates in the current state of an episode.

    Call `reset` at the start of every episode (the object's pose changes the candidates'
    visibility), then `values` after every step.
    """

    def __init__(self) -> None:
        self._views: CandidateViews | None = None

    def reset(self, episode: Episode) -> None:
        """Render the ground truth from every band candidate of the episode (and, with the
        robot, screen their reachability)."""
        self._views = candidate_views(episode, BAND_COUNT)

    def values(self, episode: Episode) -> np.ndarray:
        """R2's reward (BAND_COUNT,) for requesting each candidate now: the predicted coverage
        gain, `WASTED` where it is zero or the candidate is not usable.

        Raises:
            RuntimeError: Before `reset`.
        """
        if self._views is None:
            raise RuntimeError("call reset() before values()")
        views = self._views
        # Confirms the best candidates by simulated acquisitions, as the oracle does: the
        # renderer's prediction overstates what the sensor covers (by about a tenth).
        views.next_best(episode, taken=set())
        gain = (views.known_visibility() & ~episode.covered).mean(axis=1)
        return np.where(views.usable & (gain > 0.0), gain, WASTED)
