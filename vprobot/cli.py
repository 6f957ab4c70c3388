"""The `vprobot` command line.

The module imports what a command runs when it runs (planners, the renderer, training, the
benchmarks), so that `vprobot --help` and a bad option answer at once; those imports inside the
command functions are the only ones in vprobot without a comment of their own.

Exit codes: 0 success; 1 only where a command documents it (`reach`: the view is unreachable);
2 a user error (bad option, config, mesh, plan or output path), reported as one line on stderr;
130 interrupted (Ctrl-C or SIGTERM; `evaluate` keeps the episodes it finished).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from vprobot import plugins
from vprobot.config import (
    Config,
    available_sensors,
    load_config,
    replace,
    with_sensing,
    with_sensor,
)
from vprobot.export import CHECK_DT_S, EXPORT_DT_S, SUFFIXES
from vprobot.outputs import check_output_file, check_output_folder
from vprobot.progress import showing_progress
from vprobot.robots import available_robots, load_robot
from vprobot.sensing import SENSING_MODELS

VIDEO_SUFFIXES = (".mp4", ".gif")
PLANNING_OPTIONS = ("mesh", "scale", "planner", "views", "seed", "carrier", "stop", "estimator")
"""Options that choose what `plan` or `render` plans; a replayed `--plan` fixes them all."""
INTERRUPTED = 130


def _config(args: argparse.Namespace) -> Config:
    """The config file (or the default), with `--robot`, `--sensor` and `--sensing` applied
    when given."""
    config = load_config(args.config)
    if getattr(args, "robot", None):
        try:
            load_robot(args.robot)
        except ValueError as error:  # named as the user gave it, not as the config key
            raise ValueError(f"--robot: {error}") from None
        config = replace(config, "cell", robot=args.robot)
    return _sensor_option(config, args)


def _sensor_option(config: Config, args: argparse.Namespace) -> Config:
    """`config` with the `--sensor` preset, when given, in place of its sensor (same mount),
    then with the `--sensing` model, when given."""
    if getattr(args, "sensor", None):
        config = with_sensor(config, args.sensor)
    if getattr(args, "sensing", None):
        try:
            config = with_sensing(config, args.sensing)
        except ValueError as error:  # named as the user gave it
            raise ValueError(f"--sensing: {error}") from None
    return config


def _write_json(path: str | None, document: dict[str, Any]) -> None:
    if path:
        from vprobot.plan_export import write_json

        print(f"wrote {write_json(path, document)}")


def _number(kind: type, low: float, strict: bool, what: str,
            high: float = math.inf) -> Callable[[str], Any]:
    """An argparse type: a number of `kind` above `low`, at most `high` (argparse names the
    option)."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
        # Integers are finite (and may exceed what a float or numpy holds).
        if (kind is float and not math.isfinite(value)) or value < low or (
                strict and value == low):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        if value > high:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}, which is too large")
        return value

    parse.__name__ = what
    return parse


EVALUATED_PLANNERS = ("random1", "random2", "uniform4", "uniform5", "uniform6", "nbv", "nbv@grid",
                      "agent", "hrec", "bscp", "bscp4", "bscp5", "oracle")
"""What `evaluate` compares by default: every planner, the model-free ones first."""


def _planner_name(text: str) -> str:
    """An argparse type: a planner name, `agent` or `agent:PATH` (the view count goes in
    `--views`)."""
    from vprobot.planners.runner import parse_planner

    try:
        return parse_planner(text, counted=False)[0]
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _stop_rule(text: str) -> str:
    """An argparse type: a stop rule (`goal`, `estimate:0.9`, `views:5`, ...)."""
    from vprobot.stopping.rules import parse_stop

    try:
        parse_stop(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def _family_name(text: str) -> str:
    """An argparse type: a registered part family."""
    from vprobot.families import FAMILIES

    try:
        return FAMILIES[text].name
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


NON_NEGATIVE_INT = _number(int, 0, False, "an integer >= 0")
POSITIVE_INT = _number(int, 0, True, "an integer >= 1")
POSITIVE_FLOAT = _number(float, 0.0, True, "a number > 0")
MAX_COUNT = 10_000
"""Most objects one `motors generate` or `objects generate` writes (0.1 to 1 s each)."""
COUNT = _number(int, 0, True, f"an integer in 1..{MAX_COUNT}", MAX_COUNT)


def _view_count(text: str) -> int:
    """An argparse type: a fixed number of views, 1..MAX_VIEWS."""
    from vprobot.planners.base import MAX_VIEWS

    return _number(int, 0, True, f"an integer in 1..{MAX_VIEWS}", MAX_VIEWS)(text)


def command_reach(args: argparse.Namespace) -> int:
    """Answer "can the cell reach this view?" and optionally write the plan JSON."""
    from vprobot.geometry import Pose
    from vprobot.kinematics import OUT_OF_REACH, RobotArm, SensorTarget
    from vprobot.plan_export import plan_document, view_entry
    from vprobot.scene import Cell

    check_output_file(args.json, "--json", (".json",))
    target = SensorTarget.look_at(args.position, args.look_at)
    cell = Cell(_config(args))
    arm = RobotArm(cell)
    joints = cell.joints
    q_from = joints.home
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
    _write_json(args.json, plan_document(cell, [view]))
    return 0 if result.reachable else 1


def command_cell(args: argparse.Namespace) -> int:
    """Report how much of the view sphere around the motor the robot reaches."""
    from vprobot.kinematics import RobotArm
    from vprobot.kinematics.survey import default_cell, view_sphere_survey, view_sphere_targets

    check_output_file(args.json, "--json", (".json",))
    config = _config(args)
    cell = default_cell(config)
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
    _write_json(args.json, {"robot": cell.robot.name, "fraction": survey["fraction"],
                            "reasons": survey["reasons"]})
    return 0


def _planning(args: argparse.Namespace) -> dict[str, Any]:
    """The planning options of `plan` / `render`, defaults filled in."""
    chosen = {name: getattr(args, name) for name in PLANNING_OPTIONS}
    defaults = {"scale": 1.0, "planner": "bscp", "seed": 0, "carrier": "robot", "stop": "goal"}
    return {name: defaults.get(name) if value is None else value
            for name, value in chosen.items()}


def command_plan(args: argparse.Namespace) -> int:
    """Plan the inspection of a motor, write the plan JSON and optionally a video."""
    from vprobot.plan_export import write_json
    from vprobot.planners.runner import plan_motor

    check_output_file(args.out, "--out", (".json",))
    _check_render_outputs(args, args.video, "--video")
    options = _planning(args)
    with showing_progress():
        scene, record, document, summary = plan_motor(
            _config(args), options["mesh"], options["scale"], options["planner"],
            options["views"], options["carrier"], options["seed"], options["stop"],
            options["estimator"])
    if args.no_timing:
        document.pop("timing")
    print(summary)
    print(f"wrote {write_json(args.out, document)}")
    _render_outputs(args, scene, record, args.video)
    return 0


def command_render(args: argparse.Namespace) -> int:
    """Render an inspection (a plan JSON, or a planner's run) as a video."""
    from vprobot.planners.runner import plan_motor
    from vprobot.render import episode_from_plan

    _check_render_outputs(args, args.out, "--out")
    config = _config(args)
    if args.plan:
        given = [f"--{name}" for name in (*PLANNING_OPTIONS, "robot", "sensor", "sensing")
                 if getattr(args, name) is not None]
        if given:
            raise ValueError(f"--plan replays a stored plan, which fixes the mesh, pose, robot, "
                             f"sensor, sensing model and views; {', '.join(given)} cannot be "
                             f"combined with it")
        with showing_progress():
            scene, record = episode_from_plan(config, args.plan)
    else:
        options = _planning(args)
        with showing_progress():
            scene, record, _, summary = plan_motor(
                config, options["mesh"], options["scale"], options["planner"],
                options["views"], options["carrier"], options["seed"], options["stop"],
                options["estimator"])
        print(summary)
    _render_outputs(args, scene, record, args.out)
    return 0


def command_export(args: argparse.Namespace) -> int:
    """Write a plan's motion as a trajectory, a CSV, a URScript program or a ROS 2 message."""
    from vprobot.export.formats import export_plan
    from vprobot.files import write_text
    from vprobot.render.replay import read_plan

    check_output_file(args.out, "--out", (SUFFIXES[args.format],))
    if Path(args.out).resolve() == Path(args.plan).resolve():
        raise ValueError(f"--out {args.out} is the plan itself; give another file")
    text = export_plan(read_plan(args.plan), args.format, args.dt)
    print(f"wrote {write_text(Path(args.out), text)}")
    return 0


def command_check(args: argparse.Namespace) -> int:
    """Replay a plan's trajectory in its cell; exit 1 when a limit, a collision or a view fails."""
    from vprobot.export.check import check_plan

    with showing_progress():
        result = check_plan(_config(args), args.plan, args.dt)
    print(result.report())
    return 0 if result.holds else 1


def _check_render_outputs(args: argparse.Namespace, video: str | None, option: str) -> None:
    """Fail before the long work when a video or summary output cannot be written."""
    check_output_file(video, option, VIDEO_SUFFIXES)
    check_output_file(args.summary, "--summary", (".png",))


def _render_outputs(args: argparse.Namespace, scene: Any, record: Any, video: str | None) -> None:
    from vprobot.render import render_episode, render_summary

    if video:
        rendered = render_episode(scene, record, video, width=args.width, height=args.height,
                                  progress=True)
        print(f"wrote {rendered.path} ({rendered.frames} frames, {rendered.duration_s:.1f} s)")
    if args.summary:
        print(f"wrote {render_summary(scene, record, args.summary)}")


def command_evaluate(args: argparse.Namespace) -> int:
    """Compare planners on one episode list; write evaluation.md, .csv, episodes.json and the
    coverage curves plot."""
    from vprobot.evaluation import EPISODES_NAME, PLOT_NAME, evaluate, evaluation_episodes

    check_output_folder(args.out, "--out")
    config = _config(args)
    specs = evaluation_episodes(config, args.motors, args.seeds, args.episodes)
    evaluate(config, args.planners, specs, args.out, progress=True, carriers=args.carriers,
             workers=args.workers, address=args.address, stops=args.stop,
             estimator=args.estimator)
    print((Path(args.out) / "evaluation.md").read_text())
    print(f"coverage curves: {Path(args.out) / PLOT_NAME}")
    with (Path(args.out) / EPISODES_NAME).open(newline="") as stream:
        empty = [f"{row['planner']} ({row['carrier']}) on episode {row['episode']}"
                 for row in csv.DictReader(stream) if row["requested"] == "0"]
    if empty:
        print(f"note: {len(empty)} episode(s) requested no view, covering nothing (the robot "
              f"reached no initial view, or no candidate view was usable): {'; '.join(empty)}")
    return 0


def command_train(args: argparse.Namespace) -> int:
    """Train an agent into a run directory, or resume one."""
    from vprobot.agents.training import profile_config, train

    if args.profile is None and not args.resume:
        raise ValueError("give a profile (e.g. configs/agents/cpu.yaml), or --resume a run")
    if args.resume and (args.profile is not None or args.set or args.steps is not None
                        or args.seed is not None or args.sensor is not None
                        or args.sensing is not None or args.seeds is not None):
        raise ValueError("--resume goes on with the run's own profile, overrides, sensor, "
                         "sensing, steps and seed; give only --out (and --device)")
    if args.seeds is not None and args.seed is not None:
        raise ValueError("give --seed (one run) or --seeds (one run per seed), not both")
    if args.seeds is None and (args.workers is not None or args.address is not None):
        raise ValueError("--workers and --address run the seeds of --seeds on Ray; add --seeds")
    check_output_folder(args.out, "--out")
    config = (None if args.resume
              else _sensor_option(profile_config(args.profile, args.set, args.steps), args))
    if args.seeds is not None and config is not None:  # (--resume takes no --seeds)
        from vprobot.agents.seeds import train_seeds

        command = ["vprobot", "train", args.profile, *(["--set", *args.set] if args.set else []),
                   *(["--sensor", args.sensor] if args.sensor else []),
                   *(["--sensing", args.sensing] if args.sensing else []),
                   *(["--steps", str(args.steps)] if args.steps is not None else [])]
        train_seeds(config, args.out, args.seeds, command, device=args.device,
                    workers=args.workers, address=args.address)
        print((Path(args.out) / "seeds.md").read_text())
        return 0
    result = train(config, args.out, seed=args.seed or 0, resume=args.resume,
                   device=args.device, argv=["vprobot", *args.argv])
    best = result["best"]
    print(f"trained {result['steps']:,} steps in {result['wall_s'] / 60:.1f} min; on the "
          f"validation episodes:")
    print(f"  best model (the one kept, agent.select), from step {best['step']:,.0f}: "
          f"{_scores(best)}: {Path(args.out) / 'best_model.zip'}")
    print(f"  final model, step {result['steps']:,}: {_scores(result)}"
          + ("" if result["reachable_pct"] is None
             else f", {result['reachable_pct']:.0f} % of requests reachable"))
    if result["curves"] is None:
        print(f"run directory: {args.out} (evaluations.csv); no finished episodes yet, so no "
              f"curves.png: more --steps, or `vprobot curves` later")
    else:
        print(f"run directory: {args.out} (curves.png, evaluations.csv)")
    return 0


def command_teacher(args: argparse.Namespace) -> int:
    """Roll out a profile's teacher episodes into its teacher folder, on several cores."""
    from vprobot.agents.pretrain import collect
    from vprobot.agents.training import profile_config

    config = _sensor_option(profile_config(args.profile, args.set), args)
    folder = args.out or config.agent.teacher_dir
    if folder is None:
        raise ValueError("give --out FOLDER, or a profile with agent.teacher_dir (the folder "
                         "its runs read the teacher's states from)")
    if config.agent.pretrain_episodes < 1:
        raise ValueError(f"{args.profile} has no teacher: its agent.pretrain_episodes is "
                         f"{config.agent.pretrain_episodes}")
    states = collect(config, config.agent.pretrain_episodes, args.seed, Path(folder),
                     workers=args.workers, progress=True)
    print(f"{config.agent.pretrain_episodes} teacher episodes, {len(states):,} states, are in "
          f"{folder}")
    return 0


def _scores(row: dict[str, Any]) -> str:
    """An evaluation on the validation episodes, as `train` reports it."""
    return (f"coverage {row['coverage_pct']:.1f} %, {row['acquisitions']:.2f} acquisitions, "
            f"{row['success_pct']:.0f} % at the goal")


def command_sweep(args: argparse.Namespace) -> int:
    """Run a study of agent configurations on Ray."""
    from vprobot.agents.sweep import sweep

    check_output_folder(args.out, "--out")
    sweep(args.study, args.out, resume=args.resume, address=args.address,
          workers=args.workers)
    print((Path(args.out) / "study.md").read_text())
    return 0


def command_curves(args: argparse.Namespace) -> int:
    """Plot training curves of one or more runs."""
    from vprobot.agents.curves import plot_curves

    check_output_file(args.out, "--out", (".png",))
    print(f"wrote {plot_curves(args.runs, args.out, args.window)}")
    return 0


def _print_results(results: dict[str, Any]) -> None:
    width = max(len(key) for key in results)
    for key, value in results.items():
        shown = f"{value:.3f}" if isinstance(value, float) else json.dumps(value)
        print(f"{key:<{width}}  {shown}")


def command_benchmark(args: argparse.Namespace) -> int:
    check_output_file(args.json, "--json", (".json",))
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
    elif args.suite == "train":
        from vprobot.benchmarks.train import run_train_benchmark

        results = run_train_benchmark(config, steps=args.samples)
    elif args.suite == "cluster":
        from vprobot.benchmarks.cluster import run_cluster_benchmark

        results = run_cluster_benchmark(config)
    elif args.suite == "render":
        from vprobot.benchmarks.render import run_render_benchmark

        results = run_render_benchmark(config)
    elif args.suite == "objects":
        from vprobot.benchmarks.objects import run_objects_benchmark

        results = run_objects_benchmark(config)
    elif args.suite == "mesh":
        from vprobot.benchmarks.large_mesh import run_large_mesh_benchmark

        # The suite runs `vprobot plan` itself, with this command's cell options.
        results = run_large_mesh_benchmark(config, [
            item for option in ("config", "robot", "sensor") if getattr(args, option)
            for item in (f"--{option}", str(getattr(args, option)))])
    elif args.suite == "motion":
        from vprobot.benchmarks.motion import print_table, run_motion_benchmark

        results, printer = run_motion_benchmark(config, samples=args.samples), print_table
    else:
        from vprobot.benchmarks.sensor import print_table, run_sensor_benchmark

        results, printer = run_sensor_benchmark(config), print_table
    printer(results)
    _write_json(args.json, results)
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


def command_motors_generate(args: argparse.Namespace) -> int:
    from vprobot.motors import generate_motors

    check_output_folder(args.out, "--out")
    paths = generate_motors(args.count, args.seed, Path(args.out))
    print(f"wrote {len(paths)} motors to {args.out}")
    return 0


def command_objects(args: argparse.Namespace) -> int:
    """`objects list`: each part family with its parameters; `objects generate`: write
    instances of one family."""
    from vprobot.families import FAMILIES, generate_instances

    if args.objects_command == "list":
        for part in FAMILIES.values():
            print(f"{part.name}: {part.description}")
            for p in part.parameters:
                print(f"  {p.name:24s} {p.range_text():18s} {p.description}")
        return 0
    if args.objects_command == "cache":
        from vprobot.agents.training import profile_config
        from vprobot.env.inspect_env import build_training_objects
        from vprobot.paths import cache_root

        count = build_training_objects(profile_config(args.profile, args.set))
        print(f"{count} training objects and their ground truth are in {cache_root()}")
        return 0
    check_output_folder(args.out, "--out")
    paths = generate_instances(args.family, args.count, args.seed, Path(args.out))
    print(f"wrote {len(paths)} {args.family} parts to {args.out}")
    return 0


def command_stop_fit(args: argparse.Namespace) -> int:
    """Fit the model-free coverage estimate on rollouts of split v1 and report it."""
    from vprobot.stopping.report import fit_estimate

    check_output_folder(args.out, "--out")
    figures = fit_estimate(_config(args), args.out, args.episodes, args.seed, args.planners)
    print((Path(args.out) / "estimate.md").read_text())
    print(f"estimator: {Path(args.out) / 'estimator.npz'}; validation MAE "
          f"{figures['mae_pp']:.2f} pp")
    return 0


def command_stop_error(args: argparse.Namespace) -> int:
    """Score the coverage estimate on episode lists (rollouts of model-free planners)."""
    from vprobot.stopping.report import score_estimate

    check_output_folder(args.out, "--out")
    with showing_progress():
        score_estimate(_config(args), args.out, args.episodes, args.planners, args.estimator)
    print((Path(args.out) / "error.md").read_text())
    return 0


def command_stop_study(args: argparse.Namespace) -> int:
    """Run the stop study: every stop rule with every planner it applies to, robot in the
    loop, on the episode lists."""
    from vprobot.stopping.study import stop_study

    check_output_folder(args.out, "--out")
    with showing_progress():
        stop_study(_config(args), args.out, args.episodes, args.planners, args.stop,
                   args.estimator, args.workers)
    print((Path(args.out) / "study.md").read_text())
    print(f"plot: {Path(args.out) / 'study.png'}")
    return 0


def command_robots_list(args: argparse.Namespace) -> int:
    from vprobot.robots import available_robots, load_robot

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
    from vprobot.robots.urdf_import import Provenance, convert_urdf

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


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like every other user error (the usage is
    for --help); its subcommands' parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="vprobot", description="Robot-guided visual inspection planning in MuJoCo."
    )
    parser.add_argument("--plugin", action="append", metavar="MODULE",
                        help="import this module first, to use what it registers (a planner, "
                        "a reward, ...): a module name or a .py file; repeatable; besides the "
                        "vprobot.plugins entry points (docs/extending.md#plugins)")
    commands = parser.add_subparsers(dest="command", required=True)

    def add(name: str, handler: Callable[[argparse.Namespace], int], help_text: str,
            parent: Any = commands, config: bool = True) -> argparse.ArgumentParser:
        sub = parent.add_parser(name, help=help_text, description=help_text)
        sub.set_defaults(handler=handler, prog=sub.prog)
        if config:  # train and sweep take their configuration from a profile instead
            sub.add_argument("--config", help="YAML config (default: configs/default.yaml)")
        return sub

    def add_robot(sub: argparse.ArgumentParser) -> None:
        sub.add_argument("--robot", metavar="ROBOT",
                         help=f"robot to use instead of the config's: "
                              f"{', '.join(available_robots())} or a robot folder")
        add_sensor(sub)

    def add_sensor(sub: argparse.ArgumentParser) -> None:
        sub.add_argument("--sensor", choices=available_sensors(),
                         help="sensor preset (configs/sensors/) to use instead of the config's "
                         "sensor, on the config's mount")
        sub.add_argument("--sensing", choices=SENSING_MODELS,
                         help="sensing model instead of the sensor's (docs/sensor.md#sensing); "
                         "structured_light needs a preset with its figures (`vprobot sensors`)")

    def add_stop(sub: argparse.ArgumentParser, many: Sequence[str] | None = None) -> None:
        """`--stop RULE`, or with `many` (their default) `--stop RULE [RULE ...]`."""
        from vprobot.stopping.rules import stop_names

        sub.add_argument("--stop", type=_stop_rule, nargs=None if many is None else "+",
                         default=None if many is None else list(many),
                         help=f"when to stop{'' if many is None else ' (each rule in turn)'}: "
                         f"{', '.join(stop_names())}; goal: the simulator's stop at the "
                         f"coverage goal, estimate: the model-free coverage estimate reaches it "
                         f"with confidence C, grid: the seen surface stops growing, views:N: "
                         f"after N acquisitions, agent: the agent's learned stop action "
                         f"(docs/planners.md#stop-rules); default: "
                         f"{'goal' if many is None else ' '.join(many)}")
        sub.add_argument("--estimator", metavar="PATH",
                         help="coverage estimator (estimator.npz of `vprobot stop fit`) for "
                         "--stop estimate and the per-view estimates; default: the bundled one")

    reach = add("reach", command_reach, "Can the cell reach this sensor view?")
    add_robot(reach)
    reach.add_argument("--position", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="sensor position in the world (m)")
    reach.add_argument("--look-at", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                       help="point the sensor looks at (m)")
    reach.add_argument("--from-joints", type=float, nargs="+", metavar="Q",
                       help="start configuration (rad); default: the home keyframe")
    reach.add_argument("--json", help="write the plan JSON (docs/plan-format.md) here")

    cell = add("cell", command_cell, "Reachability report of the cell's view sphere.")
    add_robot(cell)
    cell.add_argument("--candidates", type=POSITIVE_INT, default=900,
                      help="view-sphere candidates")
    cell.add_argument("--json", help="write the report as JSON here")

    def add_planning(sub: argparse.ArgumentParser) -> None:
        from vprobot.planners.runner import counted_planners, planner_names

        add_robot(sub)
        sub.add_argument("--mesh", help="mesh file (STL/OBJ/PLY); default: the bundled motor")
        sub.add_argument("--scale", type=POSITIVE_FLOAT,
                         help="file units to metres, e.g. 0.001 for millimetres (default 1)")
        sub.add_argument("--planner", type=_planner_name,
                         help=f"{', '.join(planner_names())}: agent is the bundled trained "
                         f"agent, agent:NAME another bundled one (cpu: motors only), "
                         f"agent:PATH a training run or model .zip, nbv@RULE nbv "
                         f"stopping itself by a --stop rule (nbv@grid); default: bscp")
        sub.add_argument("--views", type=_view_count,
                         help=f"fixed number of views ({', '.join(counted_planners())}); "
                         f"default: until the coverage goal")
        sub.add_argument("--seed", type=NON_NEGATIVE_INT,
                         help="seed of the episode (object pose, initial view); default 0")
        sub.add_argument("--carrier", choices=["robot", "free"],
                         help="robot in the loop (default), or a free-flying sensor (the paper)")
        add_stop(sub)
        sub.add_argument("--summary", help="also write a summary PNG here")
        sub.add_argument("--width", type=POSITIVE_INT, default=640, help="video width (pixels)")
        sub.add_argument("--height", type=POSITIVE_INT, default=480,
                         help="video height (pixels)")

    plan = add("plan", command_plan, "Plan the inspection of a motor and write the plan JSON.")
    add_planning(plan)
    plan.add_argument("--out", required=True, help="plan JSON to write")
    plan.add_argument("--video", help="also render the rollout to this .mp4 or .gif")
    plan.add_argument("--no-timing", action="store_true",
                      help="leave the timing block out of the plan JSON, so that the same "
                      "inputs give the same file byte for byte")

    render = add("render", command_render,
                 "Render an inspection (a plan JSON or a planner's run) as an MP4 or GIF.")
    add_planning(render)
    render.add_argument("--plan", help="plan JSON (docs/plan-format.md) to replay instead")
    render.add_argument("--out", required=True, help="video to write (.mp4 or .gif)")

    export = add("export", command_export, "Write a plan's motion for a cell: a sampled "
                 "trajectory (JSON, CSV), a URScript program or a ROS 2 JointTrajectory.",
                 config=False)
    export.add_argument("plan", help="plan JSON of `vprobot plan --out` (docs/plan-format.md)")
    export.add_argument("--format", required=True, choices=list(SUFFIXES),
                        help="trajectory (.json), csv (.csv), urscript (.script, UR robots) or "
                        "ros2 (.yaml) (docs/motion.md#export)")
    export.add_argument("--out", required=True, help="file to write, with the format's suffix")
    export.add_argument("--dt", type=POSITIVE_FLOAT, default=EXPORT_DT_S,
                        help=f"sampling step of the trajectory (s; default {EXPORT_DT_S})")
    check = add("check", command_check, "Replay a plan's trajectory in its cell: collisions, "
                "joint, velocity, acceleration and jerk limits, sensor poses; exit 1 when one "
                "fails.")
    check.add_argument("plan", help="plan JSON of `vprobot plan --out` (docs/plan-format.md)")
    check.add_argument("--dt", type=POSITIVE_FLOAT, default=CHECK_DT_S,
                       help=f"replay step (s; default {CHECK_DT_S})")

    evaluation = add("evaluate", command_evaluate,
                     "Compare planners on a fixed episode list (default: the test motors).")
    add_robot(evaluation)
    evaluation.add_argument("--planners", nargs="+", default=list(EVALUATED_PLANNERS),
        help="planner names: uniform<k> (k fixed views), nbv (volumetric next-best view; "
        "nbv:GAIN ranks by another gain, nbv@RULE stops itself by a --stop rule), bscp<N> / "
        "agent<N> for B_SCP / the bundled agent with N views, agent (the bundled agent), "
        "agent:NAME (another bundled one, e.g. agent:cpu, motors only) or agent:PATH (a "
        "training run or model .zip); default: the model-free planners, then the model-based "
        "ones")
    evaluation.add_argument("--episodes", help="episode list: a bundled one by name (test-v1: "
                            "the test motors; shapes-v1: the non-motor objects) or a JSON file "
                            "as written into --out; default: test-v1")
    evaluation.add_argument("--motors", nargs="+",
                            help="mesh files to draw episodes for instead (default: the test "
                            "motors)")
    evaluation.add_argument("--seeds", type=NON_NEGATIVE_INT, nargs="+",
                            help="seeds to draw episodes for instead (default: 0 1 2)")
    evaluation.add_argument("--carriers", nargs="+", choices=["robot", "free"],
                            default=["robot", "free"],
                            help="robot: the robot in the loop; free: a free-flying sensor (the "
                            "paper's setting); each episode runs with each (default: both)")
    add_stop(evaluation, many=["goal"])
    evaluation.add_argument("--out", default="results", help="folder for the tables")
    evaluation.add_argument("--workers", type=POSITIVE_INT, default=1,
                            help="episodes at once on Ray (one CPU each); 1: in this process")
    evaluation.add_argument("--address", help="Ray cluster address (default: a local Ray)")

    training = add("train", command_train,
                   "Train an RL agent (stable-baselines3) headless into a run directory.",
                   config=False)
    training.add_argument("profile", nargs="?",
                          help="agent profile YAML, e.g. configs/agents/cpu.yaml")
    training.add_argument("--set", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                          help="override profile settings, e.g. env.state=s_bin "
                          "agent.algorithm=ppo agent.encoder=pointnet env.carrier=free")
    add_sensor(training)
    training.add_argument("--steps", type=POSITIVE_INT, help="env steps (agent.total_steps)")
    training.add_argument("--seed", type=NON_NEGATIVE_INT, help="seed of the run (default 0)")
    training.add_argument("--seeds", type=NON_NEGATIVE_INT, nargs="+", metavar="SEED",
                          help="one run per seed in OUT/seed-<n>/, each scored on the test "
                          "lists, then mean and min-max over seeds (OUT/seeds.md); rerun to go on")
    training.add_argument("--out", required=True, help="run directory (with --seeds: the folder "
                          "of the seeds' runs)")
    training.add_argument("--resume", action="store_true",
                          help="go on from the run's latest checkpoint")
    training.add_argument("--device", choices=["cpu", "cuda", "auto"],
                          help="torch device (default: the profile's, cpu)")
    training.add_argument("--workers", type=POSITIVE_INT,
                          help="with --seeds: seeds at once on a local Ray, one CPU each "
                          "(default: one after another in this process)")
    training.add_argument("--address", help="with --seeds: run the seeds on this Ray cluster")

    teacher = add("teacher", command_teacher,
                  "Roll out a profile's teacher episodes (agent.pretrain_episodes) into its "
                  "teacher folder, shard by shard, on several cores: the runs that share "
                  "agent.teacher_seed and agent.teacher_dir then read them; resumable.",
                  commands, config=False)
    teacher.add_argument("profile", help="agent profile YAML, e.g. "
                                         "configs/agents/real-candidates.yaml")
    teacher.add_argument("--set", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                         help="override profile settings, as in `vprobot train`")
    add_sensor(teacher)
    teacher.add_argument("--out", help="the teacher folder (default: agent.teacher_dir)")
    teacher.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                         help="the run seed the teacher's stream follows when the profile "
                              "sets no agent.teacher_seed (default 0)")
    teacher.add_argument("--workers", type=POSITIVE_INT, default=1,
                         help="processes rolling out shards at once (default 1)")
    study = add("sweep", command_sweep,
                "Run a study (a grid of agent configurations x seeds) as training runs on Ray.",
                config=False)
    study.add_argument("study", help="study YAML, e.g. configs/studies/state_algorithm.yaml")
    study.add_argument("--out", required=True, help="folder of the study's runs and table")
    study.add_argument("--resume", action="store_true",
                       help="go on with the study in --out; finished trials are not rerun")
    study.add_argument("--address", help="Ray cluster address (default: a local Ray)")
    study.add_argument("--workers", type=POSITIVE_INT,
                       help="CPUs of the local Ray, one per trial (default: all)")

    curves = add("curves", command_curves,
                 "Plot training curves (coverage, acquisitions, reward, travel) of runs.",
                 config=False)
    curves.add_argument("runs", nargs="+", help="run directories")
    curves.add_argument("--out", default="curves.png", help="PNG to write")
    curves.add_argument("--window", type=POSITIVE_INT, default=50,
                        help="episodes in the trailing mean")

    benchmark = add("benchmark", command_benchmark, "Measure the speed and quality targets.")
    add_robot(benchmark)
    benchmark.add_argument("suite",
                           choices=["kinematics", "sensor", "env", "planners", "mesh",
                                    "render", "train", "cluster", "objects", "motion"],
                           help="what to measure (docs/benchmarks.md)")
    benchmark.add_argument("--samples", type=POSITIVE_INT, default=200,
                           help="random targets (kinematics), steps (env, train) or view-to-view "
                                "moves (motion) per measure")
    benchmark.add_argument("--json", help="write the results as JSON here")

    add("sensors", command_sensors, "List the sensor presets (configs/sensors/).", config=False)

    motors = commands.add_parser("motors", help="Synthetic starter motors.")
    motor_commands = motors.add_subparsers(dest="motors_command", required=True)
    generate = add("generate", command_motors_generate, "Generate seeded starter motors.",
                   motor_commands)
    generate.add_argument("--count", type=COUNT, required=True,
                          help=f"number of motors (1..{MAX_COUNT})")
    generate.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                          help="seed of the set: motor i depends only on (seed, i), so a "
                          "larger count extends a smaller one (default 0: the paper's motors)")
    generate.add_argument("--out", required=True, help="output folder")

    objects = commands.add_parser("objects", help="Seeded part families besides motors.")
    object_commands = objects.add_subparsers(dest="objects_command", required=True)
    add("list", command_objects, "List the part families and their parameters.",
        object_commands, config=False)
    parts = add("generate", command_objects,
                "Write seeded instances of a part family (STL + parameter JSON).",
                object_commands, config=False)
    parts.add_argument("--family", type=_family_name, required=True,
                       help="part family (see `vprobot objects list`)")
    parts.add_argument("--count", type=COUNT, required=True,
                       help=f"number of instances (1..{MAX_COUNT})")
    parts.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                       help="seed of the first instance; the others follow it (default 0)")
    parts.add_argument("--out", required=True, help="output folder")
    prepare = add("cache", command_objects,
                  "Build the objects a profile trains on and their ground truth once (training "
                  "otherwise builds each when it first draws it).", object_commands, config=False)
    prepare.add_argument("profile",
                         help="agent profile YAML, e.g. configs/agents/cpu-families.yaml")
    prepare.add_argument("--set", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                         help="override profile settings, as in `vprobot train`")

    stop = commands.add_parser("stop", help="Knowing when to stop without the model.")
    stop_commands = stop.add_subparsers(dest="stop_command", required=True)
    stop_fit = add("fit", command_stop_fit,
                   "Fit the model-free coverage estimate on rollouts of split v1 (training "
                   "objects; validation list for selection and the report) and widen its std "
                   "for unseen part families (each training family left out in turn); "
                   "resumable.", stop_commands)
    stop_fit.add_argument("--out", required=True,
                          help="folder for the rollouts, the family folds, the estimator and "
                               "the report")
    stop_fit.add_argument("--episodes", type=POSITIVE_INT, default=400,
                          help="training episodes, one planner each in turn (default 400)")
    stop_fit.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                          help="seed of the training episodes and the networks (default 0)")
    stop_fit.add_argument("--planners", nargs="+", type=_planner_name,
                          help="model-free planners of the rollouts (default: random2 "
                               "uniform4 uniform6 uniform8 nbv)")

    from vprobot.stopping import study as study_defaults

    stop_error = add("error", command_stop_error,
                     "Score the coverage estimate on episode lists: its error per view count "
                     "and calibration on rollouts of model-free planners (resumable).",
                     stop_commands)
    add_robot(stop_error)
    stop_error.add_argument("--out", required=True,
                            help="folder for the rollouts (LIST.csv) and error.md, error.csv")
    stop_error.add_argument("--episodes", nargs="+", default=list(study_defaults.DEFAULT_LISTS),
                            help=f"episode lists, bundled names or files (default: "
                            f"{' '.join(study_defaults.DEFAULT_LISTS)})")
    stop_error.add_argument("--planners", nargs="+", type=_planner_name,
                            help="model-free planners of the rollouts (default: random2 "
                                 "uniform4 uniform6 uniform8 nbv)")
    stop_error.add_argument("--estimator", metavar="PATH",
                            help="an estimator.npz (default: the bundled one)")


    stop_study = add("study", command_stop_study,
                     "Run the stop study: each stop rule with each planner it applies to, robot "
                     "in the loop, on episode lists (resumable).", stop_commands)
    add_robot(stop_study)
    stop_study.add_argument("--out", required=True,
                            help="folder for the study (study.md, .csv, .png; LIST/RULE/ "
                            "evaluations)")
    stop_study.add_argument("--episodes", nargs="+", default=list(study_defaults.DEFAULT_LISTS),
                            help=f"episode lists, bundled names or files (default: "
                            f"{' '.join(study_defaults.DEFAULT_LISTS)})")
    stop_study.add_argument("--planners", nargs="+", type=_planner_name,
                            default=list(study_defaults.DEFAULT_PLANNERS),
                            help=f"planners (default: "
                            f"{' '.join(study_defaults.DEFAULT_PLANNERS)}: the bundled agent, "
                            f"nbv and the bundled agent with a stop action)")
    add_stop(stop_study, many=study_defaults.DEFAULT_RULES)
    stop_study.add_argument("--workers", type=POSITIVE_INT, default=1,
                            help="episodes at once on Ray (one CPU each); 1: in this process")

    robots = commands.add_parser("robots", help="Robots: the bundled ones, importing your own.")
    robot_commands = robots.add_subparsers(dest="robots_command", required=True)
    add("list", command_robots_list, "List the bundled robots.", robot_commands, config=False)
    importer = add("import", command_robots_import,
                   "Convert a serial arm's URDF into a robot folder.", robot_commands,
                   config=False)
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
    return parser


def _warning_printer(prog: str) -> Callable[..., None]:
    """A `warnings.showwarning` that prints one line in the user's terms (not Python's file,
    line number and source line)."""

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: Any = None, line: str | None = None) -> None:
        print(f"{prog}: warning: {message}", file=sys.stderr)

    return show


def _interrupt(signum: int, frame: object) -> None:
    # SIGTERM takes the Ctrl-C path: partial outputs are cleaned up or saved, not left half.
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:  # before the parser, which checks names against the registries
        plugins.load_requested(argv)
    except ValueError as error:
        print(f"vprobot: error: {error}", file=sys.stderr)
        return 2
    args = build_parser().parse_args(argv)
    args.argv = argv
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _interrupt) if in_main_thread else None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _warning_printer(args.prog)
            return args.handler(args)
    except (ValueError, OSError) as error:
        # ConfigError is a ValueError; OSError covers unreadable inputs and full disks.
        text = str(error).splitlines()[0] if str(error) else type(error).__name__
        print(f"{args.prog}: error: {text}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{args.prog}: interrupted", file=sys.stderr)
        return INTERRUPTED
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
