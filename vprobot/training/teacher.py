"""The teacher of the candidate-view agent: what each candidate would pay, known from the model.

Simulation only, during training: like the `oracle` planner it renders the object's ground truth
from every band candidate of the episode (`vprobot.planners.candidates.candidate_views`, with
the robot: the candidates the IK reaches from the episode's start, others unusable), so it knows
the coverage each candidate would add now, and confirms the best ones by simulated acquisitions
(`CandidateViews.next_best`). The value of a candidate is the reward R2 pays for requesting it:
that gain, or -1 where the robot cannot take it. (R2 also pays -1 for a view that adds nothing;
the values keep 0 there, so that they stay continuous in what a view sees: a candidate that
would add 0.1 % and one that adds nothing look alike and differ by a thousandth, not by one.)
The agent never sees them at run time; `vprobot.training.pretrain` fits the Q-network to them
before RL.

The teacher also labels each state with its *remaining cover* (`CandidateTeacher.remaining_cover`),
as MA-SCVP does: the fewest candidates that bring the part from its coverage now to the goal
within the views left, a set cover (`vprobot.planners.optimum.solve_cover`) over what each
usable candidate measures (every one confirmed by a simulated acquisition, once an episode:
what a candidate measures does not depend on the state; on a copy of the candidates of its own,
so that the values stay what the teacher alone knows). Where 3 or fewer candidates reach the
goal the label is exact (every pair and triple counted); beyond, it is greedy's solution made
smaller (`swap_down`), and the count proves no 3 reach it: HiGHS's exact program costs up to a
minute a state here (its root alone), thousands of states a teacher. Where no set reaches the
goal within the views left, the candidates greedy finds adding the most. A policy that scores
membership in it learns where the rest of the plan lies, not only the next view. Beside it, each
candidate's *views to the goal* when taken next (`CandidateTeacher.views_to_goal`): exact up to
3, greedy's count beyond; the candidates where it is least are those of some smallest cover
(there are often many), and that least is the number of views left.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vprobot.config import ConfigError, EnvConfig
from vprobot.episode import Episode
from vprobot.episode.views import BAND_COUNT
from vprobot.planners.candidates import CandidateViews, candidate_views
from vprobot.planners.optimum import Cover, solve_cover, views_to_goal

WASTED = -1.0
"""R2's reward for a request that adds nothing: here, one the robot cannot take."""


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
        self._labels: CandidateViews | None = None
        self._rows: np.ndarray | None = None

    def reset(self, episode: Episode,
              screened: tuple[np.ndarray, Sequence[str | None]] | None = None) -> None:
        """Render the ground truth from every band candidate of the episode (and, with the
        robot, screen their reachability, unless `screened` holds the episode's screening:
        the `s_grid` state's, `GridState.screening`)."""
        self._views = candidate_views(episode, BAND_COUNT, screened=screened)
        # The labels measure every candidate on a copy of their own (the acquisitions shared):
        # the values go on knowing only the candidates they confirmed themselves.
        self._labels = self._views.own_copy()
        self._rows = None

    def values(self, episode: Episode) -> np.ndarray:
        """The value (BAND_COUNT,) of requesting each candidate now: the coverage it adds (the
        best candidates' confirmed), `WASTED` where the robot cannot take it.

        Raises:
            RuntimeError: Before `reset`.
        """
        views = _reset_before(self._views)
        # Confirms the best candidates by simulated acquisitions, as the oracle does: the
        # renderer's prediction overstates what the sensor covers (by about a tenth).
        views.next_best(episode, taken=set())
        gain = (views.known_visibility() & ~episode.covered).mean(axis=1)
        return np.where(views.usable, gain, WASTED)

    def remaining_cover(self, episode: Episode, goal: float, views_left: int) -> Cover:
        """The fewest candidates that bring the episode's coverage to `goal` with at most
        `views_left` views, or without such a set the `views_left` that add the most: the set
        cover over what every usable candidate measures (its `picks`, candidate indices; exact
        where it takes 3 or fewer, see the module docstring; `proven` says where).

        Raises:
            RuntimeError: Before `reset`.
        """
        return solve_cover(self._measured_rows(episode), episode.covered, views_left, goal,
                           node_limit=0)

    def views_to_goal(self, episode: Episode, goal: float, cover: Cover) -> np.ndarray:
        """The views to the goal (BAND_COUNT,) when each candidate is taken next
        (`optimum.views_to_goal` over what every usable candidate measures; inf where the
        robot cannot take it or the goal is out of reach), no more than the size of the state's
        remaining `cover` for its members where it reaches the goal.

        Raises:
            RuntimeError: Before `reset`.
        """
        labels = _reset_before(self._labels)
        views = views_to_goal(self._measured_rows(episode), episode.covered, goal, labels.usable)
        if cover.goal_reached:
            picks = list(cover.picks)
            views[picks] = np.minimum(views[picks], len(picks))
        return views

    def _measured_rows(self, episode: Episode) -> np.ndarray:
        """What every candidate measures (its row of the labels' copy), acquired once an
        episode: what a candidate measures does not depend on the state."""
        labels = _reset_before(self._labels)
        if self._rows is None:
            for index in np.flatnonzero(labels.usable):
                labels.measured(int(index), episode)
            self._rows = labels.known_visibility()
        return self._rows


def _reset_before(views: CandidateViews | None) -> CandidateViews:
    """The teacher's candidates, set by `reset`.

    Raises:
        RuntimeError: Before `reset`.
    """
    if views is None:
        raise RuntimeError("call reset() before asking the teacher")
    return views
