"""Globe valve bodies: a hollow ball with flanged pipe ends along x and a bonnet neck with a
bolted flange on top."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, carve, cylinder_x, polar, rod


def _bolt_circle(count: int, pitch: float, radius: float, start: np.ndarray, end: np.ndarray,
                 axis: int) -> list[trimesh.Trimesh]:
    """Cuts of `count` holes of `radius` on a circle of `pitch` about the coordinate `axis`,
    running from `start` to `end` along it."""
    holes = []
    for k in range(count):
        offset = np.insert(polar(pitch, (k + 0.5) * 2 * np.pi / count), axis, 0.0)
        holes.append(rod(radius, start + offset, end + offset, 20))
    return holes


@register_family
class ValveBody(PartFamily):
    name = "valve_body"
    description = "globe valve body: hollow ball, flanged ends, bonnet neck with bolted flange"
    parameters = (
        Parameter("body_radius_m", 0.03, 0.05, "ball radius"),
        Parameter("port_radius_ratio", 0.5, 0.7, "pipe end radius / ball radius"),
        Parameter("face_to_face_m", 0.12, 0.22, "end flange to end flange"),
        Parameter("flange_radius_ratio", 1.5, 1.9, "end flange radius / pipe end radius"),
        Parameter("flange_thickness_m", 0.008, 0.014, "flange thickness"),
        Parameter("bolt_count", 4, 8, "bolts per end flange", integer=True),
        Parameter("bonnet_height_m", 0.045, 0.08, "bonnet flange top above the ball centre"),
        Parameter("bonnet_radius_ratio", 0.55, 0.8, "bonnet neck radius / ball radius"),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        ball, o = values["body_radius_m"], OVERLAP_M
        port = values["port_radius_ratio"] * ball
        half = values["face_to_face_m"] / 2
        flange, t = values["flange_radius_ratio"] * port, values["flange_thickness_m"]
        neck, top = values["bonnet_radius_ratio"] * ball, values["bonnet_height_m"]
        bonnet = 1.45 * neck
        solids = [trimesh.creation.icosphere(3, ball), cylinder_x(port, -half, half, 64),
                  rod(neck, (0, 0, 0), (0, 0, top), 64),
                  rod(bonnet, (0, 0, top - t), (0, 0, top), 64)]
        cuts = [trimesh.creation.icosphere(3, 0.75 * ball),
                cylinder_x(0.7 * port, -half - o, half + o, 64),
                rod(0.65 * neck, (0, 0, 0), (0, 0, top + o), 64)]
        hole = min(0.3 * (flange - port), 0.008)
        for side in (-1, 1):
            x0, x1 = sorted((side * (half - t), side * half))
            solids.append(cylinder_x(flange, x0, x1, 64))
            cuts += _bolt_circle(int(values["bolt_count"]), (port + flange) / 2, hole,
                                 np.array([side * (half - t - o), 0, 0]),
                                 np.array([side * (half + o), 0, 0]), 0)
        cuts += _bolt_circle(4, (neck + bonnet) / 2, 0.3 * (bonnet - neck),
                             np.array([0, 0, top - t - o]), np.array([0, 0, top + o]), 2)
        return carve(solids, cuts)
