"""The export format `trajectory`: the sampled joint trajectory as JSON (docs/motion.md#export)."""

from __future__ import annotations

import json
from typing import Any

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion


def acquisition_entries(motion: PlanMotion) -> list[dict[str, Any]]:
    """Per acquisition: the view, when the robot stands there, its joints and the plan's sensor
    pose, for checking."""
    return [{"view": stop.view, "start_s": acquisition.start_s, "end_s": acquisition.end_s,
             "joints": stop.joints.tolist(), "sensor_position": stop.position.tolist(),
             "sensor_quaternion": stop.quaternion.tolist()}
            for stop, acquisition in zip(motion.stops, motion.timed.acquisitions, strict=True)]


@register_format("trajectory", ".json", "the sampled joint trajectory as JSON")
def trajectory_json(motion: PlanMotion, dt: float) -> str:
    """Times, positions, velocities and accelerations at every sample (every `dt` s), the cycle
    time and the acquisitions."""
    samples = motion.timed.sample(dt)
    document = {
        "robot": motion.robot,
        "joint_names": list(samples.joint_names),
        "cycle_time": motion.timed.cycle.as_dict(),
        "times": samples.times.tolist(),
        "positions": samples.positions.tolist(),
        "velocities": samples.velocities.tolist(),
        "accelerations": samples.accelerations.tolist(),
        "acquisitions": acquisition_entries(motion),
    }
    return json.dumps(document, allow_nan=False) + "\n"
