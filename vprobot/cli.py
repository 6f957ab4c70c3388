"""The `vprobot` command line."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config, ConfigError, load_config, replace
from vprobot.robots import available_robots


def _config(args: argparse.Namespace) -> Config:
    """The config file (or the default), with `--robot` applied when given."""
    config = load_config(args.config)
    if getattr(args, "robot", None):
        config = replace(config, "cell", robot=args.robot)
    return config


def _write_json(path: str | None, document: dict[str, Any]) -> None:
    if path:
        from vprobot.plan_export import write_json

        print(f"wrote {write_json(path, document)}")


def command_reach(args: argparse.Namespace) -> int:
    """Answer "can the cell reach this view?" and optionally write the plan JSON."""
    from vprobot.geometry import Pose
    from vprobot.kinematics import RobotArm, SensorTarget
    from vprobot.plan_export import PlannedView, plan_document
    from vprobot.scene import Cell

    target = SensorTarget.look_at(args.position, args.look_at)
    cell = Cell(_config(args))
    arm = RobotArm(cell)
    q_from = cell.joints.home if args.from_joints is None else cell.joints.check(args.from_joints)
    result = arm.reach(target, q_from)
    verdict = "REACHABLE" if result.reachable else f"UNREACHABLE ({result.reason})"
    print(f"robot {cell.robot}: sensor at {np.round(target.pose.position, 4).tolist()} looking at "
          f"{np.round(args.look_at, 4).tolist()}: {verdict}")
    print(f"  IK: {result.attempts} attempt(s), {result.iterations} iterations, residual "
          f"{result.position_error_m * 1e3:.3f} mm / {result.orientation_error_deg:.3f} deg")
    view = PlannedView(pose=target.pose, joints=None, reachable=False, reason=result.reason)
    if result.reachable:
        travel = arm.travel(q_from, result.q, cell.object_center)
        print(f"  joints [rad]: {np.round(result.q, 4).tolist()}")
        print(f"  travel from start: {travel.joint_time:.3f} s joint time, "
              f"{travel.joint_path:.3f} rad joint path, {travel.cartesian:.3f} m sensor path")
        reached: Pose = arm.fk(result.q)
        view = PlannedView(pose=reached, joints=result.q, reachable=True, travel=travel)
    _write_json(args.json, plan_document(cell, [view]))
    return 0 if result.reachable else 1


def command_cell(args: argparse.Namespace) -> int:
    """Report how much of the view sphere around the motor the robot reaches."""
    from vprobot.benchmarks.kinematics import default_cell, view_sphere_survey, view_sphere_targets
    from vprobot.kinematics import RobotArm

    config = _config(args)
    cell = default_cell(config)
    arm = RobotArm(cell)
    targets = view_sphere_targets(cell, args.candidates)
    survey = view_sphere_survey(arm, targets, progress=True, label=cell.robot)
    heights = np.array([t.pose.position[2] - cell.object_center[2] for t in targets])
    polar = np.degrees(np.arccos(np.clip(heights / config.sensor.working_distance_m, -1, 1)))
    reachable = np.array(survey["reachable"])
    print(f"cell: {cell.robot} base at {list(config.cell.robot_base_position_m)} m, motor centre "
          f"at {list(config.cell.object_center_m)} m, views at "
          f"{config.sensor.working_distance_m} m looking at the centre")
    print("polar angle from the top   candidates   reachable")
    for low in range(0, 120, 15):
        band = (polar >= low) & (polar < low + 15)
        if band.any():
            print(f"  {low:3d}-{low + 15:3d} deg             {band.sum():5d}     "
                  f"{reachable[band].mean():7.1%}")
    print(f"all                          {len(targets):5d}     {survey['fraction']:7.1%}")
    print(f"failures: {survey['reasons']}")
    _write_json(args.json, {"robot": cell.robot, "fraction": survey["fraction"],
                            "reasons": survey["reasons"]})
    return 0


def command_plan(args: argparse.Namespace) -> int:
    """Plan the inspection of a motor, write the plan JSON and optionally a video."""
    from vprobot.plan_export import write_json
    from vprobot.planners import plan_motor

    _check_outputs(args)
    scene, record, document, summary = plan_motor(_config(args), args.mesh, args.scale,
                                                  args.planner, args.views, args.carrier,
                                                  args.seed)
    print(summary)
    print(f"wrote {write_json(args.out, document)}")
    _render_outputs(args, scene, record)
    return 0


def command_render(args: argparse.Namespace) -> int:
    """Render an inspection (a plan JSON, or a planner's run) as a video."""
    from vprobot.planners import plan_motor
    from vprobot.render import episode_from_plan

    _check_outputs(args)
    config = _config(args)
    if args.plan:
        scene, record = episode_from_plan(config, args.plan)
    else:
        scene, record, _, summary = plan_motor(config, args.mesh, args.scale, args.planner,
                                               args.views, args.carrier, args.seed)
        print(summary)
    _render_outputs(args, scene, record)
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Fail before the long work when an output folder does not exist."""
    for option in ("out", "video", "summary"):
        path = getattr(args, option, None)
        if path and not Path(path).parent.is_dir():
            raise ValueError(f"--{option}: folder {Path(path).parent} does not exist")


def _render_outputs(args: argparse.Namespace, scene: Any, record: Any) -> None:
    from vprobot.render import render_episode, render_summary

    video = args.video if args.command == "plan" else args.out
    if video:
        rendered = render_episode(scene, record, video, width=args.width, height=args.height,
                                  progress=True)
        print(f"wrote {rendered.path} ({rendered.frames} frames, {rendered.duration_s:.1f} s)")
    if args.summary:
        print(f"wrote {render_summary(scene, record, args.summary)}")


def command_evaluate(args: argparse.Namespace) -> int:
    """Compare planners on one episode list; write evaluation.md, .csv and episodes.json."""
    from vprobot.evaluation import evaluate, evaluation_episodes

    config = _config(args)
    specs = evaluation_episodes(config, args.motors, args.seeds, args.episodes)
    evaluate(config, args.planners, specs, args.out, progress=True, carriers=args.carriers)
    print((Path(args.out) / "evaluation.md").read_text())
    return 0


def _print_results(results: dict[str, Any]) -> None:
    width = max(len(key) for key in results)
    for key, value in results.items():
        shown = f"{value:.3f}" if isinstance(value, float) else json.dumps(value)
        print(f"{key:<{width}}  {shown}")


def command_benchmark(args: argparse.Namespace) -> int:
    config = _config(args)
    printer: Callable[[dict[str, Any]], None] = _print_results
    if args.suite == "kinematics":
        from vprobot.benchmarks.kinematics import run_kinematics_benchmark

        results = run_kinematics_benchmark(config, samples=args.samples)
    elif args.suite == "env":
        from vprobot.benchmarks.env import run_env_benchmark

        results = run_env_benchmark(config, steps=args.samples)
    elif args.suite == "planners":
        from vprobot.benchmarks.planners import print_table, run_planners_benchmark

        results, printer = run_planners_benchmark(config), print_table
    elif args.suite == "render":
        from vprobot.benchmarks.render import run_render_benchmark

        results = run_render_benchmark(config)
    else:
        from vprobot.benchmarks.sensor import print_table, run_sensor_benchmark

        results, printer = run_sensor_benchmark(config), print_table
    printer(results)
    _write_json(args.json, results)
    return 0


def command_motors_generate(args: argparse.Namespace) -> int:
    from vprobot.motors import generate_motors

    paths = generate_motors(args.count, args.seed, Path(args.out))
    print(f"wrote {len(paths)} motors to {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vprobot", description="Robot-guided visual inspection planning in MuJoCo."
    )
    commands = parser.add_subparsers(dest="command", required=True)

    def add(name: str, handler: Callable[[argparse.Namespace], int], help_text: str,
            parent: Any = commands) -> argparse.ArgumentParser:
        sub = parent.add_parser(name, help=help_text, description=help_text)
        sub.set_defaults(handler=handler)
        sub.add_argument("--config", help="YAML config (default: configs/default.yaml)")
        return sub

    def add_robot(sub: argparse.ArgumentParser) -> None:
        sub.add_argument("--robot", choices=available_robots(),
                         help="robot to use instead of the config's")

    reach = add("reach", command_reach, "Can the cell reach this sensor view?")
    add_robot(reach)
    reach.add_argument("--position", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="sensor position in the world (m)")
    reach.add_argument("--look-at", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="point the sensor looks at (m)")
    reach.add_argument("--from-joints", type=float, nargs="+", metavar="Q",
                       help="start configuration (rad); default: the home keyframe")
    reach.add_argument("--json", help="write the plan JSON (SPEC section 12) here")

    cell = add("cell", command_cell, "Reachability report of the cell's view sphere.")
    add_robot(cell)
    cell.add_argument("--candidates", type=int, default=900, help="view-sphere candidates")
    cell.add_argument("--json", help="write the report as JSON here")

    def add_planning(sub: argparse.ArgumentParser) -> None:
        from vprobot.planners.runner import PLANNER_NAMES

        add_robot(sub)
        sub.add_argument("--mesh", help="mesh file (STL/OBJ/PLY); default: the bundled motor")
        sub.add_argument("--scale", type=float, default=1.0,
                         help="file units to metres, e.g. 0.001 for millimetres")
        sub.add_argument("--planner", choices=PLANNER_NAMES, default="bscp")
        sub.add_argument("--views", type=int,
                         help="fixed number of views (bscp); default: until the coverage goal")
        sub.add_argument("--seed", type=int, default=0,
                         help="seed of the episode (object pose, initial view)")
        sub.add_argument("--carrier", choices=["robot", "free"], default="robot",
                         help="robot in the loop, or a free-flying sensor (as in the paper)")
        sub.add_argument("--summary", help="also write a summary PNG here")
        sub.add_argument("--width", type=int, default=640, help="video width (pixels)")
        sub.add_argument("--height", type=int, default=480, help="video height (pixels)")

    plan = add("plan", command_plan, "Plan the inspection of a motor and write the plan JSON.")
    add_planning(plan)
    plan.add_argument("--out", required=True, help="plan JSON to write")
    plan.add_argument("--video", help="also render the rollout to this .mp4 or .gif")

    render = add("render", command_render,
                 "Render an inspection (a plan JSON or a planner's run) as an MP4 or GIF.")
    add_planning(render)
    render.add_argument("--plan", help="plan JSON (SPEC section 12) to replay instead")
    render.add_argument("--out", required=True, help="video to write (.mp4 or .gif)")

    evaluation = add("evaluate", command_evaluate, "Compare planners on the test motors.")
    add_robot(evaluation)
    evaluation.add_argument("--planners", nargs="+", default=[
        "random1", "random2", "hrec", "bscp", "bscp4", "bscp5", "oracle"],
        help="planner names, or bscp<N> for B_SCP with N views")
    evaluation.add_argument("--episodes", help="episode list (JSON, as written into --out); "
                            "default: the bundled list over the test motors")
    evaluation.add_argument("--motors", nargs="+",
                            help="mesh files to draw episodes for instead (default: the test "
                            "motors)")
    evaluation.add_argument("--seeds", type=int, nargs="+",
                            help="seeds to draw episodes for instead (default: 0 1 2)")
    evaluation.add_argument("--carriers", nargs="+", choices=["robot", "free"],
                            default=["robot", "free"])
    evaluation.add_argument("--out", default="results", help="folder for the tables")

    benchmark = add("benchmark", command_benchmark, "Measure the speed and quality targets.")
    add_robot(benchmark)
    benchmark.add_argument("suite",
                           choices=["kinematics", "sensor", "env", "planners", "render"])
    benchmark.add_argument("--samples", type=int, default=200,
                           help="random targets (kinematics) or steps (env) per measure")
    benchmark.add_argument("--json", help="write the results as JSON here")

    motors = commands.add_parser("motors", help="Synthetic starter motors.")
    motor_commands = motors.add_subparsers(dest="motors_command", required=True)
    generate = add("generate", command_motors_generate, "Generate seeded starter motors.",
                   motor_commands)
    generate.add_argument("--count", type=int, required=True)
    generate.add_argument("--seed", type=int, default=0)
    generate.add_argument("--out", required=True, help="output folder")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.handler(args)
    except (ConfigError, ValueError, FileNotFoundError) as error:
        print(f"vprobot {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
