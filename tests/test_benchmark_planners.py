"""The planners suite's timing of the agent: its reachability screening is timed once per
episode and left out of its decision time per view."""

from __future__ import annotations

from vprobot.benchmarks.planners import _timed_screenings
from vprobot.config import Config
from vprobot.env.grid_state import GridState
from vprobot.episode import PartScene, seeded_episode
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.planners.runner import run

CONFIG = Config()


def test_the_agents_screening_is_timed_once_per_episode_within_its_planning() -> None:
    scene = PartScene.load(CONFIG, DEFAULT_MOTOR)
    screening = GridState.screening
    with _timed_screenings() as seconds:
        played = run(CONFIG, scene, "agent", seeded_episode(CONFIG.env, DEFAULT_MOTOR, 0),
                     "robot")
        assert GridState.screening is not screening
    # One screening though the state asks for it at every view, within the planning time.
    assert played.requested >= 3 and len(seconds) == 1
    assert 0.0 < seconds[0] < played.plan_seconds
    assert GridState.screening is screening
