"""Pipe fittings: tees, elbows, crosses and reducers, hollow, with optional bolted end flanges."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, carve, revolve_x, rod

_KINDS = ("tee", "elbow", "cross", "reducer")
_ARMS = {"tee": ((1, 0, 0), (-1, 0, 0), (0, 1, 0)), "elbow": ((1, 0, 0), (0, 1, 0)),
         "cross": ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)),
         "reducer": ((1, 0, 0), (-1, 0, 0))}


def _flange(direction: np.ndarray, end: float, pipe: float, radius: float, thickness: float,
            ) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    """A flange of `radius` on the arm along `direction` ending `end` from the centre, and the
    cuts of its four bolt holes."""
    disc = rod(radius, (end - thickness) * direction, end * direction, 64)
    side = np.cross(direction, (0, 0, 1))
    pitch, hole = (pipe + radius) / 2, min(0.3 * (radius - pipe), 0.009)
    o = OVERLAP_M
    holes = [rod(hole, (end - thickness - o) * direction + offset, (end + o) * direction + offset,
                 20)
             for offset in (pitch * side, -pitch * side, (0, 0, pitch), (0, 0, -pitch))]
    return disc, holes


@register_family
class PipeFitting(PartFamily):
    name = "pipe_fitting"
    description = "hollow pipe fitting (tee, elbow, cross, reducer), optional bolted end flanges"
    parameters = (
        Parameter("kind", 0, 3, "0 tee, 1 elbow, 2 cross, 3 reducer", integer=True),
        Parameter("pipe_radius_m", 0.02, 0.04, "outer radius of the pipe"),
        Parameter("wall_ratio", 0.12, 0.25, "wall thickness / pipe radius"),
        Parameter("arm_length_m", 0.065, 0.10, "centre to end face"),
        Parameter("reducer_ratio", 0.5, 0.75, "small end radius / pipe radius (reducer)"),
        Parameter("flange_count", 0, 1, "1: a bolted flange on every end", integer=True),
        Parameter("flange_radius_ratio", 1.5, 2.0, "flange radius / pipe radius"),
        Parameter("flange_thickness_m", 0.008, 0.016, "flange thickness"),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        kind = _KINDS[int(values["kind"])]
        pipe, arm = values["pipe_radius_m"], values["arm_length_m"]
        wall = values["wall_ratio"] * pipe
        o = OVERLAP_M
        ends = [(np.array(d, dtype=float), pipe) for d in _ARMS[kind]]
        if kind == "reducer":
            small = values["reducer_ratio"] * pipe
            ends[0] = (ends[0][0], small)
            solids = [revolve_x([(-arm, 0), (-arm, pipe), (-0.2 * arm, pipe), (0.2 * arm, small),
                                 (arm, small), (arm, 0)], 64)]
            cuts = [revolve_x([(-arm - o, 0), (-arm - o, pipe - wall), (-0.2 * arm, pipe - wall),
                               (0.2 * arm, small - wall), (arm + o, small - wall), (arm + o, 0)],
                              64)]
        else:
            solids = [rod(pipe, (0, 0, 0), arm * d, 64) for d, _ in ends]
            cuts = [rod(pipe - wall, (0, 0, 0), (arm + o) * d, 64) for d, _ in ends]
            # A ball where the arms meet keeps the outside of a corner round and the bore open.
            solids.append(trimesh.creation.icosphere(3, pipe))
            cuts.append(trimesh.creation.icosphere(3, pipe - wall))
        if values["flange_count"]:
            for direction, radius in ends:
                disc, holes = _flange(direction, arm, radius,
                                      values["flange_radius_ratio"] * radius,
                                      values["flange_thickness_m"])
                solids.append(disc)
                cuts += holes
        return carve(solids, cuts)
