"""View planners behind one interface: random agents, H_rec, B_SCP and a greedy oracle.

`run` plays one episode of a planner on a motor (robot in the loop or free-flying sensor) as an
episode spec fixes it;
`plan_motor` is the `vprobot plan` job: load a mesh, plan, and return the record, the plan JSON
document and a summary.
"""

from vprobot.planners.base import PLANNERS, Planner, PlanPlanner, register_planner
from vprobot.planners.bscp import SetCoverPlanner
from vprobot.planners.candidates import CandidateViews, candidate_views
from vprobot.planners.greedy import greedy_cover
from vprobot.planners.hrec import BoxFacesPlanner
from vprobot.planners.oracle import OraclePlanner
from vprobot.planners.ordering import order_requests, order_views
from vprobot.planners.random_views import Random1Planner, Random2Planner
from vprobot.planners.runner import (
    EpisodeResult,
    make_planner,
    parse_planner,
    plan_motor,
    planner_names,
    run,
    run_episode,
    summary,
)

__all__ = [
    "PLANNERS",
    "BoxFacesPlanner",
    "CandidateViews",
    "EpisodeResult",
    "OraclePlanner",
    "PlanPlanner",
    "Planner",
    "Random1Planner",
    "Random2Planner",
    "SetCoverPlanner",
    "candidate_views",
    "greedy_cover",
    "make_planner",
    "order_requests",
    "order_views",
    "parse_planner",
    "plan_motor",
    "planner_names",
    "register_planner",
    "run",
    "run_episode",
    "summary",
]
