"""`vprobot plan`, `render` and `evaluate`: planning inspections, one or a list of them."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path
from typing import Any

from vprobot.cli.common import (
    NON_NEGATIVE_INT,
    POSITIVE_FLOAT,
    POSITIVE_INT,
    Commands,
    LateHelp,
    add,
    add_former,
    add_robot,
    add_stop,
    config_of,
    naming_the_cell,
    number,
    planner_name,
)
from vprobot.files.outputs import VIDEO_SUFFIXES, check_output_file, check_output_folder
from vprobot.planners.base import MAX_VIEWS, counted_planners, evaluated_planners, planner_names

PLANNING_OPTIONS = ("mesh", "scale", "planner", "views", "seed", "carrier", "stop", "estimator")
"""Options that choose what `plan` or `render` plans; a replayed `--plan` fixes them all."""


def _planner_help() -> str:
    return (f"{', '.join(planner_names())}: agent is the bundled trained "
            f"agent, agent:NAME another bundled one (cpu: motors only), "
            f"agent:PATH a training run or model .zip, agent~K the nearest of "
            f"a candidate agent's K best views, nbv@RULE nbv "
            f"stopping itself by a --stop rule (nbv@grid); default: bscp")


def _planners_help() -> str:
    return (f"planner names: {', '.join(planner_names())}; uniform<k>: k fixed views, "
            f"{' / '.join(f'{name}<N>' for name in counted_planners())} with N views, nbv:GAIN "
            f"nbv ranking by another gain, nbv@RULE nbv stopping itself by a --stop rule, "
            f"agent:NAME another bundled agent (e.g. agent:cpu, motors only), agent:PATH a "
            f"training run or model .zip, agent~K the nearest of a candidate agent's K best "
            f"views; default: {' '.join(evaluated_planners())}")


def _views_help() -> str:
    return (f"fixed number of views ({', '.join(counted_planners())}); "
            f"default: until the coverage goal")


def _add_planning(sub: argparse.ArgumentParser) -> None:
    """The options of `plan` and `render` that choose what they plan."""
    add_robot(sub)
    sub.add_argument("--mesh", help="mesh file (STL/OBJ/PLY); default: the bundled motor")
    sub.add_argument("--scale", type=POSITIVE_FLOAT,
                     help="file units to metres, e.g. 0.001 for millimetres (default 1)")
    sub.add_argument("--planner", type=planner_name, help=LateHelp(_planner_help))
    sub.add_argument("--views", type=_view_count, help=LateHelp(_views_help))
    sub.add_argument("--seed", type=NON_NEGATIVE_INT,
                     help="seed of the episode (object pose, initial view); default 0")
    sub.add_argument("--carrier", choices=["robot", "free"],
                     help="robot in the loop (default), or a free-flying sensor (the paper)")
    add_stop(sub)
    sub.add_argument("--summary", help="write a summary still here (.png): coverage and views; "
                     "`plan` writes one beside --out by default")
    sub.add_argument("--width", type=POSITIVE_INT, default=640, help="video width (pixels)")
    sub.add_argument("--height", type=POSITIVE_INT, default=480,
                     help="video height (pixels)")


def add_plan(commands: Commands) -> None:
    plan = add(commands, "plan", command_plan,
               "Plan the inspection of a part and write the plan JSON.")
    _add_planning(plan)
    plan.add_argument("--out", required=True, help="plan JSON to write")
    plan.add_argument("--video", help="also render the rollout to this .mp4 or .gif")
    plan.add_argument("--picture", help="also write a still of the cell to this .png: the robot "
                      "at its start pose, the part placed, static objects see-through "
                      "(docs/your-cell.md)")
    plan.add_argument("--no-summary", action="store_true",
                      help="write no summary still (by default beside --out: plan.png for "
                      "plan.json)")
    plan.add_argument("--no-timing", action="store_true",
                      help="leave the timing block out of the plan JSON, so that the same "
                      "inputs give the same file byte for byte")


def add_render(commands: Commands) -> None:
    render = add(commands, "render", command_render,
                 "Render an inspection (a plan JSON or a planner's run) as an MP4 or GIF.")
    _add_planning(render)
    render.add_argument("--plan", help="plan JSON (docs/plan-format.md) to replay instead")
    render.add_argument("--out", required=True, help="video to write (.mp4 or .gif)")


def add_evaluate(commands: Commands) -> None:
    evaluation = add(commands, "evaluate", command_evaluate,
                     "Compare planners on a fixed episode list (default: the test motors).")
    add_robot(evaluation)
    evaluation.add_argument("--planners", nargs="+", help=LateHelp(_planners_help))
    evaluation.add_argument("--episodes", help="episode list: a bundled one by name (test-v1: "
                            "the test motors; shapes-v1: the non-motor objects) or a JSON file "
                            "as written into --out; default: test-v1")
    add_former(evaluation, "--motors", evaluation.add_argument(
        "--parts", nargs="+",
        help="mesh files to draw episodes for instead (default: the test motors)"))
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


def _view_count(text: str) -> int:
    """An argparse type: a fixed number of views, 1..MAX_VIEWS."""
    return number(int, 0, True, f"an integer in 1..{MAX_VIEWS}", MAX_VIEWS)(text)


def _planning(args: argparse.Namespace) -> dict[str, Any]:
    """The planning options of `plan` / `render`, defaults filled in."""
    chosen = {name: getattr(args, name) for name in PLANNING_OPTIONS}
    defaults = {"scale": 1.0, "planner": "bscp", "seed": 0, "carrier": "robot", "stop": "goal"}
    return {name: defaults.get(name) if value is None else value
            for name, value in chosen.items()}


def command_plan(args: argparse.Namespace) -> int:
    """Plan the inspection of a part, write the plan JSON and optionally a video."""
    from vprobot.files.progress import showing_progress
    from vprobot.plan import write_json
    from vprobot.planners.runner import plan_part

    check_output_file(args.out, "--out", (".json",))
    if args.no_summary and args.summary:
        raise ValueError("--summary and --no-summary contradict each other; give one")
    if args.summary is None and not args.no_summary:
        args.summary = str(Path(args.out).with_suffix(".png"))
    _check_render_outputs(args, args.video, "--video")
    check_output_file(args.picture, "--picture", (".png",))
    options = _planning(args)
    config = config_of(args)
    with showing_progress(), naming_the_cell(args):
        scene, record, document, summary = plan_part(
            config, options["mesh"], options["scale"], options["planner"],
            options["views"], options["carrier"], options["seed"], options["stop"],
            options["estimator"])
    if args.no_timing:
        document.pop("timing")
    print(summary)
    print(f"wrote {write_json(args.out, document)}")
    _render_outputs(args, scene, record, args.video)
    if args.picture:
        from vprobot.render.picture import render_cell_picture

        print(f"wrote {render_cell_picture(scene, record, args.picture)}")
    return 0


def command_render(args: argparse.Namespace) -> int:
    """Render an inspection (a plan JSON, or a planner's run) as a video."""
    from vprobot.files.progress import showing_progress
    from vprobot.planners.runner import plan_part
    from vprobot.render import episode_from_plan

    _check_render_outputs(args, args.out, "--out")
    config = config_of(args)
    if args.plan:
        given = [f"--{name}" for name in (*PLANNING_OPTIONS, "cell", "robot", "sensor",
                                          "sensing")
                 if getattr(args, name) is not None]
        if given:
            raise ValueError(f"--plan replays a stored plan, which fixes the mesh, pose, robot, "
                             f"sensor, sensing model and views; {', '.join(given)} cannot be "
                             f"combined with it")
        with showing_progress():
            scene, record = episode_from_plan(config, args.plan)
    else:
        options = _planning(args)
        with showing_progress(), naming_the_cell(args):
            scene, record, _, summary = plan_part(
                config, options["mesh"], options["scale"], options["planner"],
                options["views"], options["carrier"], options["seed"], options["stop"],
                options["estimator"])
        print(summary)
    _render_outputs(args, scene, record, args.out)
    return 0


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
    config = config_of(args)
    specs = evaluation_episodes(config, args.parts, args.seeds, args.episodes)
    evaluate(config, args.planners or evaluated_planners(), specs, args.out, progress=True,
             carriers=args.carriers, workers=args.workers, address=args.address,
             stops=args.stop, estimator=args.estimator)
    print((Path(args.out) / "evaluation.md").read_text())
    print(f"coverage curves: {Path(args.out) / PLOT_NAME}")
    with (Path(args.out) / EPISODES_NAME).open(newline="") as stream:
        empty = [f"{row['planner']} ({row['carrier']}) on episode {row['episode']}"
                 for row in csv.DictReader(stream) if row["requested"] == "0"]
    if empty:
        print(f"note: {len(empty)} episode(s) requested no view, covering nothing (the robot "
              f"reached no initial view, or no candidate view was usable): {'; '.join(empty)}")
    return 0

