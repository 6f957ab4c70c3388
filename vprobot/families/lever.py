"""Levers and rocker arms: a flat arm between two bosses of different size, each with a bore,
and an optional lightening slot through the arm."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import carve, circle, cylinder_x, hull


def _stadium(r0: float, r1: float, y0: float, y1: float, x0: float, x1: float) -> trimesh.Trimesh:
    """Hull of two circles in the y-z plane (radii r0 at y0 and r1 at y1), from x0 to x1."""
    ring = np.vstack([circle(r0, 48, (y0, 0)), circle(r1, 48, (y1, 0))])
    return hull([(x, y, z) for y, z in ring for x in (x0, x1)])


@register_family
class Lever(PartFamily):
    name = "lever"
    description = "lever: flat arm between two bored bosses, optional lightening slot"
    parameters = (
        Parameter("centre_distance_m", 0.12, 0.22, "boss centre to boss centre"),
        Parameter("big_boss_radius_m", 0.018, 0.03, "radius of the larger boss"),
        Parameter("small_boss_ratio", 0.55, 0.8, "smaller boss radius / larger"),
        Parameter("arm_thickness_m", 0.006, 0.014, "arm plate thickness"),
        Parameter("arm_width_ratio", 0.6, 0.9, "arm half-width at a boss / that boss radius"),
        Parameter("boss_length_m", 0.018, 0.04, "boss length along its bore"),
        Parameter("bore_ratio", 0.35, 0.55, "bore radius / boss radius"),
        Parameter("slot_count", 0, 1, "a lightening slot through the arm", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        half = values["centre_distance_m"] / 2
        big = values["big_boss_radius_m"]
        small = values["small_boss_ratio"] * big
        t, length = values["arm_thickness_m"], values["boss_length_m"]
        ratio, bore = values["arm_width_ratio"], values["bore_ratio"]
        solids = [_stadium(ratio * big, ratio * small, -half, half, -t / 2, t / 2),
                  cylinder_x(big, -length / 2, length / 2, 64, (-half, 0)),
                  cylinder_x(small, -length / 2, length / 2, 48, (half, 0))]
        cuts = [cylinder_x(bore * big, -length, length, 48, (-half, 0)),
                cylinder_x(bore * small, -length, length, 32, (half, 0))]
        if values["slot_count"]:
            slot = 0.4 * ratio * small
            cuts.append(_stadium(slot, slot, -half + 1.6 * big, half - 1.6 * small, -t, t))
        return carve(solids, cuts)
