"""The `vprobot` command line.

One module per command group builds that group's subcommands and runs them (`cell`, `planning`,
`view`, `export`, `training`, `benchmark`, `objects`, `stop`, `report`; `common` holds what they
share).
The package imports what a command runs when it runs (planners, the renderer, training, the
benchmarks), inside the command functions, and builds the parser from light modules only, so
that `vprobot --help` and a bad option answer at once; those imports inside the command
functions are the only ones in vprobot without a comment of their own.

Exit codes: 0 success; 1 only where a command documents it (`reach`: the view is unreachable;
`check`: the replay fails; `report compare`, `report check`: a cell moved);
2 a user error (bad option, config, mesh, plan or output path), reported as one line on stderr;
130 interrupted (Ctrl-C or SIGTERM; `evaluate` keeps the episodes it finished); 141 the reader
of the output went away (`| head`), which ends the command quietly.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Sequence
from typing import Any

from vprobot.cli import benchmark, cell, export, objects, planning, report, stop, training, view
from vprobot.cli.common import Commands, Parser
from vprobot.compute import processes
from vprobot.extensions import plugins

INTERRUPTED = 130
BROKEN_PIPE = 141
"""A shell's status of a command that SIGPIPE ended (128 + 13): its reader closed the pipe."""
COMMANDS: tuple[Callable[[Commands], None], ...] = (
    cell.add_reach, cell.add_cell, planning.add_plan, planning.add_render, view.add_view,
    export.add_export,
    export.add_check, planning.add_evaluate, training.add_train, training.add_teacher,
    training.add_sweep, training.add_curves, benchmark.add_benchmark, cell.add_sensors,
    objects.add_motors, objects.add_objects, stop.add_stop_commands, cell.add_robots,
    report.add_report)
"""Each adds its subcommands, in the order `vprobot --help` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command and option (their handler in `handler`)."""
    parser = Parser(prog="vprobot",
                    description="Robot-guided visual inspection planning in MuJoCo.")
    parser.add_argument("--plugin", action="append", metavar="MODULE",
                        help="import this module first, to use what it registers (a planner, "
                        "a reward, ...): a module name or a .py file; repeatable; besides the "
                        "vprobot.plugins entry points (docs/extending.md#plugins)")
    commands = parser.add_subparsers(dest="command", required=True)
    for add_commands in COMMANDS:
        add_commands(commands)
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
    in_main_thread = threading.current_thread() is threading.main_thread()
    # First: a SIGTERM while the plugins are imported is an interrupt too.
    previous = signal.signal(signal.SIGTERM, _interrupt) if in_main_thread else None
    prog = "vprobot"  # the command's own name once the parser has it
    try:
        processes.end_with_environment()
        plugins.load_requested(argv)  # before the parser, which checks names against registries
        args = build_parser().parse_args(argv)
        args.argv = argv
        prog = args.prog
        with warnings.catch_warnings():
            warnings.showwarning = _warning_printer(prog)
            code: int = args.handler(args)
        sys.stdout.flush()  # here, so that a reader gone (`| head`) is met below, not at exit
        return code
    except BrokenPipeError:
        # The reader of the output is gone (`vprobot objects list | head`): stop quietly, as
        # other tools do; stdout goes to devnull, so that Python's flush at exit finds no pipe.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return BROKEN_PIPE
    except (ValueError, OSError) as error:
        # ConfigError is a ValueError; OSError covers unreadable inputs and full disks.
        text = str(error).splitlines()[0] if str(error) else type(error).__name__
        print(f"{prog}: error: {text}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return INTERRUPTED
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)
