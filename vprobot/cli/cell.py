"""`vprobot reach`, `cell`, `sensors` and `robots`: the cell, its robot and its sensor."""

from __future__ import annotations

import argparse
from pathlib import Path

from vprobot.cli.common import (
    POSITIVE_INT,
    Commands,
    add,
    add_robot,
    config_of,
    naming_the_cell,
    write_json,
)
from vprobot.files.outputs import check_output_file
from vprobot.files.paths import available_robots, available_sensors


def add_reach(commands: Commands) -> None:
    reach = add(commands, "reach", command_reach, "Can the cell reach this sensor view?")
    add_robot(reach)
    reach.add_argument("--position", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="sensor position in the world (m)")
    reach.add_argument("--look-at", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="point the sensor looks at (m)")
    reach.add_argument("--from-joints", type=float, nargs="+", metavar="Q",
                       help="start configuration (rad); default: the home keyframe")
    reach.add_argument("--json", help="write the plan JSON (docs/plan-format.md) here")


def add_cell(commands: Commands) -> None:
    cell = add(commands, "cell", command_cell, "Reachability report of the cell's view sphere.")
    add_robot(cell)
    cell.add_argument("--candidates", type=POSITIVE_INT, default=900,
                      help="view-sphere candidates")
    cell.add_argument("--json", help="write the report as JSON here")


def add_sensors(commands: Commands) -> None:
    add(commands, "sensors", command_sensors, "List the sensor presets (configs/sensors/).",
        config=False)


def add_robots(commands: Commands) -> None:
    robots = commands.add_parser("robots", help="Robots: the bundled ones, importing your own.")
    robot_commands = robots.add_subparsers(dest="robots_command", required=True)
    add(robot_commands, "list", command_robots_list, "List the bundled robots.", config=False)
    importer = add(robot_commands, "import", command_robots_import,
                   "Convert a serial arm's URDF into a robot folder.", config=False)
    importer.add_argument("urdf", help="the URDF file")
    importer.add_argument("--flange", required=True,
                          help="the link that carries the sensor (the flange frame)")
    importer.add_argument("--name", required=True, help="the robot's name")
    importer.add_argument("--out", help="the robot folder to write (default: robots/NAME)")
    importer.add_argument("--home", type=float, nargs="+", metavar="Q",
                          help="home configuration (rad); default: zero, mid-range where zero "
                               "is outside the limits")
    importer.add_argument("--base-position", type=float, nargs=3, metavar=("X", "Y", "Z"),
                          default=(0.0, 0.0, 0.5), help="base position in the cell (m)")
    importer.add_argument("--base-yaw", type=float, default=0.0,
                          help="base rotation about the world z axis (deg)")
    importer.add_argument("--base-tilt", type=float, default=0.0,
                          help="base rotation about its own y axis: 0 floor, 90 wall, "
                               "180 ceiling (deg)")
    importer.add_argument("--package", type=_package_path, action="append",
                          metavar="NAME=FOLDER",
                          help="folder of a ROS package named by package:// mesh paths")
    importer.add_argument("--force", action="store_true", help="replace an existing folder")


def command_reach(args: argparse.Namespace) -> int:
    """Answer "can the cell reach this view?" and optionally write the plan JSON."""
    import numpy as np

    from vprobot.cell.scene import Cell
    from vprobot.geometry.poses import Pose
    from vprobot.kinematics import OUT_OF_REACH, RobotArm, SensorTarget
    from vprobot.plan import plan_document, view_entry

    check_output_file(args.json, "--json", (".json",))
    target = SensorTarget.look_at(args.position, args.look_at)
    cell = Cell(config_of(args))
    arm = RobotArm(cell)
    joints = cell.joints
    q_from = joints.start
    if args.from_joints is not None:
        q_from = joints.check(args.from_joints, "--from-joints")
        if not joints.within_limits(q_from):
            raise ValueError(f"--from-joints {np.round(q_from, 4).tolist()} lies outside the "
                             f"joint limits {np.round(joints.lower, 4).tolist()} .. "
                             f"{np.round(joints.upper, 4).tolist()} rad")
    result = arm.reach(target, q_from)
    verdict = "REACHABLE" if result.reachable else f"UNREACHABLE ({result.reason})"
    print(f"robot {cell.robot.name}: sensor at {np.round(target.pose.position, 4).tolist()} "
          f"looking at {np.round(args.look_at, 4).tolist()}: {verdict}")
    if result.reason == OUT_OF_REACH:
        distance = np.linalg.norm(target.pose.position - arm.shoulder_position)
        print(f"  out of the robot's reach: the sensor position lies {distance:.3f} m from its "
              f"shoulder, which reaches {arm.reach_radius_m:.3f} m at most (no IK attempt)")
    else:
        print(f"  IK: {result.attempts} attempt(s), {result.iterations} iterations, residual "
              f"{result.position_error_m * 1e3:.3f} mm / {result.orientation_error_deg:.3f} deg")
    view = view_entry(pose=target.pose, joints=None, reachable=False, reason=result.reason)
    if result.reachable:
        travel = arm.travel(q_from, result.q, cell.object_center, result.motion)
        print(f"  joints [rad]: {np.round(result.q, 4).tolist()}")
        print(f"  travel from start: {travel.joint_time:.3f} s joint time, "
              f"{travel.joint_path:.3f} rad joint path, {travel.cartesian:.3f} m sensor path")
        reached: Pose = arm.fk(result.q)
        view = view_entry(pose=reached, joints=result.q, reachable=True, travel=travel)
    write_json(args.json, plan_document(cell, [view]))
    return 0 if result.reachable else 1


def command_cell(args: argparse.Namespace) -> int:
    """Report how much of the view sphere around the part the robot reaches."""
    import numpy as np

    from vprobot.cell.check import check_cell
    from vprobot.kinematics import RobotArm
    from vprobot.kinematics.survey import default_cell, view_sphere_survey, view_sphere_targets

    check_output_file(args.json, "--json", (".json",))
    config = config_of(args)
    cell = default_cell(config)
    # A survey from a start pose that already collides would count every view unreachable.
    with naming_the_cell(args):
        check_cell(cell, cell.make_data())
    arm = RobotArm(cell)
    targets = view_sphere_targets(cell, args.candidates)
    survey = view_sphere_survey(arm, targets, progress=True, label=cell.robot.name)
    heights = np.array([t.pose.position[2] - cell.object_center[2] for t in targets])
    polar = np.degrees(np.arccos(np.clip(heights / config.sensor.working_distance_m, -1, 1)))
    reachable = np.array(survey["reachable"])
    print(f"cell: {cell.robot.name} base at {np.round(cell.robot_base.position, 4).tolist()} m, "
          f"motor centre "
          f"at {list(config.cell.object_center_m)} m, views at "
          f"{config.sensor.working_distance_m} m looking at the centre")
    print("polar angle from the top   candidates   reachable")
    for low in range(0, 120, 15):
        band = (polar >= low) & (polar < low + 15)
        if band.any():
            print(f"  {low:3d}-{low + 15:3d} deg             {band.sum():5d}     "
                  f"{reachable[band].mean():7.1%}")
    print(f"all                          {len(targets):5d}     {survey['fraction']:7.1%}")
    print("unreachable, by reason (docs/cell-and-robots.md#reachability)" if survey["reasons"]
          else "unreachable: none")
    for reason, count in survey["reasons"].items():
        print(f"  {reason:<26} {count:5d}     {count / len(targets):7.1%}")
    write_json(args.json, {"robot": cell.robot.name, "fraction": survey["fraction"],
                           "reasons": survey["reasons"]})
    return 0


def command_sensors(args: argparse.Namespace) -> int:
    """List the sensor presets: resolution, opening angles, range, working distance, default
    sensing model, structured-light figures and the file that gives their sources."""
    from vprobot.config import sensor_preset

    print("preset            resolution    fov (deg)        range (m)      working distance (m)  "
          "sensing           structured light (baseline, max incidence camera / projector, noise, "
          "dropout)  sources")
    for name in available_sensors():
        sensor = sensor_preset(name)
        light = sensor.structured_light
        figures = ("-" if light is None else
                   f"{light.baseline_m * 1e3:g} mm, {light.max_incidence_deg:g} / "
                   f"{light.projector_max_incidence_deg:g} deg, {light.noise_sigma_m * 1e3:g} mm "
                   f"at {light.noise_distance_m:g} m, {light.dropout_grazing:g} (theta / 90 deg)"
                   f"^{light.dropout_exponent:g}")
        print(f"{name:<17} {sensor.resolution[0]:>4} x {sensor.resolution[1]:<4}   "
              f"{sensor.fov_deg[0]:5.2f} x {sensor.fov_deg[1]:5.2f}   "
              f"{sensor.near_m:.3f} - {sensor.far_m:.3f}  {sensor.working_distance_m:.3f}"
              f"                  {sensor.sensing:<17} {figures}  configs/sensors/{name}.yaml")
    return 0


def command_robots_list(args: argparse.Namespace) -> int:
    from vprobot.robots import load_robot

    print("robot    joints  base (m)            yaw, tilt (deg)  flange")
    for name in available_robots():
        robot = load_robot(name)
        print(f"{name:8s} {robot.dof:6d}  {list(robot.base_position_m)!s:19s} "
              f"{robot.base_yaw_deg:5.0f}, {robot.base_tilt_deg:4.0f}      {robot.flange}")
    return 0


def _package_path(text: str) -> tuple[str, Path]:
    name, separator, folder = text.partition("=")
    if not separator or not name or not folder:
        raise argparse.ArgumentTypeError(f"must be NAME=FOLDER, got {text!r}")
    return name, Path(folder)


def command_robots_import(args: argparse.Namespace) -> int:
    """Convert a URDF into a robot folder and report its reachability of the view sphere."""
    from vprobot.importers.urdf import Provenance, convert_urdf

    out = Path(args.out if args.out is not None else Path("robots") / args.name)
    robot = convert_urdf(
        args.urdf, args.name, args.flange, out,
        provenance=Provenance(title=args.name, source=f"`{args.urdf}`"),
        home=args.home, base_position_m=args.base_position, base_yaw_deg=args.base_yaw,
        base_tilt_deg=args.base_tilt, package_paths=dict(args.package or []),
        overwrite=args.force)
    print(f"wrote {out}: {robot.dof} joints from {robot.base!r} to {robot.flange!r}, pan "
          f"{robot.pan_joint!r}, roll {robot.roll_joint!r}")
    print(f"use it with --robot {out} (or cell.robot: {out}); `vprobot cell --robot {out}` "
          f"reports how much of the view sphere it reaches from its base placement")
    return 0

