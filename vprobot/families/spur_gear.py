"""Spur gears: a toothed rim, a web thinned by recesses and lightening holes, a hub with a
keyed bore."""

from __future__ import annotations

import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import (
    OVERLAP_M,
    carve,
    cylinder_x,
    keyed_bore_x,
    prism_x,
    toothed_outline,
    web_cuts,
)


@register_family
class SpurGear(PartFamily):
    name = "spur_gear"
    description = "spur gear: teeth, recessed web with lightening holes, hub, keyed bore"
    parameters = (
        Parameter("tooth_count", 18, 60, "teeth", integer=True),
        Parameter("pitch_radius_m", 0.055, 0.12, "pitch circle radius"),
        Parameter("face_width_m", 0.015, 0.045, "tooth width along the axis"),
        Parameter("hub_radius_ratio", 0.25, 0.4, "hub radius / pitch radius"),
        Parameter("hub_length_m", 0.02, 0.07, "hub length (at least the face width)"),
        Parameter("bore_ratio", 0.4, 0.65, "bore radius / hub radius"),
        Parameter("web_ratio", 0.3, 0.6, "web thickness / face width"),
        Parameter("lightening_hole_count", 0, 6, "holes through the web", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        pitch, teeth = values["pitch_radius_m"], int(values["tooth_count"])
        module = 2 * pitch / teeth
        root = pitch - 1.25 * module
        width = values["face_width_m"]
        hub = values["hub_radius_ratio"] * pitch
        hub_half = max(values["hub_length_m"], width) / 2
        rim = root - max(2 * module, 0.006)
        blank = prism_x(toothed_outline(teeth, root, pitch + module), (0, 0), -width / 2, width / 2)
        holes = int(values["lightening_hole_count"]) if rim - hub > 0.015 else 0
        wheel = carve([blank], web_cuts(hub, rim, width, values["web_ratio"], holes))
        o = OVERLAP_M
        bore = keyed_bore_x(values["bore_ratio"] * hub, -hub_half - o, hub_half + o)
        return carve([wheel, cylinder_x(hub, -hub_half, hub_half, 64)], bore)
