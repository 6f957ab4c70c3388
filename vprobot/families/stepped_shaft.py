"""Stepped shafts: journals stepping up to a central collar, chamfered ends, a keyway on the
step beside the collar and an optional cross hole."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, box, carve, revolve_x, rod


@register_family
class SteppedShaft(PartFamily):
    name = "stepped_shaft"
    description = "stepped shaft: journals up to a collar, chamfers, keyway, cross hole"
    parameters = (
        Parameter("step_count", 3, 5, "steps including the collar", integer=True),
        Parameter("length_m", 0.16, 0.30, "overall length"),
        Parameter("collar_radius_m", 0.015, 0.035, "radius of the collar, the thickest step"),
        Parameter("end_radius_ratio", 0.4, 0.7, "radius of the end steps / collar radius"),
        Parameter("collar_ratio", 0.06, 0.15, "collar length / overall length"),
        Parameter("collar_position_ratio", 0.3, 0.7, "collar centre along the length"),
        Parameter("keyway_length_ratio", 0.4, 0.8, "keyway length / its step's length"),
        Parameter("cross_hole_count", 0, 1, "a radial hole through an end step", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        length, big = values["length_m"], values["collar_radius_m"]
        small = values["end_radius_ratio"] * big
        collar = values["collar_ratio"] * length
        centre = values["collar_position_ratio"] * length
        steps = int(values["step_count"]) - 1
        left = steps // 2
        # Steps on each side of the collar share its side's length; radii fall towards the ends.
        edges = [*np.linspace(0, centre - collar / 2, left + 1),
                 *np.linspace(centre + collar / 2, length, steps - left + 1)]
        step_radius = np.interp(np.arange(steps), [0, steps - 1], [small, 0.85 * big])
        radii = [*step_radius[:left], big, *step_radius[left:][::-1]]
        c = min(0.0015, 0.2 * small)
        profile = [(0.0, 0.0), (0.0, radii[0] - c), (c, radii[0])]
        for x, before, after in zip(edges[1:-1], radii[:-1], radii[1:], strict=True):
            profile += [(x, before), (x, after)]
        profile += [(length - c, radii[-1]), (length, radii[-1] - c), (length, 0.0)]
        # The keyway goes on the longer of the two steps beside the collar.
        keyed = left - 1 if centre > length / 2 and left > 0 else left + 1
        x0, x1 = edges[keyed], edges[keyed + 1]
        r = radii[keyed]
        key_length = values["keyway_length_ratio"] * (x1 - x0)
        key = 0.5 * r
        cuts = [box((key_length, key, key), ((x0 + x1) / 2, 0, r - key / 2 + OVERLAP_M))]
        if values["cross_hole_count"]:
            x = edges[1] / 2
            cuts.append(rod(0.4 * radii[0], (x, 0, -2 * radii[0]), (x, 0, 2 * radii[0]), 24))
        return carve([revolve_x(profile, 64)], cuts)
