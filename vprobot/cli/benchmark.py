"""`vprobot benchmark`: the speed and quality targets, one suite at a time."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from vprobot.cli.common import POSITIVE_INT, Commands, add, add_robot, config_of, write_json
from vprobot.files.outputs import check_output_file

SUITES = ("kinematics", "sensor", "env", "planners", "mesh", "render", "train", "cluster",
          "objects", "motion", "cli", "optimum", "grid", "viewer")


def add_benchmark(commands: Commands) -> None:
    benchmark = add(commands, "benchmark", command_benchmark,
                    "Measure the speed and quality targets.")
    add_robot(benchmark)
    benchmark.add_argument("suite", choices=SUITES, help="what to measure (docs/benchmarks.md)")
    benchmark.add_argument("--samples", type=POSITIVE_INT, default=200,
                           help="random targets (kinematics), steps (env, train) or view-to-view "
                                "moves (motion) per measure")
    benchmark.add_argument("--json", help="write the results as JSON here")


def _print_results(results: dict[str, Any]) -> None:
    width = max(len(key) for key in results)
    for key, value in results.items():
        shown = f"{value:.3f}" if isinstance(value, float) else json.dumps(value)
        print(f"{key:<{width}}  {shown}")


def command_benchmark(args: argparse.Namespace) -> int:
    """Run one suite, print its figures and write them as JSON when asked."""
    check_output_file(args.json, "--json", (".json",))
    config = config_of(args)
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
    elif args.suite == "optimum":
        from vprobot.benchmarks.optimum import print_table, run_optimum_benchmark

        results, printer = run_optimum_benchmark(config), print_table
    elif args.suite == "grid":
        from vprobot.benchmarks.grid import run_grid_benchmark

        results = run_grid_benchmark(config)
    elif args.suite == "viewer":
        from vprobot.benchmarks.viewer import run_viewer_benchmark

        results = run_viewer_benchmark(config)
    elif args.suite == "cli":
        from vprobot.benchmarks.cli import run_cli_benchmark

        results = run_cli_benchmark()
    elif args.suite == "motion":
        from vprobot.benchmarks.motion import print_table, run_motion_benchmark

        results, printer = run_motion_benchmark(config, samples=args.samples), print_table
    else:
        from vprobot.benchmarks.sensor import print_table, run_sensor_benchmark

        results, printer = run_sensor_benchmark(config), print_table
    printer(results)
    write_json(args.json, results)
    return 0

