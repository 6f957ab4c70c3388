"""`vprobot export` and `check`: a plan's motion for a real cell, and its replay."""

from __future__ import annotations

import argparse
from pathlib import Path

from vprobot.cli.common import Commands, LateHelp, add, config_of, number
from vprobot.export import CHECK_DT_S, CHECK_MAX_DT_S, EXPORT_DT_S, MIN_DT_S
from vprobot.files.outputs import check_output_file


def add_export(commands: Commands) -> None:
    export = add(commands, "export", command_export, "Write a plan's motion for a cell: a "
                 "sampled trajectory (JSON, CSV), a URScript program, a ROS 2 "
                 "FollowJointTrajectory goal or its acquisitions.",
                 config=False)
    export.add_argument("plan", help="plan JSON of `vprobot plan --out` (docs/plan-format.md)")
    export.add_argument("--format", required=True, type=_format_name,
                        help=LateHelp(_formats_help))
    export.add_argument("--out", required=True, help="file to write, with the format's suffix")
    export.add_argument("--dt", type=number(float, MIN_DT_S, False, f"a step >= {MIN_DT_S:g} s"),
                        default=EXPORT_DT_S, help=f"sampling step of the trajectory (s; at least "
                        f"{MIN_DT_S:g}, default {EXPORT_DT_S})")


def _format_name(text: str) -> str:
    """An argparse type: a registered export format."""
    from vprobot.export.formats import FORMATS

    try:
        return FORMATS[text].name
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _formats_help() -> str:
    from vprobot.export.formats import FORMATS

    # From the declarations: listing the formats imports none of them.
    formats = [f"{name} ({FORMATS.fact(name, 'suffix')}): {FORMATS.fact(name, 'description')}"
               for name in FORMATS]
    return f"{'; '.join(formats)} (docs/motion.md#export)"


def add_check(commands: Commands) -> None:
    check = add(commands, "check", command_check, "Replay a plan's trajectory in its cell: "
                "collisions, joint, velocity, acceleration and jerk limits, sensor poses; exit 1 "
                "when one fails.")
    check.add_argument("plan", help="plan JSON of `vprobot plan --out` (docs/plan-format.md)")
    check.add_argument("--dt", type=number(float, MIN_DT_S, False, f"a step in [{MIN_DT_S:g}, "
                                           f"{CHECK_MAX_DT_S:g}] s", high=CHECK_MAX_DT_S),
                       default=CHECK_DT_S, help=f"replay step (s; {MIN_DT_S:g} to "
                       f"{CHECK_MAX_DT_S:g}, default {CHECK_DT_S}: coarser samples can average "
                       f"a peak over the limits away)")


def command_export(args: argparse.Namespace) -> int:
    """Write a plan's motion as a trajectory, a CSV, a URScript program, a ROS 2 goal or the
    acquisitions."""
    from vprobot.export.formats import FORMATS
    from vprobot.export.program import export_plan_file
    from vprobot.files.atomic import write_text

    check_output_file(args.out, "--out", (FORMATS[args.format].suffix,))
    if Path(args.out).resolve() == Path(args.plan).resolve():
        raise ValueError(f"--out {args.out} is the plan itself; give another file")
    text = export_plan_file(args.plan, args.format, args.dt)
    print(f"wrote {write_text(Path(args.out), text)}")
    return 0


def command_check(args: argparse.Namespace) -> int:
    """Replay a plan's trajectory in its cell; exit 1 when a limit, a collision or a view fails."""
    from vprobot.export.check import check_plan
    from vprobot.files.progress import showing_progress

    with showing_progress():
        result = check_plan(config_of(args), args.plan, args.dt)
    print(result.report())
    return 0 if result.holds else 1

