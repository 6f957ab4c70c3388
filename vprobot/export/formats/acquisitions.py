"""The export format `acquisitions`: when and where the robot stops to acquire, as JSON
(docs/motion.md#ros-2), the machine-readable companion of the `ros2` goal."""

from __future__ import annotations

import json

from vprobot.export.formats.base import register_format
from vprobot.export.formats.trajectory import acquisition_entries
from vprobot.export.motion import PlanMotion


@register_format("acquisitions", ".json", "the acquisitions' times, joints and sensor poses")
def acquisitions_json(motion: PlanMotion, dt: float) -> str:
    """Per acquisition the view, the start and end of the stop (s from the trajectory's start),
    the joints and the plan's sensor pose (world frame). `dt` is not used: the stops' times are
    the time law's, which every sampled format holds as samples."""
    document = {"robot": motion.robot, "joint_names": list(motion.joint_names),
                "acquisition_time_s": motion.acquisition_time_s,
                "cycle_time_s": motion.timed.cycle.total_s,
                "acquisitions": acquisition_entries(motion)}
    return json.dumps(document, allow_nan=False, indent=1) + "\n"
