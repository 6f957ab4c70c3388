"""Gearbox housings: an open-topped box with bearing bosses through its end walls, ribs on its
sides and bolted mounting lugs at the foot."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, box, carve, cylinder_x, rod


@register_family
class Housing(PartFamily):
    name = "housing"
    description = "open-topped gearbox housing: bearing bosses, side ribs, bolted foot lugs"
    parameters = (
        Parameter("length_m", 0.10, 0.20, "along x, the bearing axis"),
        Parameter("width_m", 0.07, 0.13, "along y"),
        Parameter("height_m", 0.06, 0.12, "along z"),
        Parameter("wall_m", 0.005, 0.012, "wall and floor thickness"),
        Parameter("boss_radius_ratio", 0.25, 0.4, "bearing boss radius / height"),
        Parameter("boss_length_m", 0.006, 0.015, "how far a boss stands out of its wall"),
        Parameter("rib_count", 0, 4, "vertical ribs on each side wall", integer=True),
        Parameter("lug_length_m", 0.01, 0.02, "how far the foot lugs stand out"),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        length, width, height = values["length_m"], values["width_m"], values["height_m"]
        wall, o = values["wall_m"], OVERLAP_M
        boss = values["boss_radius_ratio"] * height
        x_boss = length / 2 + values["boss_length_m"]
        solids = [box((length, width, height)),
                  cylinder_x(boss, -x_boss, x_boss, 64, (0, 0))]
        cuts = [box((length - 2 * wall, width - 2 * wall, height),
                    (0, 0, wall)),
                cylinder_x(0.6 * boss, -x_boss - o, x_boss + o, 64, (0, 0))]
        rib_x = length * ((np.arange(values["rib_count"]) + 0.5) / max(values["rib_count"], 1)
                          - 0.5)
        for side in (-1, 1):
            for x in rib_x:
                solids.append(box((wall, 0.006 + o, height - wall),
                                  (x, side * (width / 2 + 0.003 - o / 2), -wall / 2)))
            lug = values["lug_length_m"]
            for x in (-1, 1):
                centre = (x * (length / 2 - 1.5 * lug), side * (width / 2 + lug / 2 - o / 2),
                          -height / 2 + wall / 2)
                solids.append(box((2 * lug, lug + o, wall), centre))
                y = side * (width / 2 + lug / 2)
                cuts.append(rod(0.3 * lug, (centre[0], y, -height / 2 - o),
                                (centre[0], y, -height / 2 + wall + o), 20))
        return carve(solids, cuts)
