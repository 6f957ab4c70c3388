"""Weld-neck pipe flanges: a disc with a raised face, a tapered neck, a bore and a bolt circle."""

from __future__ import annotations

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, carve, cylinder_x, polar, revolve_x


@register_family
class Flange(PartFamily):
    name = "flange"
    description = "weld-neck flange: disc, raised face, tapered neck, bore, bolt circle"
    parameters = (
        Parameter("outer_radius_m", 0.06, 0.12, "disc radius"),
        Parameter("thickness_m", 0.012, 0.028, "disc thickness"),
        Parameter("hub_radius_ratio", 0.45, 0.62, "neck radius at the disc / outer radius"),
        Parameter("hub_length_m", 0.015, 0.06, "neck length beyond the disc"),
        Parameter("bore_ratio", 0.55, 0.8, "bore radius / neck radius"),
        Parameter("bolt_count", 4, 12, "holes on the bolt circle", integer=True),
        Parameter("bolt_hole_radius_m", 0.005, 0.011, "bolt holes (capped by the room)"),
        Parameter("raised_face_m", 0.002, 0.005, "height of the raised sealing face"),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        r, t = values["outer_radius_m"], values["thickness_m"]
        hub = values["hub_radius_ratio"] * r
        bore = values["bore_ratio"] * hub
        count, face = int(values["bolt_count"]), values["raised_face_m"]
        pitch = (hub + r) / 2
        hole = min(values["bolt_hole_radius_m"], 0.35 * (r - hub), 0.3 * np.pi * pitch / count)
        face_r = pitch - hole - 0.003
        neck_end = max(bore + 0.004, 0.85 * hub)
        x_end, c = t + values["hub_length_m"], 0.0015
        profile = [(-face, 0), (-face, face_r), (0, face_r), (0, r - c), (c, r), (t - c, r),
                   (t, r - c), (t, hub), (x_end, neck_end), (x_end, 0)]
        o = OVERLAP_M
        holes = [cylinder_x(hole, -face - o, t + o, 24, polar(pitch, (k + 0.5) * 2 * np.pi / count))
                 for k in range(count)]
        return carve([revolve_x(profile, 96)], [cylinder_x(bore, -face - o, x_end + o, 64), *holes])
