"""`optimum`: the fewest candidate views that reach the coverage goal, an exact set cover.

B_SCP's greedy is near the floor but not on it. The optimum solves the set-cover program over the
same candidates (`candidates.candidate_views`: the robot's reachability, visibility following the
sensing model) with HiGHS (`scipy.optimize.milp`):

    minimise sum_j x_j  subject to  sum_i y_i >= needed,  y_i <= sum_{j sees i} x_j,
    x_j in {0, 1},  0 <= y_i <= 1,

x_j taking candidate j and y_i covering GT point i (`needed`: the goal's points not yet covered);
`optimum<N>` maximises sum_i y_i with sum_j x_j <= N instead. The y need not be integer: with
integer x, y_i = 1 exactly where a taken candidate sees point i. Before solving, the instance is
reduced (`reduce_cover`): points already covered or seen by no candidate are dropped, points seen
by the same candidates merge into one weighted y, and a candidate whose points another one sees
too (dominated) is dropped. When 3 or fewer views reach the goal, they are found by counting
pairs and triples (`fewest_views`), which also proves when 4 are needed. Greedy's solution
(B_SCP's picks), made smaller where one candidate stands in for two of its views or two for
three (`swap_down`), is the incumbent: the program is bounded by it (no more views, or no fewer
points) and is only taken when it does better, so the optimum never needs more views than
B_SCP.
HiGHS stops after `node_limit` branch-and-bound nodes (a count of work, so the plan and its
proof are the same on every machine and under any load); the planner then keeps the best
solution found and records the proven gap. `time_limit_s` is a wall-clock safety net only, for a
much slower machine: a plan it cuts short states no proof (`OptimumPlanner.proof` is None, with a
warning), since what it would prove depends on the clock.

The visibility is predicted, so the chosen views are confirmed by simulated acquisitions as B_SCP
confirms its picks: the program is solved again on the rows measured so far until every view it
chooses was measured before the solve (its answer then holds for what the views measure); after
`PREDICTED_ROUNDS` solves every usable candidate is measured and the program solved once more,
on what every candidate measures. The views are ordered for the least cycle time
(`ordering.cycle_order`); when the executed plan falls short of the goal, the planner adds
B_SCP's next view as B_SCP does.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
import warnings
from collections.abc import Callable, Sequence

import numpy as np
from scipy import optimize, sparse

from vprobot.episode import Episode, ViewRequest
from vprobot.planners.base import register_planner
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.candidates import (
    CANDIDATE_COUNT,
    CONFIRMATIONS_PER_PICK,
    candidate_views,
)
from vprobot.planners.greedy import cover_input, greedy_cover
from vprobot.planners.ordering import cycle_order
from vprobot.planners.proof import ExactPlanner, Proof
from vprobot.planners.visibility import DEFAULT_RESOLUTION

NODE_LIMIT = 100
"""HiGHS's branch-and-bound nodes per solve at most: the optimum's work limit, counted, so that
its plans and proofs do not depend on the machine or its load. HiGHS's root (presolve, cuts,
heuristics) runs to its end before it, and is the most of the work on the valve bodies."""
TIME_LIMIT_S = 1200.0
"""Wall-clock safety net per episode (all solves of the confirmation rounds together), far above
what `NODE_LIMIT` and `PREDICTED_ROUNDS` take here; a plan it cuts short states no proof."""
TRIPLE_CHUNK = 20_000
"""Triples counted exactly at once (memory: this many rows of bits, one per point)."""
TRIPLE_LIMIT = 5_000_000
"""Triples counted exactly per program at most (some seconds); the test motors leave under
half a million open."""
PREDICTED_ROUNDS = 1
"""Solves on predicted rows at most: a solve confirms the views it chose, and most episodes end
there. Where the prediction is optimistic (structured light above all), each further round on
predicted rows found another set whose predicted rows reach the goal and whose measured rows do
not (5 rounds of 70-120 s on a pipe fitting, 50 on some motors); after this many, every usable
candidate is measured (about 36 s for 693 candidates under structured light, with the machine
busy) and the program solved once more, on measured rows only."""


@dataclasses.dataclass(frozen=True)
class Cover:
    """A solution of the set-cover program.

    Attributes:
        picks: The chosen rows, ascending.
        points: The points they add to those covered before.
        goal_reached: Whether the picks reach the goal (always False without one).
        views_bound: The solver's proof: no fewer rows reach the goal (None when the goal was
            not solved for: no goal, or none of `count` rows reaches it).
        points_bound: The solver's proof: no `count` rows add more points (None when the goal
            was solved for, or no solve ran).
        proven: Whether the picks meet the bound (optimal).
        seconds: Time spent reducing and solving.
        timed_out: Whether a solve stopped at the wall-clock `time_limit_s` (the safety net)
            rather than at its end or its node limit.
    """

    picks: tuple[int, ...]
    points: int
    goal_reached: bool
    views_bound: int | None
    points_bound: int | None
    proven: bool
    seconds: float
    timed_out: bool = False


@dataclasses.dataclass(frozen=True)
class Solved:
    """What one HiGHS solve of the reduced program found.

    Attributes:
        picks: The rows found (original indices; None when none were found or none exist).
        bound: The proven bound on the objective (views, or points).
        timed_out: Whether HiGHS stopped at its wall-clock time limit.
    """

    picks: list[int] | None
    bound: int
    timed_out: bool = False


@dataclasses.dataclass(frozen=True)
class Reduced:
    """A set-cover instance without the rows and columns that cannot matter.

    Attributes:
        rows: The kept rows of the original matrix (ascending).
        matrix: Which merged points each kept row sees (rows, columns).
        weights: How many original points each merged column stands for.
    """

    rows: np.ndarray
    matrix: np.ndarray
    weights: np.ndarray


def reduce_cover(visibility: np.ndarray, covered: np.ndarray) -> Reduced:
    """Drop covered and unseen points, merge points seen by the same rows, drop dominated rows
    (among rows that see the same points, the first is kept).

    Any solution of the reduced instance is one of the original adding as many points, and the
    rows of any solution of the original can be swapped for kept rows that add at least as many.
    """
    seen = np.asarray(visibility, dtype=bool)[:, ~np.asarray(covered, dtype=bool)]
    rows = np.flatnonzero(seen.any(axis=1))
    seen = seen[rows][:, seen.any(axis=0)]
    columns, weights = _merge_columns(seen, np.ones(seen.shape[1]))
    counts = columns.astype(np.float32)  # exact: counts stay far below 2^24
    shared = counts @ counts.T
    sizes = np.diag(shared)
    # Row j is dominated by row k when k sees all of j's points, and more or k comes first.
    index = np.arange(len(rows))
    dominated = ((shared >= sizes[:, None] - 0.5)
                 & ((sizes[None, :] > sizes[:, None]) | (index[None, :] < index[:, None])))
    kept = ~dominated.any(axis=1)
    columns, weights = _merge_columns(columns[kept], weights)
    return Reduced(rows[kept], columns, weights)


def _merge_columns(matrix: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct columns of a boolean matrix and the summed weights of each."""
    if matrix.size == 0:
        return matrix.reshape(len(matrix), 0), np.zeros(0)
    unique, inverse = np.unique(matrix.T, axis=0, return_inverse=True)
    return unique.T, np.bincount(inverse.ravel(), weights, minlength=len(unique))


def solve_cover(visibility: np.ndarray, covered: np.ndarray, count: int,
                goal: float | None = None, time_limit_s: float = TIME_LIMIT_S,
                incumbent: Sequence[int] = (), node_limit: int = NODE_LIMIT) -> Cover:
    """The fewest rows of `visibility` that reach the goal, or without a goal the most points
    `count` rows add; never worse than greedy (`greedy_cover`) or `incumbent`.

    Args:
        visibility: Which points each candidate sees (candidates, points).
        covered: Points covered already (points,); they count towards the goal.
        count: Most rows. With a goal that no `count` rows reach, the most points instead.
        goal: Fraction of all points to cover; None: the most points with `count` rows.
        time_limit_s: The solver's wall-clock safety net (all solves together).
        incumbent: A known solution (e.g. one confirmed by acquisitions) that bounds the
            program.
        node_limit: HiGHS's branch-and-bound nodes per solve at most; 0 runs no solve (nor its
            root, which alone can take a minute): the rows counted exactly when 3 or fewer reach
            the goal, else greedy's solution made smaller (`swap_down`) with the counted bound.

    Raises:
        ValueError: If the shapes disagree, count < 0, or the goal lies outside (0, 1].
    """
    start = time.perf_counter()
    visibility, covered = cover_input(visibility, covered, count)
    if goal is not None and not 0.0 < goal <= 1.0:
        raise ValueError(f"goal must lie in (0, 1], got {goal}")
    needed = (max(math.ceil(goal * len(covered) - 1e-9) - int(covered.sum()), 0)
              if goal is not None else None)

    def points(picks: Sequence[int]) -> int:
        return int((visibility[list(picks)].any(axis=0) & ~covered).sum()) if picks else 0

    timed_out = False

    def result(picks: Sequence[int], views_bound: int | None = None,
               points_bound: int | None = None) -> Cover:
        picks = tuple(sorted(int(pick) for pick in picks))
        added = points(picks)
        reached = needed is not None and added >= needed and len(picks) <= count
        proven = ((views_bound is not None and reached and views_bound >= len(picks))
                  or (points_bound is not None and points_bound <= added))
        return Cover(picks, added, reached, views_bound, points_bound, proven,
                     time.perf_counter() - start, timed_out)

    # Greedy's solution, or a better one given, bounds the program: HiGHS's own incumbents can
    # trail greedy's for a long time.
    greedy = tuple(greedy_cover(visibility, covered, count, goal)[0])
    incumbent = greedy if _better(visibility, covered, count, goal, greedy, incumbent) else tuple(
        incumbent)
    if needed is not None:
        incumbent = tuple(swap_down(visibility, covered, needed, incumbent))
    reduced = reduce_cover(visibility, covered)
    if needed is not None and reduced.weights.sum() >= needed:
        reaching = incumbent if points(incumbent) >= needed and len(incumbent) <= count else None
        cap = len(reaching) if reaching is not None else count
        fewest, lowest = fewest_views(reduced, needed)
        if reaching is not None and len(reaching) <= lowest:
            return result(reaching, views_bound=lowest)
        if fewest is not None and len(fewest) <= count:
            return result(fewest, views_bound=lowest)
        if node_limit == 0:
            if reaching is not None:
                return result(reaching, views_bound=lowest)
        else:
            solved = _solve(reduced, cap, needed, node_limit, time_limit_s, lowest)
            timed_out = solved.timed_out
            if solved.picks is not None and (reaching is None
                                             or len(solved.picks) < len(reaching)):
                return result(solved.picks, views_bound=solved.bound)
            if reaching is not None:
                return result(reaching, views_bound=solved.bound)
        # No `count` rows reach the goal (proven, or none found within the limits): the most
        # points.
        time_limit_s -= time.perf_counter() - start
    fallback = incumbent if len(incumbent) <= count else ()
    if node_limit == 0:
        return result(fallback)
    floor = points(fallback)
    solved = _solve(reduced, count, None, node_limit, max(time_limit_s, 0.0), floor)
    timed_out = timed_out or solved.timed_out
    best = (solved.picks if solved.picks is not None and points(solved.picks) > floor
            else fallback)
    return result(best, points_bound=solved.bound)


def swap_down(visibility: np.ndarray, covered: np.ndarray, needed: int,
              picks: Sequence[int]) -> list[int]:
    """`picks` made smaller while fewer rows can stand in for some of them: each time, two picks
    are replaced by the one row that, with the rest, adds `needed` new points, or else three by
    the two rows that do (of those, the pair adding the most). Picks that do not reach `needed`
    are returned as they are.

    Greedy's last picks often add little each; one row may cover what two of them add, two rows
    what three add. A smaller incumbent bounds the program tighter, and is a solution where the
    solver's work runs out.
    """
    picks = list(picks)

    def added(chosen: Sequence[int]) -> np.ndarray:
        return covered | visibility[list(chosen)].any(axis=0) if chosen else covered.copy()

    if int((added(picks) & ~covered).sum()) < needed:
        return picks
    target = needed + int(covered.sum())
    rows = visibility.astype(np.float32)  # exact: the counts stay far below 2^24
    improved = True
    while improved:
        improved = False
        for size in (2, 3):
            for dropped in itertools.combinations(range(len(picks)), size):
                rest = [pick for index, pick in enumerate(picks) if index not in dropped]
                base = added(rest)
                stand_in = _stand_in(rows, ~base, target - int(base.sum()), size - 1)
                if stand_in is not None:
                    picks, improved = rest + stand_in, True
                    break
            if improved:
                break
    return picks


def _stand_in(rows: np.ndarray, open_points: np.ndarray, missing: int, most: int
              ) -> list[int] | None:
    """At most `most` (1 or 2) rows that see `missing` of the open points (fewest first, then
    the ones seeing most), or None when no such rows exist."""
    if missing <= 0:
        return []  # the rest reach the goal by themselves
    seen = rows[:, open_points]
    gains = seen.sum(axis=1)
    best = int(np.argmax(gains))
    if gains[best] >= missing:
        return [best]
    if most < 2 or gains[best] + np.partition(gains, -2)[-2] < missing:
        return None
    # A pair's union is at most its gains' sum: only rows with enough gain can complete one.
    able = np.flatnonzero(gains >= missing - gains[best])
    unions = gains[able, None] + gains[None, able] - seen[able] @ seen[able].T
    first, second = np.unravel_index(np.argmax(unions), unions.shape)
    return [int(able[first]), int(able[second])] if unions[first, second] >= missing else None


def fewest_views(reduced: Reduced, needed: int) -> tuple[list[int] | None, int]:
    """The fewest rows that add `needed` points when 3 or fewer do (of those, the rows adding
    the most), found without the solver, else a proven lower bound on them.

    The largest rows bound the count from below; then every pair and every triple is tried
    (the test motors mostly need 3 or 4 views, which HiGHS's relaxation is slow to find and to
    prove). A triple's union is bounded by inclusion-exclusion from its pairs' overlaps (the
    smallest standing in for the three-way overlap); only the triples that bound leaves open
    are counted exactly, at most `TRIPLE_LIMIT` of them.

    Returns:
        The rows (original indices; None when more than 3 are needed or none was found among
        the triples counted before the limit) and the proven fewest rows.
    """
    if needed <= 0:
        return [], 0
    seen = reduced.matrix.astype(np.float32)  # exact: the sums stay far below 2^24
    weights = reduced.weights.astype(np.float32)
    sizes = seen @ weights
    if sizes.sum() < needed - 0.5:
        return None, len(sizes) + 1
    lowest = int(np.searchsorted(np.cumsum(np.sort(sizes)[::-1]), needed - 0.5)) + 1
    if lowest == 1:
        return reduced.rows[[int(np.argmax(sizes))]].tolist(), 1
    if lowest > 3:
        return None, lowest
    shared = seen @ (seen * weights).T
    if lowest == 2:
        unions = sizes[:, None] + sizes[None, :] - shared
        if unions.max() >= needed - 0.5:
            return reduced.rows[list(np.unravel_index(np.argmax(unions), unions.shape))].tolist(), 2
    # The rows over the original points, as bits: a union's size is a count of bits.
    bits = np.packbits(np.repeat(reduced.matrix, np.rint(reduced.weights).astype(int), axis=1),
                       axis=1)
    counted, found, most = 0, None, needed - 0.5
    for i in range(len(sizes) - 2):
        rest = slice(i + 1, None)
        with_i = shared[i, rest]
        bound = (sizes[i] + sizes[rest, None] + sizes[None, rest] - with_i[:, None]
                 - with_i[None, :] - shared[rest, rest]
                 + np.minimum(np.minimum(with_i[:, None], with_i[None, :]), shared[rest, rest]))
        first, second = np.nonzero(np.triu(bound >= needed - 0.5, 1))
        first, second = first + i + 1, second + i + 1
        for start in range(0, len(first), TRIPLE_CHUNK):
            chunk = slice(start, start + TRIPLE_CHUNK)
            unions = np.bitwise_count(bits[i] | bits[first[chunk]] | bits[second[chunk]]).sum(
                axis=1, dtype=np.int64)
            best = int(np.argmax(unions))
            if unions[best] >= most:
                found, most = [i, first[chunk][best], second[chunk][best]], unions[best]
            counted += len(unions)
            if counted > TRIPLE_LIMIT:
                return (None, 3) if found is None else (reduced.rows[found].tolist(), 3)
    return (None, 4) if found is None else (reduced.rows[found].tolist(), 3)


def views_to_goal(visibility: np.ndarray, covered: np.ndarray, goal: float,
                  usable: np.ndarray | None = None) -> np.ndarray:
    """For every row, the fewest rows that take it and reach the goal: the views to the goal
    when it is taken next (the cost-to-go of the remaining cover; the smallest covers are the
    rows where it is least).

    Exact up to 3: one row is counted, a pair is greedy's second pick (the row adding the most
    to it), a triple every pair that can complete it (`_stand_in`). Beyond 3, greedy's count
    from the row, an upper bound. Greedy runs from every row at once, over the points merged by
    the rows that see them.

    Args:
        visibility: Which points each candidate sees (candidates, points).
        covered: Points covered already (points,); they count towards the goal.
        goal: Fraction of all points to cover, in (0, 1].
        usable: Rows that may be taken (candidates,); None: all.

    Returns:
        Views (candidates,), float: inf for an unusable row, and for every row where all the
        usable rows together do not reach the goal.

    Raises:
        ValueError: If the shapes disagree or the goal lies outside (0, 1].
    """
    visibility, covered = cover_input(visibility, covered, 0)
    if not 0.0 < goal <= 1.0:
        raise ValueError(f"goal must lie in (0, 1], got {goal}")
    usable = (np.ones(len(visibility), dtype=bool) if usable is None
              else np.asarray(usable, dtype=bool))
    if usable.shape != visibility.shape[:1]:
        raise ValueError(f"usable {usable.shape} and visibility {visibility.shape} disagree")
    needed = max(math.ceil(goal * len(covered) - 1e-9) - int(covered.sum()), 0)
    views = np.full(len(visibility), np.inf)
    seen = visibility[:, ~covered] & usable[:, None]
    seen_any = seen.any(axis=0)
    if seen_any.sum() < needed:
        return views
    matrix, weights = _merge_columns(seen[:, seen_any], np.ones(int(seen_any.sum())))
    weights = weights.astype(np.float32)  # exact: the sums stay far below 2^24
    columns = matrix.astype(np.float32)
    added = columns @ weights
    count = np.ones(len(views))
    open_points = ~matrix
    active = usable.copy()
    while True:
        reached = active & (added >= needed - 0.5)
        views[reached] = count[reached]
        active &= ~reached
        if not active.any():
            break
        # Greedy's next pick from every open row at once: the row adding the most to it.
        gains = (open_points[active] * weights) @ columns.T
        picks = np.argmax(gains, axis=1)
        open_points[active] &= ~matrix[picks]
        added[active] += gains[np.arange(len(picks)), picks]
        count[active] += 1
    rows = seen.astype(np.float32)
    for row in np.flatnonzero(np.isfinite(views) & (views > 3)):
        if _stand_in(rows, ~seen[row], needed - int(seen[row].sum()), 2) is not None:
            views[row] = 3
    return views


def _solve(reduced: Reduced, count: int, needed: int | None, node_limit: int,
           time_limit_s: float, floor: int = 0) -> Solved:
    """Solve the reduced program within `node_limit` nodes (and the safety net `time_limit_s`):
    with `needed`, the fewest rows (at most `count`, at least `floor`, a proven bound) adding
    that many points; else the most points (at least `floor`) with `count` rows."""
    rows, weights = len(reduced.rows), reduced.weights
    if needed == 0:
        return Solved([], 0)
    if count == 0 or rows == 0:
        return Solved(None, count + 1) if needed is not None else Solved([], 0)
    # Variables: x (rows) then y (merged points); y_c <= w_c * (the x_j seeing column c).
    links = sparse.hstack([sparse.csr_array(reduced.matrix.T * -weights[:, None]),
                           sparse.eye_array(len(weights))])
    taken = np.concatenate([np.ones(rows), np.zeros(len(weights))])
    gained = 1.0 - taken
    constraints = [optimize.LinearConstraint(links, -np.inf, 0.0),
                   optimize.LinearConstraint(taken, 0 if needed is None else floor, count),
                   optimize.LinearConstraint(gained, floor if needed is None else needed,
                                             np.inf)]
    # Presolve off: the reduced program leaves HiGHS's presolve nothing to remove (38 s on a
    # valve body's solve for no reduction; the solve took 119 s without it, 228 s with it).
    found = optimize.milp(taken if needed is not None else -gained, integrality=taken,
                          bounds=optimize.Bounds(0.0, np.concatenate([np.ones(rows), weights])),
                          constraints=constraints,
                          options={"node_limit": node_limit, "presolve": False,
                                   "time_limit": max(time_limit_s, 1e-3)})
    picks = None if found.x is None else reduced.rows[found.x[:rows] > 0.5].tolist()
    if found.status == 2:  # infeasible: no `count` rows add `needed` (or `floor`) points
        return Solved(None, count + 1 if needed is not None else floor)
    # Status 1 is HiGHS's time (or iteration) limit; its node limit is status 4.
    timed_out = found.status == 1
    dual = found.fun if found.status == 0 else found.mip_dual_bound
    proved = dual if dual is not None and np.isfinite(dual) else None
    if needed is not None:
        # Without a bound within the limits, the one given holds.
        return Solved(picks, max(math.ceil(proved - 1e-6) if proved is not None else 0, floor),
                      timed_out)
    return Solved(picks, math.floor(-proved + 1e-6) if proved is not None
                  else round(weights.sum()), timed_out)


@register_planner
class OptimumPlanner(ExactPlanner, SetCoverPlanner):
    """The exact set cover over the usable candidates, confirmed and ordered for cycle time.

    Args:
        views: Fixed number of views (`optimum<N>`: the most coverage with N views); None: the
            fewest views that reach the goal.
        goal: Coverage goal when `views` is None.
        max_views: View budget when planning to the goal.
        candidate_count: Candidate positions on the view sphere.
        resolution: Grid of the visibility renderer.
        node_limit: HiGHS's branch-and-bound nodes per solve (the work limit).
        time_limit_s: Wall-clock safety net per episode.

    Attributes:
        picks: The plan's candidates (before ordering for cycle time).
        gains: GT points each pick adds after the ones before it (measured).
        greedy_picks: B_SCP's picks on the same candidates, the incumbent.
        proof: Whether the plan is proven optimal on the measured rows of its views, the last
            solve's bound and the views above it (`Proof`); None when the safety net
            `time_limit_s` cut the solves short.
        solve_seconds: Time spent in the solver (all rounds).
        rounds: Solves run.

    Raises:
        ValueError: As `SetCoverPlanner`, or if node_limit or time_limit_s is not positive.
    """

    name = "optimum"
    evaluated = ()  # minutes per episode: asked for by name (and not B_SCP's)

    def __init__(self, views: int | None = None, goal: float = 0.9, max_views: int = 10,
                 candidate_count: int = CANDIDATE_COUNT,
                 resolution: tuple[int, int] = DEFAULT_RESOLUTION,
                 node_limit: int = NODE_LIMIT, time_limit_s: float = TIME_LIMIT_S):
        super().__init__(views, goal, max_views, candidate_count, resolution)
        if not node_limit > 0:
            raise ValueError(f"node_limit must be > 0, got {node_limit}")
        if not time_limit_s > 0.0:
            raise ValueError(f"time_limit_s must be > 0 s, got {time_limit_s}")
        self.node_limit = node_limit
        self.time_limit_s = time_limit_s
        self.greedy_picks: list[int] = []
        self.solve_seconds = 0.0
        self.rounds = 0

    def plan(self, episode: Episode) -> list[ViewRequest]:
        candidates = candidate_views(episode, self.candidate_count, self.resolution)
        self.candidates = candidates
        count = self.views if self.views is not None else self.max_views
        goal = None if self.views is not None else self.goal
        measured: set[int] = set()

        def confirm(index: int) -> np.ndarray:
            measured.add(index)
            return candidates.measured(index, episode)

        self.greedy_picks, _ = greedy_cover(
            candidates.known_visibility(), episode.covered, count, goal, confirm=confirm,
            confirmations=CONFIRMATIONS_PER_PICK)
        usable = np.flatnonzero(candidates.usable).tolist()
        best = self._confirmed_optimum(candidates.known_visibility, episode.covered, count, goal,
                                       confirm, measured, usable)
        self.picks, self.gains = _ordered_gains(candidates.known_visibility(), episode.covered,
                                                best)
        self._taken = set(self.picks)
        return cycle_order(episode, [candidates.request(i) for i in self.picks])

    def _confirmed_optimum(self, known: Callable[[], np.ndarray], covered: np.ndarray,
                           count: int, goal: float | None, confirm: Callable[[int], np.ndarray],
                           measured: set[int], usable: Sequence[int]) -> list[int]:
        """The best confirmed solution: solve on the rows known so far (greedy's picks the
        incumbent), confirm the chosen rows, again until a solve chooses only rows measured
        before it; after `PREDICTED_ROUNDS` solves every `usable` row is measured, so that the
        next solve is the last. Records the proof and the gap, or None when the safety net
        `time_limit_s` cut the rounds short (the proof would depend on the clock)."""
        best = list(self.greedy_picks)
        deadline = time.perf_counter() + self.time_limit_s
        self.solve_seconds, self.rounds = 0.0, 0
        while True:
            cover = solve_cover(known(), covered, count, goal,
                                max(deadline - time.perf_counter(), 0.0), best, self.node_limit)
            self.solve_seconds += cover.seconds
            self.rounds += 1
            fresh = [index for index in cover.picks if index not in measured]
            for index in fresh:
                confirm(index)
            if _better(known(), covered, count, goal, cover.picks, best):
                best = list(cover.picks)
            # Cut when HiGHS stopped at the clock, or another round was due past it.
            timed_out = cover.timed_out or (bool(fresh) and time.perf_counter() >= deadline)
            if not fresh or timed_out:
                break
            if self.rounds == PREDICTED_ROUNDS:
                # Measured rows only from here: the next solve chooses none unmeasured.
                for index in usable:
                    if index not in measured:
                        confirm(index)
        if timed_out:
            warnings.warn(f"optimum: the {self.time_limit_s:g} s safety net cut the solves "
                          f"short after {self.rounds} round(s); the plan states no proof",
                          stacklevel=2)
            self.proof = None
            return best
        # A proof on rows that include none confirmed since holds for `best` (no worse than
        # the cover on those rows).
        self.proof = Proof(
            proven=cover.proven and not fresh,
            bound=cover.views_bound if cover.views_bound is not None else cover.points_bound,
            gap_views=(max(len(best) - cover.views_bound, 0)
                       if goal is not None and cover.views_bound is not None else None))
        return best


def _better(rows: np.ndarray, covered: np.ndarray, count: int, goal: float | None,
            picks: Sequence[int], than: Sequence[int]) -> bool:
    """Whether `picks` beats `than` on these rows: reaching the goal (within `count`) with fewer
    rows, else covering more."""
    def score(chosen: Sequence[int]) -> tuple[bool, int]:
        total = int((covered | rows[list(chosen)].any(axis=0)).sum()) if chosen else int(
            covered.sum())
        reached = (goal is not None and len(chosen) <= count
                   and total >= math.ceil(goal * len(covered) - 1e-9))
        return reached, -len(chosen) if reached else total

    return score(picks) > score(than)


def _ordered_gains(rows: np.ndarray, covered: np.ndarray, picks: Sequence[int]
                   ) -> tuple[list[int], list[int]]:
    """The picks by decreasing marginal gain (greedy order among themselves) and the gains."""
    order, gains = greedy_cover(rows[list(picks)], covered, len(picks))
    rest = [i for i in range(len(picks)) if i not in order]  # rows that add nothing
    return [picks[i] for i in order + rest], gains + [0] * len(rest)
