"""Rewards R1-R14 against hand-computed values (docs/states-actions-rewards.md#rewards)."""

from __future__ import annotations

import pytest

from vprobot.env.rewards import Reward

FLOOR = 1e-3


def dense(name: str, delta: float, remaining: float, travel: float,
          reachable: bool = True, penalty: float = 0.0) -> float:
    reward = Reward(name, FLOOR, penalty)
    return reward.step(delta, remaining, travel, reachable, False, False, 0.0, 1, travel).reward


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("R1", 0.2),
        ("R2", 0.2),
        ("R3", 0.2 / 0.5),
        ("R4", 0.2 / 0.5),
        ("R5", 0.2 / 2.0),
        ("R6", 0.2 / 0.5 / 2.0),
        ("R7", 0.2 / 2.0),
        ("R8", 0.2 / 0.5 / 2.0),
    ],
)
def test_dense_rewards_with_gain(name: str, expected: float) -> None:
    assert dense(name, 0.2, 0.5, 2.0) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("name", "expected"), [("R1", 0.0), ("R2", -1.0), ("R3", 0.0), ("R4", -1.0), ("R5", 0.0),
                           ("R6", 0.0), ("R7", -1.0), ("R8", -1.0)]
)
def test_dense_rewards_without_gain(name: str, expected: float) -> None:
    assert dense(name, 0.0, 0.5, 2.0) == pytest.approx(expected)


def test_travel_floor_and_penalty() -> None:
    # A skipped step has k_t = 0: the floor keeps R5 finite.
    assert dense("R5", 0.01, 0.5, 0.0) == pytest.approx(0.01 / FLOOR)
    assert dense("R2", 0.0, 0.5, 0.0, reachable=False, penalty=-0.5) == pytest.approx(-1.5)


def scripted(name: str) -> list[float]:
    """A 3-step episode: coverage 0.5 -> 0.7 -> 0.7 -> 0.92, travels 1.0, 0.0, 2.0."""
    reward = Reward(name, FLOOR)
    coverages, travels = [0.5, 0.7, 0.7, 0.92], [1.0, 0.0, 2.0]
    rewards, travel_sum = [], 0.0
    for step, travel in enumerate(travels, start=1):
        travel_sum += travel
        over = step == len(travels)
        rewards.append(reward.step(coverages[step] - coverages[step - 1], 1 - coverages[step - 1],
                                   travel, True, over, over, coverages[step], step,
                                   travel_sum).reward)
    return rewards


@pytest.mark.parametrize(
    ("name", "final"),
    [
        ("R9", 0.92),
        ("R10", 0.92 / 3),
        ("R11", 0.92 / 3.0),
        ("R12", 0.92 / (3 * 3.0)),
        ("R13", 1 / 3),
        ("R14", 1 / (3 * 3.0)),
    ],
)
def test_sparse_rewards_on_a_scripted_episode(name: str, final: float) -> None:
    assert scripted(name) == pytest.approx([0.0, 0.0, final])


def test_dense_rewards_on_the_scripted_episode() -> None:
    assert scripted("R2") == pytest.approx([0.2, -1.0, 0.22])
    assert scripted("R6") == pytest.approx([0.2 / 0.5 / 1.0, 0.0, 0.22 / 0.3 / 2.0])


def test_goal_only_rewards_pay_nothing_without_the_goal() -> None:
    reward = Reward("R13", FLOOR)
    assert reward.goal_only
    assert reward.step(0.1, 0.5, 1.0, True, True, False, 0.6, 50, 10.0).reward == 0.0


def test_unknown_reward_and_bad_floor() -> None:
    with pytest.raises(ValueError, match=r"unknown reward 'R15'"):
        Reward("R15", FLOOR)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="travel_cost_floor"):
        Reward("R1", 0.0)
