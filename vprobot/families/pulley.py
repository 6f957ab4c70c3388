"""V-belt pulleys: a grooved rim, a web thinned by recesses and lightening holes, a hub standing
out on one side with a keyed bore."""

from __future__ import annotations

import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, carve, cylinder_x, keyed_bore_x, revolve_x, web_cuts


@register_family
class Pulley(PartFamily):
    name = "pulley"
    description = "V-belt pulley: grooved rim, recessed web with holes, offset hub, keyed bore"
    parameters = (
        Parameter("outer_radius_m", 0.06, 0.13, "rim radius"),
        Parameter("groove_count", 1, 3, "V grooves", integer=True),
        Parameter("groove_depth_m", 0.006, 0.012, "depth of a groove"),
        Parameter("groove_pitch_m", 0.012, 0.02, "groove centre to centre"),
        Parameter("hub_radius_ratio", 0.25, 0.4, "hub radius / rim radius"),
        Parameter("hub_offset_m", 0.0, 0.02, "how far the hub stands out of the rim"),
        Parameter("bore_ratio", 0.4, 0.6, "bore radius / hub radius"),
        Parameter("lightening_hole_count", 0, 6, "holes through the web", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        r, depth = values["outer_radius_m"], values["groove_depth_m"]
        count, pitch = int(values["groove_count"]), values["groove_pitch_m"]
        edge = 0.004
        width = count * pitch + 2 * edge
        profile = [(-width / 2, 0.0), (-width / 2, r)]
        for k in range(count):
            centre = -width / 2 + edge + (k + 0.5) * pitch
            profile += [(centre - 0.45 * pitch, r), (centre - 0.12 * pitch, r - depth),
                        (centre + 0.12 * pitch, r - depth), (centre + 0.45 * pitch, r)]
        profile += [(width / 2, r), (width / 2, 0.0)]
        hub = values["hub_radius_ratio"] * r
        rim = r - depth - 0.006
        holes = int(values["lightening_hole_count"]) if rim - hub > 0.015 else 0
        wheel = carve([revolve_x(profile, 96)], web_cuts(hub, rim, width, 0.4, holes))
        x1 = width / 2 + values["hub_offset_m"]
        bore = keyed_bore_x(values["bore_ratio"] * hub, -width / 2 - OVERLAP_M, x1 + OVERLAP_M)
        return carve([wheel, cylinder_x(hub, -width / 2, x1, 64)], bore)
