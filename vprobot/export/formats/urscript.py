"""The export format `urscript`: a URScript program for Universal Robots arms
(docs/motion.md#urscript).

One `movej` per straight segment of every move: UR's `movej` moves the joints linearly in joint
space, all arriving together, with a trapezoidal speed profile whose acceleration `a` and speed
`v` are those of the leading joint, so the segment's line, and with it the path planner's
collision check, carries over. The controller's trapezoid has no jerk limit, so the planned
jerk-limited profile cannot be sent as is; each segment gets the leading joint's acceleration
`a` of the plan's time law (within every joint's limit) and the speed `v` <= the path's speed
limit at which the trapezoid takes the segment's planned duration (L / v + v / a = T), so the
program keeps the plan's clock and its cycle time. `t=` durations would leave the profile, and
so the accelerations, to the controller.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion, ViewStop, require_ur
from vprobot.kinematics.trajectory import Segment

TRIGGER = "trigger_acquisition"
"""The function the program calls at every view; a stub for the cell engineer to fill in."""


def trapezoid(segment: Segment, acceleration: float) -> float:
    """The leading joint's speed at which a trapezoid with `acceleration` covers the segment in
    its planned duration (the smaller root of L / v + v / a = T, at most sqrt(a L): a valid
    trapezoid)."""
    a, length, duration = acceleration, segment.length, segment.duration_s
    # The jerk-limited profile is slower than the triangle at `a`: the root is real but for
    # rounding.
    return (a * duration - math.sqrt(max(a * a * duration * duration - 4 * a * length, 0.0))) / 2


def leading_limit(segment: Segment, limits: np.ndarray) -> float:
    """The path's limit along a segment: the leading joint's, such that no joint exceeds its
    own (`vprobot.kinematics.trajectory.time_segment`)."""
    moving = segment.direction != 0.0
    return float(np.min(limits[moving] / np.abs(segment.direction[moving])))


def _floats(values: np.ndarray) -> str:
    return "[" + ", ".join(repr(float(x) + 0.0) for x in values) + "]"


def _acquire(stop: ViewStop, count: int, total: int, time_s: float) -> list[str]:
    return [f"  # view {stop.view} (acquisition {count} of {total}): sensor position "
            f"{_floats(stop.position)} quaternion (w, x, y, z) {_floats(stop.quaternion)}",
            f"  {TRIGGER}({stop.view})", f"  sleep({time_s!r})"]


@register_format("urscript", ".script", "a URScript program (UR robots)")
def urscript(motion: PlanMotion, dt: float) -> str:
    """The program: `def inspection():` with the moves, an acquisition call and a stop of the
    acquisition time at every view. `dt` is not used: the controller times each segment
    itself, so the program sends segments, not samples.

    Raises:
        ValueError: If the robot is not a Universal Robots arm.
    """
    require_ur(motion)
    segments = iter(motion.timed.segments)
    total = len(motion.stops)
    lines = [f"# vprobot inspection program for the {motion.robot}: {total} acquisitions, cycle "
             f"time {motion.timed.cycle.total_s:.3f} s (docs/motion.md#urscript)",
             f"# joints: {', '.join(motion.joint_names)}",
             "def inspection():",
             f"  def {TRIGGER}(view):",
             "    # Fill in: trigger the sensor for this view and wait for its frame.",
             '    textmsg("vprobot: acquire view ", view)',
             "  end"]
    for index, move in enumerate(motion.moves):
        lines.append("  # approach" if index == 0 else "  # return to the start"
                     if index == total else f"  # move to view {motion.stops[index].view}")
        for start, end in itertools.pairwise(move):
            if not np.any(end != start):
                continue  # no segment: the time law has none either
            segment = next(segments)
            a = leading_limit(segment, motion.limits.acceleration)
            v = trapezoid(segment, a)
            lines.append(f"  movej({_floats(end)}, a={a!r}, v={v!r})  "
                         f"# {segment.duration_s:.4f} s")
        if index < total:
            lines += _acquire(motion.stops[index], index + 1, total, motion.acquisition_time_s)
    lines += ["end", ""]
    return "\n".join(lines)
