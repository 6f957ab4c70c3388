"""Brackets and angle plates: an L (one upright) or U channel (two) bent from plate, with rows
of bolt holes in base and uprights and optional gussets in the inner corner."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, box, carve, hull, rod


@register_family
class Bracket(PartFamily):
    name = "bracket"
    description = "L bracket or U channel from plate, bolt-hole rows, optional corner gussets"
    parameters = (
        Parameter("base_length_m", 0.10, 0.22, "base plate along x"),
        Parameter("width_m", 0.05, 0.12, "plate width along y"),
        Parameter("height_m", 0.05, 0.14, "upright height"),
        Parameter("thickness_m", 0.004, 0.012, "plate thickness"),
        Parameter("upright_count", 1, 2, "1: L bracket, 2: U channel", integer=True),
        Parameter("hole_radius_m", 0.003, 0.007, "bolt holes (capped by their spacing)"),
        Parameter("hole_count", 1, 3, "holes per row", integer=True),
        Parameter("gusset_count", 0, 2, "triangular ribs per upright, at the edges", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        length, width, height = values["base_length_m"], values["width_m"], values["height_m"]
        t, n, o = values["thickness_m"], values["hole_count"], OVERLAP_M
        # Holes keep to the width inside the gussets, which sit on the edges.
        span = width - 2 * t
        ys = span * ((np.arange(n) + 0.5) / n - 0.5)
        hole = min(values["hole_radius_m"], 0.3 * span / n)
        solids = [box((length, width, t), (0, 0, t / 2))]
        cuts = []
        sides = (-1, 1) if values["upright_count"] == 2 else (-1,)
        gusset_size = 0.45 * min(height - t, length / 2 - t)
        for side in sides:
            x = side * (length / 2 - t / 2)
            solids.append(box((t, width, height), (x, 0, height / 2)))
            cuts += [rod(hole, (x - t, y, 0.6 * height), (x + t, y, 0.6 * height), 24) for y in ys]
            inner = x - side * t / 2
            for y in (-1, 1)[: int(values["gusset_count"])]:
                y0 = y * (width / 2 - t)
                corner = [(inner + side * o, t - o), (inner - side * gusset_size, t - o),
                          (inner + side * o, t + gusset_size)]
                solids.append(hull([(cx, yy, cz) for cx, cz in corner for yy in (y0, y0 + y * t)]))
        base_x = length / 4 if len(sides) == 1 else 0.0
        cuts += [rod(hole, (base_x, y, -o), (base_x, y, t + o), 24) for y in ys]
        return carve(solids, cuts)
