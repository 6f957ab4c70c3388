"""The export format `urscript`: a URScript program for Universal Robots arms
(docs/motion.md#urscript).

A complete program: a global `speed_scale`, `def inspection():` that sets the TCP and the
payload, moves slowly to the plan's start pose, runs the plan and triggers the sensor at every
view, and the call `inspection()`. The sensor poses in its comments are in the controller's
`base` frame, as the pendant shows the TCP.

One `movej` per straight segment of every move: UR's `movej` moves the joints linearly in joint
space, all arriving together, with a trapezoidal speed profile whose acceleration `a` and speed
`v` are those of the leading joint, so the segment's line, and with it the path planner's
collision check, carries over. The controller's trapezoid has no jerk limit, so the planned
jerk-limited profile cannot be sent as is; each segment gets the leading joint's acceleration
`a` of the plan's time law (within every joint's limit) and the speed `v` <= the path's speed
limit at which the trapezoid takes the segment's planned duration (L / v + v / a = T), so the
program keeps the plan's clock and its cycle time. `t=` durations would leave the profile, and
so the accelerations, to the controller. `speed_scale` s multiplies every v by s and every a by
s^2: the same trapezoids, each taking T / s.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from vprobot.export.formats.base import register_format
from vprobot.export.motion import PlanMotion, ProgramCell, require_ur
from vprobot.geometry.poses import Pose, matrix_to_quat, rotation_about_z
from vprobot.kinematics.trajectory import Segment

UR_BASE = Pose(np.zeros(3), rotation_about_z(math.pi))
"""The controller's `base` frame in ROS `base_link`, the robot's base body: turned 180 deg about
z (ur_description: the fixed joint base_link -> base has rpy 0 0 pi)."""
START_SPEED_RAD_S = 0.3
START_ACCELERATION_RAD_S2 = 0.5
"""The leading joint's speed and acceleration of the first move, to the start pose from
wherever the arm stands: slow, as no planner checked it."""
TRIGGER_PULSE_S = 0.02
"""How long the trigger output stays high: 2.5 control cycles of a CB3 (8 ms), 10 of an
e-Series (2 ms); part of the acquisition time."""
DONE_POLL_S = 0.01
"""How often the program reads the done input while it waits."""
WAIT = "wait_for_frame"
"""The function that waits for the done input at every view."""


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


def _movej(joints: np.ndarray, a: float, v: float) -> str:
    """A `movej` at the leading joint's acceleration `a` and speed `v`, both at the program's
    `speed_scale` (the same trapezoid, slower)."""
    return (f"  movej({_floats(joints)}, a={a!r} * speed_scale * speed_scale, "
            f"v={v!r} * speed_scale)")


def rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """A rotation as URScript writes it: the axis times the angle (rad, in [0, pi])."""
    w, *axis = matrix_to_quat(rotation)
    vector = np.array(axis) * (1.0 if w >= 0 else -1.0)
    norm = float(np.linalg.norm(vector))
    return vector * (2 * math.atan2(norm, abs(w)) / norm) if norm > 0 else np.zeros(3)


def ur_pose(pose: Pose) -> str:
    """A pose as URScript's `p[x, y, z, rx, ry, rz]` (m, rotation vector in rad)."""
    return "p" + _floats(np.concatenate([pose.position, rotation_vector(pose.rotation)]))


def _assumptions(cell: ProgramCell, acquisition_time_s: float) -> list[str]:
    """The header's comments: what the program takes for granted about the cell."""
    io = cell.io
    trigger = (f"digital output {io.trigger_output} pulsed high for {TRIGGER_PULSE_S} s"
               if io.trigger_output is not None else f"the statement {io.trigger_script}")
    done = (f"waits for digital input {io.done_input} to be high (set by the sensor when its "
            f"frame is taken, low again at its next trigger), at most {io.done_timeout_s!r} s, "
            f"then stops with a popup" if io.done_input is not None else
            f"stands still {acquisition_time_s!r} s (the sensor's acquisition time) without a "
            f"done signal")
    source = ("the plan's cell block" if cell.from_plan else
              "DEFAULTS: the plan has no cell block (it predates it); check them")
    return [
        f"# Assumes ({source}; docs/motion.md#urscript):",
        "#   TCP: the sensor frame, its optical centre with +z the viewing direction (set_tcp "
        "below, the plan's sensor mount on the tool flange);",
        f"#   payload: {cell.payload_kg!r} kg at the sensor housing's centre (an estimate: weigh "
        "the sensor with its mount and measure its centre of gravity);",
        f"#   trigger: {trigger}; then the program {done};",
        "#   start: the plan starts from its start pose; the first movej goes there from "
        "wherever the arm stands, on a path nothing checked for collisions: jog the arm to "
        "the start pose (or near it, clear of everything) first;",
        "#   poses in comments: the sensor (TCP) in the controller's base frame, as the pendant "
        "shows it (p[x, y, z, rx, ry, rz], m and rad), then the plan's world frame.",
    ]


def _prologue(motion: PlanMotion) -> list[str]:
    """The definitions and settings before the first move."""
    cell = motion.cell
    lines = [
        "# Runs the same path slower: 0 < speed_scale <= 1 multiplies every move's speed by it "
        "and its acceleration by its square (the stops keep their length).",
        "speed_scale = 1.0",
        "def inspection():",
        "  if speed_scale <= 0 or speed_scale > 1:",
        '    popup("vprobot: speed_scale must lie in (0, 1]", title="vprobot", error=True)',
        "    halt",
        "  end",
    ]
    io = cell.io
    if io.done_input is not None:
        lines += [
            f"  def {WAIT}(view):",
            "    waited = 0.0",
            f"    while not get_standard_digital_in({io.done_input}):",
            f"      if waited >= {io.done_timeout_s!r}:",
            '        textmsg("vprobot: no done signal at view ", view)',
            f'        popup("vprobot: the sensor gave no done signal on digital input '
            f'{io.done_input} within {io.done_timeout_s!r} s", title="vprobot", error=True)',
            "        halt",
            "      end",
            f"      sleep({DONE_POLL_S!r})",
            f"      waited = waited + {DONE_POLL_S!r}",
            "    end",
            "  end",
        ]
    lines += [f"  set_tcp({ur_pose(cell.mount)})",
              f"  set_payload({cell.payload_kg!r}, {_floats(cell.payload_center)})  "
              f"# centre of gravity: an estimate (the housing's centre)"]
    return lines


def _acquire(motion: PlanMotion, count: int) -> list[str]:
    """The comments and statements of one acquisition: the pose, the trigger, the wait."""
    stop, cell, total = motion.stops[count], motion.cell, len(motion.stops)
    in_base = cell.base.compose(UR_BASE).inverse().compose(
        Pose.from_quat(stop.position, stop.quaternion))
    lines = [f"  # view {stop.view} (acquisition {count + 1} of {total}): sensor "
             f"{ur_pose(in_base)} in the base frame; in the world: position "
             f"{_floats(stop.position)} quaternion (w, x, y, z) {_floats(stop.quaternion)}"]
    io = cell.io
    pulsed = 0.0
    if io.trigger_output is not None:
        lines += [f"  set_standard_digital_out({io.trigger_output}, True)",
                  f"  sleep({TRIGGER_PULSE_S!r})",
                  f"  set_standard_digital_out({io.trigger_output}, False)"]
        pulsed = TRIGGER_PULSE_S
    else:
        lines.append(f"  {io.trigger_script}")
    if io.done_input is not None:
        lines.append(f"  {WAIT}({stop.view})")
    elif motion.acquisition_time_s > pulsed:
        lines.append(f"  sleep({motion.acquisition_time_s - pulsed!r})")
    return lines


@register_format("urscript", ".script", "a URScript program (UR robots)")
def urscript(motion: PlanMotion, dt: float) -> str:
    """The program: the settings, a slow move to the start pose, then the moves, triggering the
    sensor and waiting for it at every view, and the call of its function. `dt` is not used:
    the controller times each segment itself, so the program sends segments, not samples.

    Raises:
        ValueError: If the robot is not a Universal Robots arm.
    """
    require_ur(motion)
    segments = iter(motion.timed.segments)
    total = len(motion.stops)
    start = motion.moves[0][0]
    lines = [f"# vprobot inspection program for the {motion.robot}: {total} acquisitions, cycle "
             f"time {motion.timed.cycle.total_s:.3f} s at speed_scale 1 from the start pose "
             f"(docs/motion.md#urscript)",
             f"# joints: {', '.join(motion.joint_names)}",
             *_assumptions(motion.cell, motion.acquisition_time_s),
             *_prologue(motion),
             "  # to the start pose, slowly, from wherever the arm stands (not collision-checked)",
             _movej(start, min(START_ACCELERATION_RAD_S2, float(motion.limits.acceleration.min())),
                    min(START_SPEED_RAD_S, float(motion.limits.velocity.min())))]
    for index, move in enumerate(motion.moves):
        lines.append("  # approach" if index == 0 else "  # return to the start"
                     if index == total else f"  # move to view {motion.stops[index].view}")
        for begin, end in itertools.pairwise(move):
            if not np.any(end != begin):
                continue  # no segment: the time law has none either
            segment = next(segments)
            a = leading_limit(segment, motion.limits.acceleration)
            v = trapezoid(segment, a)
            lines.append(f"{_movej(end, a, v)}  # {segment.duration_s:.4f} s at speed_scale 1")
        if index < total:
            lines += _acquire(motion, index)
    lines += ["end", "inspection()", ""]
    return "\n".join(lines)
