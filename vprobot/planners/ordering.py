"""Order the views of a plan to keep travel short: nearest neighbour, then 2-opt.

The views form an open path from a fixed start (the robot's current configuration). The cost
matrix is any travel cost between nodes, e.g. `joint_time` between configurations; it need not
be symmetric, because every move is scored on the whole path. A plan has a handful of views, so
the O(n^3) passes of 2-opt are instantaneous. 2-opt starts from the cheaper of the given order
and the nearest-neighbour order and only accepts improvements: the result is never longer than
the order it was given.

`cycle_order` orders a plan for the least cycle time instead: the moves are timed along their
collision-free planned paths and the cycle closes at the start, and up to `EXACT_ORDER_VIEWS`
views the order is exact (`shortest_cycle`, Held-Karp).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from typing import TypeVar

import numpy as np

from vprobot.episode import Episode, ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.kinematics.travel import joint_time, paper_travel

T = TypeVar("T")
BLOCKED_PATH_S = 1000.0
"""Extra cost of a move without a collision-free path (`RobotCarrier.path_is_free`): any order
avoiding such moves is preferred."""
EXACT_ORDER_VIEWS = 10
"""Most views `cycle_order` orders exactly: Held-Karp takes 2^n n^2 steps, a fraction of a second
for 10 views."""


class LazyCosts:
    """A square matrix of move costs whose entries are computed when first read.

    `order_views` reads about half of a plan's moves (the greedy order's forward moves and the
    reversals 2-opt tries), and with the robot each entry is a planned move, so the others are
    not planned.

    Args:
        size: Nodes of the matrix.
        cost: The cost of the move between two node indices.
    """

    def __init__(self, size: int, cost: Callable[[int, int], float]):
        self.shape = (size, size)
        self._cost = cost
        self._known: dict[tuple[int, int], float] = {}

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, move: tuple[int, int]) -> float:
        if move not in self._known:
            self._known[move] = self._cost(*move)
        return self._known[move]


Costs = np.ndarray | LazyCosts
"""A square matrix of move costs, computed (an array) or computed as read (`LazyCosts`)."""


def path_cost(cost: Costs, start: int | None, order: Sequence[int]) -> float:
    """Total cost of visiting `order` after `start` (None: the path begins at order[0])."""
    nodes = ([start] if start is not None else []) + list(order)
    return float(sum(cost[a, b] for a, b in itertools.pairwise(nodes)))


def nearest_neighbour(cost: Costs, start: int | None, nodes: Sequence[int]) -> list[int]:
    """Greedy order: always move to the cheapest unvisited node (from nodes[0] without start)."""
    remaining = list(nodes)
    order: list[int] = []
    current = start
    while remaining:
        here = current
        pick = remaining[0] if here is None else min(remaining, key=lambda n: cost[here, n])
        remaining.remove(pick)
        order.append(pick)
        current = pick
    return order


def two_opt(cost: Costs, start: int | None, order: Sequence[int]) -> list[int]:
    """Reverse segments of the path while that shortens it (first improvement)."""
    best = list(order)
    best_cost = path_cost(cost, start, best)
    improved = True
    while improved:
        improved = False
        for i in range(len(best) - 1):
            for j in range(i + 1, len(best)):
                candidate = best[:i] + best[i:j + 1][::-1] + best[j + 1:]
                candidate_cost = path_cost(cost, start, candidate)
                if candidate_cost < best_cost - 1e-12:
                    best, best_cost, improved = candidate, candidate_cost, True
    return best


def order_views(cost: Costs, start: int | None, nodes: Sequence[int]) -> list[int]:
    """A short visiting order of `nodes` from `start`, never costlier than `nodes` as given.

    Args:
        cost: Square matrix of move costs between all node indices (`LazyCosts`: only those
            read are computed).
        start: The fixed first node (not part of the result), or None for a free start.
        nodes: The nodes to visit, in their given order.

    Raises:
        ValueError: If the matrix is not square or an index is outside it.
    """
    if not isinstance(cost, LazyCosts):
        cost = np.asarray(cost, dtype=float)
        if cost.ndim != 2 or cost.shape[0] != cost.shape[1]:
            raise ValueError(f"cost must be a square matrix, got shape {cost.shape}")
    indices = list(nodes) + ([start] if start is not None else [])
    if any(not 0 <= index < len(cost) for index in indices):
        raise ValueError(f"node indices must lie in 0..{len(cost) - 1}, got {indices}")
    given = list(nodes)
    greedy = nearest_neighbour(cost, start, given)
    initial = min((given, greedy), key=lambda order: path_cost(cost, start, order))
    return two_opt(cost, start, initial)


def shortest_cycle(cost: np.ndarray) -> list[int]:
    """The order of nodes 1..n-1 of the least total cost from node 0 back to node 0, exact by
    Held-Karp dynamic programming over the subsets (keep n-1 small: 2^(n-1) (n-1)^2 steps).

    Raises:
        ValueError: If the matrix is not square or is empty.
    """
    cost = np.asarray(cost, dtype=float)
    if cost.ndim != 2 or cost.shape[0] != cost.shape[1] or len(cost) == 0:
        raise ValueError(f"cost must be a non-empty square matrix, got shape {cost.shape}")
    n = len(cost) - 1
    # best[mask, j]: the cheapest path from node 0 through the nodes of mask ending at node j+1.
    best = np.full((1 << n, n), np.inf)
    came_from = np.zeros((1 << n, n), dtype=int)
    for j in range(n):
        best[1 << j, j] = cost[0, j + 1]
    for mask in range(1, 1 << n):
        for j in (j for j in range(n) if mask >> j & 1):
            for k in (k for k in range(n) if not mask >> k & 1):
                value = best[mask, j] + cost[j + 1, k + 1]
                if value < best[mask | 1 << k, k]:
                    best[mask | 1 << k, k] = value
                    came_from[mask | 1 << k, k] = j
    order: list[int] = []
    mask = (1 << n) - 1
    last = int(np.argmin(best[mask] + cost[1:, 0])) if n else -1
    while mask:
        order.append(last + 1)
        mask, last = mask & ~(1 << last), came_from[mask, last]
    return order[::-1]


def cost_matrix(items: Sequence[T], cost: Callable[[T, T], float]) -> np.ndarray:
    """The cost of every move between two items, (n, n)."""
    return np.array([[cost(a, b) for b in items] for a in items], dtype=float).reshape(
        len(items), len(items))


def order_requests(episode: Episode, requests: Sequence[ViewRequest]) -> list[ViewRequest]:
    """Order a plan's views for short travel from the episode's current state.

    With the robot, views with known configurations are ordered by straight-line `joint_time`
    from the current configuration, a move without a collision-free path costing
    `BLOCKED_PATH_S` more (executing it falls back to the IK); views without a configuration
    (the IK will be asked when they are executed) follow in their given order. Without the
    robot, views are ordered by the paper's travel approximation (arcs about the object's
    centre) from a free start.
    """
    if episode.uses_robot:
        known: list[ViewRequest] = []
        nodes = [episode.q]
        for request in requests:
            if request.joints is not None:
                known.append(request)
                nodes.append(request.joints)
        unknown = [request for request in requests if request.joints is None]
        velocity = episode.scene.arm.joints.velocity_limits

        def move(a: np.ndarray, b: np.ndarray) -> float:
            blocked = 0.0 if episode.robot.path_is_free(a, b) else BLOCKED_PATH_S
            return joint_time(a, b, velocity) + blocked

        # Planned as the ordering reads them: none back to the current configuration or in
        # place, and of the others about half.
        moves = LazyCosts(len(nodes), lambda a, b: move(nodes[a], nodes[b]))
        order = order_views(moves, 0, range(1, len(known) + 1))
        return [known[index - 1] for index in order] + unknown
    center = episode.center
    costs = cost_matrix([request.target.pose.position for request in requests],
                        lambda a, b: paper_travel(a, b, center))
    return [requests[index] for index in order_views(costs, None, range(len(requests)))]


def cycle_order(episode: Episode, requests: Sequence[ViewRequest]) -> list[ViewRequest]:
    """Order a plan's views for the least cycle time from the episode's current configuration
    back to its start.

    With the robot, a move costs its duration (`RobotArm.move_time`) along the collision-free
    path the carrier plans for it (the one executing it drives: a planned path depends on its
    ends and their order), a move without a path `BLOCKED_PATH_S`; the acquisitions take the
    same time in every order. Up to
    `EXACT_ORDER_VIEWS` views with known configurations the order is exact (`shortest_cycle`),
    more fall back to `order_requests`, as does a plan without the robot (no cycle time) or
    with views of unknown configuration.
    """
    joints = [request.joints for request in requests if request.joints is not None]
    if (not episode.uses_robot or len(requests) > EXACT_ORDER_VIEWS
            or len(joints) < len(requests)):
        return order_requests(episode, requests)
    nodes = [episode.q, *joints, episode.start_joints]
    arm = episode.scene.arm
    cost = np.zeros((len(nodes), len(nodes)))
    for a, b in itertools.permutations(range(len(nodes)), 2):
        motion = episode.robot.plan(nodes[a], nodes[b])
        cost[a, b] = BLOCKED_PATH_S if motion is None else arm.move_time(motion.waypoints)
    # The cycle runs from the current configuration through the views to the start: a closed
    # tour of node 0 whose last leg, to the start, is charged on the way back to node 0.
    cost[1:-1, 0] = cost[1:-1, -1]
    order = shortest_cycle(cost[:-1, :-1])
    return [requests[index - 1] for index in order]


def fixed_plan(episode: Episode, targets: Sequence[SensorTarget],
               seeds: Sequence[np.ndarray] | np.ndarray | None = None) -> list[ViewRequest]:
    """The requests of fixed targets in a short travel order (`order_requests`).

    With the robot, each target is first reached, the IK starting from its seed configuration
    (e.g. one known to reach it around the cell's object envelope) or else from the current
    one; a target the IK misses keeps no configuration, so it comes last and executing it asks
    the IK once more from wherever the robot then is.
    """
    if not episode.uses_robot:
        return order_requests(episode, [ViewRequest(target) for target in targets])
    requests = []
    for index, target in enumerate(targets):
        start = seeds[index] if seeds is not None else episode.q
        result = episode.robot.reach(target, start)
        requests.append(ViewRequest(target, result.q if result.reachable else None))
    return order_requests(episode, requests)
