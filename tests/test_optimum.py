"""The optimum planner: its set-cover program against brute force, against greedy, the exact
cycle order, and the planner end to end."""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from vprobot.cli import main
from vprobot.config import Config
from vprobot.episode import Episode, MotorScene, ViewRequest, episode_cycle, seeded_episode
from vprobot.paths import DEFAULT_MOTOR
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.candidates import candidate_views
from vprobot.planners.greedy import greedy_cover
from vprobot.planners.optimum import (
    OptimumPlanner,
    fewest_views,
    reduce_cover,
    solve_cover,
    swap_down,
)
from vprobot.planners.ordering import cycle_order, path_cost, shortest_cycle
from vprobot.planners.runner import make_planner, parse_planner, run_episode

CONFIG = Config()
RESOLUTION = (107, 75)
CANDIDATES = 200


def random_instance(rng: np.random.Generator, candidates: int, points: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """A visibility matrix with rows of varied density and a few points covered already."""
    visibility = rng.random((candidates, points)) < rng.uniform(0.05, 0.5, size=(candidates, 1))
    return visibility, rng.random(points) < rng.uniform(0.0, 0.3)


def covered_by(visibility: np.ndarray, covered: np.ndarray, rows: tuple[int, ...]) -> int:
    return int((covered | visibility[list(rows)].any(axis=0)).sum())


@pytest.mark.parametrize("seed", range(4))
def test_the_fewest_views_to_the_goal_match_every_subset(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(25):
        candidates = int(rng.integers(1, 13))
        visibility, covered = random_instance(rng, candidates, int(rng.integers(5, 80)))
        goal, count = rng.uniform(0.3, 1.0), int(rng.integers(1, candidates + 1))
        needed = math.ceil(goal * len(covered) - 1e-9)
        subsets = [rows for size in range(count + 1)
                   for rows in itertools.combinations(range(candidates), size)]
        reaching = [rows for rows in subsets if covered_by(visibility, covered, rows) >= needed]
        cover = solve_cover(visibility, covered, count, goal)
        assert cover.proven and len(cover.picks) <= count
        assert cover.points == covered_by(visibility, covered, cover.picks) - covered.sum()
        if reaching:
            assert cover.goal_reached and len(cover.picks) == min(map(len, reaching))
            assert cover.views_bound == len(cover.picks)
        else:
            # No `count` views reach the goal: the most coverage with `count` views.
            assert not cover.goal_reached
            assert cover.points + covered.sum() == max(
                covered_by(visibility, covered, rows) for rows in subsets)


@pytest.mark.parametrize("seed", range(4))
def test_the_most_coverage_with_n_views_matches_every_subset(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    for _ in range(25):
        candidates = int(rng.integers(1, 13))
        visibility, covered = random_instance(rng, candidates, int(rng.integers(5, 80)))
        count = int(rng.integers(1, candidates + 1))
        best = max(covered_by(visibility, covered, rows)
                   for rows in itertools.combinations(range(candidates), count))
        cover = solve_cover(visibility, covered, count)
        assert cover.proven and len(cover.picks) <= count
        assert covered_by(visibility, covered, cover.picks) == best
        assert cover.points_bound == best - covered.sum()


@pytest.mark.parametrize("seed", range(4))
def test_up_to_three_views_are_found_by_counting_and_more_are_bounded(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    for _ in range(40):
        candidates = int(rng.integers(3, 13))
        visibility, covered = random_instance(rng, candidates, int(rng.integers(20, 80)))
        needed = int(rng.integers(1, (~covered).sum() + 1))
        fewest = next((size for size in range(candidates + 1)
                       for rows in itertools.combinations(range(candidates), size)
                       if covered_by(visibility, covered, rows) - covered.sum() >= needed), None)
        found, bound = fewest_views(reduce_cover(visibility, covered), needed)
        if fewest is not None and fewest <= 3:
            assert found is not None and len(found) == bound == fewest
            assert covered_by(visibility, covered, tuple(found)) - covered.sum() >= needed
        else:
            assert found is None and bound <= (fewest or candidates + 1)


def test_the_reduction_drops_dominated_views_and_merges_points() -> None:
    visibility = np.array([[1, 1, 0, 0, 0],   # inside row 1: dominated
                           [1, 1, 1, 0, 0],
                           [0, 0, 1, 1, 1],
                           [0, 0, 1, 1, 1],   # the same as row 2: the first is kept
                           [0, 0, 0, 0, 0]], dtype=bool)
    reduced = reduce_cover(visibility, np.array([False, False, False, False, True]))
    assert reduced.rows.tolist() == [1, 2]
    # Points 0 and 1 are seen by the same views, point 3 stands alone, point 4 is covered.
    assert sorted(reduced.weights.tolist()) == [1.0, 1.0, 2.0]
    assert reduced.matrix.shape == (2, 3)


@pytest.mark.parametrize("seed", range(3))
def test_the_optimum_never_needs_more_views_than_greedy(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    visibility, covered = random_instance(rng, 40, 300)
    for goal in (0.8, 0.95):
        picks, _ = greedy_cover(visibility, covered, 40, goal)
        cover = solve_cover(visibility, covered, 40, goal, time_limit_s=1.0)
        assert cover.goal_reached and len(cover.picks) <= len(picks)
    for count in (2, 4):
        picks, _ = greedy_cover(visibility, covered, count)
        cover = solve_cover(visibility, covered, count, time_limit_s=1.0)
        assert covered_by(visibility, covered, cover.picks) >= covered_by(visibility, covered,
                                                                          tuple(picks))


def test_swapping_two_views_for_one_undoes_greedys_classic_mistake() -> None:
    # Greedy takes the middle row (6 points), then needs both halves' rest: 3 rows; the two
    # halves alone cover all 10.
    visibility = np.zeros((3, 10), dtype=bool)
    visibility[0, :5] = visibility[1, 5:] = True
    visibility[2, 2:8] = True
    covered = np.zeros(10, dtype=bool)
    picks, _ = greedy_cover(visibility, covered, 3, 1.0)
    assert sorted(picks) == [0, 1, 2]
    assert sorted(swap_down(visibility, covered, 10, picks)) == [0, 1]
    # Short of the goal, the picks stay as they are.
    assert swap_down(visibility, covered, 10, [2]) == [2]


@pytest.mark.parametrize("seed", range(3))
def test_swapped_picks_still_reach_the_goal_with_no_more_rows(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    for _ in range(20):
        visibility, covered = random_instance(rng, int(rng.integers(3, 30)), 120)
        needed = math.ceil(rng.uniform(0.5, 0.95) * len(covered)) - int(covered.sum())
        picks, _ = greedy_cover(visibility, covered, len(visibility),
                                (needed + covered.sum()) / len(covered))
        swapped = swap_down(visibility, covered, needed, picks)
        assert len(swapped) <= len(picks) and len(set(swapped)) == len(swapped)
        if covered_by(visibility, covered, tuple(picks)) - covered.sum() >= needed:
            assert covered_by(visibility, covered, tuple(swapped)) - covered.sum() >= needed


def test_a_time_limit_keeps_the_incumbent_and_states_the_gap() -> None:
    rng = np.random.default_rng(7)
    visibility, covered = random_instance(rng, 300, 1000)
    picks, _ = greedy_cover(visibility, covered, 300, 0.99)
    cover = solve_cover(visibility, covered, 300, 0.99, time_limit_s=0.01, incumbent=picks)
    assert cover.goal_reached and len(cover.picks) <= len(picks)
    assert cover.views_bound is not None and 1 <= cover.views_bound <= len(cover.picks)
    assert cover.proven == (cover.views_bound == len(cover.picks))


def test_the_optimum_on_a_motor_needs_no_more_views_than_bscp() -> None:
    scene = MotorScene.load(CONFIG, DEFAULT_MOTOR, resolution=RESOLUTION)
    spec = seeded_episode(CONFIG.env, scene.mesh.path, 4, scene.mesh.scale)
    episode = Episode.from_spec(scene, spec, "free")
    visibility = candidate_views(episode, CANDIDATES, RESOLUTION).visibility
    for goal in (0.9, 0.97):
        picks, _ = greedy_cover(visibility, episode.covered, 10, goal)
        cover = solve_cover(visibility, episode.covered, 10, goal, time_limit_s=10.0)
        assert cover.goal_reached and len(cover.picks) <= len(picks)


@pytest.mark.parametrize("nodes", range(1, 8))
def test_the_cycle_order_is_the_shortest_of_every_order(nodes: int) -> None:
    rng = np.random.default_rng(nodes)
    cost = rng.uniform(0.0, 1.0, size=(nodes, nodes))  # asymmetric

    def cycle(order: tuple[int, ...]) -> float:
        return path_cost(cost, 0, [*order, 0])

    order = shortest_cycle(cost)
    assert sorted(order) == list(range(1, nodes))
    assert cycle(tuple(order)) == pytest.approx(
        min(cycle(order) for order in itertools.permutations(range(1, nodes))), abs=1e-12)


def test_the_cycle_order_gives_the_shortest_executed_cycle() -> None:
    scene = MotorScene.load(CONFIG, DEFAULT_MOTOR, resolution=RESOLUTION)
    spec = seeded_episode(CONFIG.env, scene.mesh.path, 2, scene.mesh.scale)
    candidates = candidate_views(Episode.from_spec(scene, spec, "robot"), CANDIDATES, RESOLUTION)
    usable = np.flatnonzero(candidates.usable)
    # Four views spread over the candidates, given in a zigzag (their best cycle is shorter).
    spread = usable[np.linspace(0, len(usable) - 1, 4, dtype=int)]
    requests = [candidates.request(i) for i in spread[[0, 2, 1, 3]]]

    def executed_cycle(order: Sequence[ViewRequest]) -> float:
        episode = Episode.from_spec(scene, spec, "robot")
        for request in order:
            episode.request(request)
        cycle = episode_cycle(episode.record(), scene.cell)
        assert cycle is not None
        return cycle.total_s

    exact = executed_cycle(cycle_order(Episode.from_spec(scene, spec, "robot"), requests))
    assert exact == pytest.approx(min(map(executed_cycle, itertools.permutations(requests))),
                                  abs=1e-9)


@pytest.mark.parametrize("views", [None, 3])
def test_the_optimum_with_the_robot_confirms_its_views_and_needs_no_more_than_bscp(
        views: int | None) -> None:
    scene = MotorScene.load(CONFIG, DEFAULT_MOTOR, resolution=RESOLUTION)
    spec = seeded_episode(CONFIG.env, scene.mesh.path, 1, scene.mesh.scale)
    optimum = OptimumPlanner(views, candidate_count=CANDIDATES, resolution=RESOLUTION,
                             time_limit_s=5.0)
    bscp = SetCoverPlanner(views, candidate_count=CANDIDATES, resolution=RESOLUTION)
    records = {}
    for planner in (optimum, bscp):
        episode = Episode.from_spec(scene, spec, "robot")
        records[planner.name] = run_episode(planner, episode, spec, CONFIG,
                                            np.random.default_rng(1)).record
    record = records["optimum"]
    # B_SCP's picks, the same candidates confirmed the same way, are the incumbent.
    assert optimum.greedy_picks == bscp.picks
    assert len(optimum.picks) <= len(bscp.picks)
    # Its picks were measured: the executed views add what the plan says they add.
    assert sum(optimum.gains) == pytest.approx(record.coverage * 2048, abs=2)
    assert all(view.reachable for view in record.views)
    if views is None:
        assert record.coverage >= CONFIG.env.coverage_goal
        assert len(record.views) <= len(records["bscp"].views)
        # Unproven in 5 s here: the gap is what the bound leaves.
        proof = optimum.proof
        assert proof.gap_views == len(optimum.picks) - proof.bound >= 0
        assert proof.proven == (proof.gap_views == 0)
    else:
        assert len(record.views) == views
        assert record.coverage >= records["bscp"].coverage - 1e-12


def test_optimum_n_names_the_most_coverage_with_n_views() -> None:
    assert parse_planner("optimum4") == ("optimum", 4)
    planner = make_planner("optimum", CONFIG, views=4)
    assert isinstance(planner, OptimumPlanner) and planner.views == 4
    with pytest.raises(ValueError, match="time_limit_s must be > 0 s, got 0"):
        OptimumPlanner(time_limit_s=0.0)


def test_plan_with_the_optimum_writes_json_video_and_replays(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    # The planner as `--planner optimum` builds it, on fewer candidates at a coarser grid.
    original = OptimumPlanner.__init__

    def small(self: OptimumPlanner, *args: object, **kwargs: object) -> None:
        original(self, *args, **{"candidate_count": CANDIDATES, "resolution": RESOLUTION,
                                 **kwargs})

    monkeypatch.setattr(OptimumPlanner, "__init__", small)
    plan, video = tmp_path / "plan.json", tmp_path / "replay.gif"
    assert main(["plan", "--planner", "optimum", "--out", str(plan)]) == 0
    assert "goal 90% reached" in capsys.readouterr().out
    document = json.loads(plan.read_text())
    assert document["coverage"] >= 0.9 and all(view["reachable"] for view in document["views"])
    assert main(["render", "--plan", str(plan), "--out", str(video), "--width", "96",
                 "--height", "72"]) == 0
    assert video.stat().st_size > 0
    assert main(["check", str(plan)]) == 0
