"""What the command groups share: the option types, the options several commands take, the
config they read and the help texts that name registered planners and stop rules.

Nothing here imports MuJoCo, torch or the planners: the parser is built from light modules
only, and a help text that lists a registry is filled in when `--help` prints it.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from vprobot.files.paths import DEFAULT_CONFIG, available_cells, available_robots, available_sensors

if TYPE_CHECKING:
    from vprobot.config import Config

Handler = Callable[[argparse.Namespace], int]
Commands = Any
"""The subcommands of a parser (argparse's private `_SubParsersAction`)."""


class LateHelp(str):
    """A help text that names what only a heavy import knows (the registered planners and stop
    rules); the parser's formatter writes `text()` in its place when `--help` prints it."""

    text: Callable[[], str]

    def __new__(cls, text: Callable[[], str]) -> LateHelp:
        # The string itself only has to be non-empty: argparse leaves out empty help texts.
        late = super().__new__(cls, "(filled in by --help)")
        late.text = text
        return late


class _Formatter(argparse.HelpFormatter):
    """argparse's formatter, with late help texts filled in."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        return action.help.text() if isinstance(action.help, LateHelp) else action.help


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like every other user error (the usage is
    for --help); its subcommands' parsers are of this class too."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def add_former(sub: argparse.ArgumentParser, former: str, current: argparse.Action) -> None:
    """Accept option `former`, the former name of the option `current` (as `add_argument`
    returned it), for one release: it stores into `current`'s value and writes a note to
    stderr; `--help` lists only `current`."""
    name = current.option_strings[0]

    class _Former(argparse.Action):
        def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                     values: Any, option_string: str | None = None) -> None:
            print(f"note: {former} is now called {name}; the old name will not be read "
                  f"after the next release", file=sys.stderr)
            setattr(namespace, self.dest, values)

    former_action = sub.add_argument(former, dest=current.dest, nargs=current.nargs,
                                     action=_Former, help=argparse.SUPPRESS)
    former_action.type = current.type


def config_of(args: argparse.Namespace) -> Config:
    """The config file (or the default), with `--cell`, `--robot`, `--sensor` and `--sensing`
    applied when given, in that order."""
    from vprobot.config import load_config, replace
    from vprobot.robots import load_robot

    config = load_config(args.config)
    if getattr(args, "cell", None):
        config = cell_option(config, args.cell)
    if getattr(args, "robot", None):
        try:
            load_robot(args.robot)
        except ValueError as error:  # named as the user gave it, not as the config key
            raise ValueError(f"--robot: {error}") from None
        try:
            config = replace(config, "cell", robot=args.robot)
        except ValueError as error:  # the robot does not fit the cell (its start pose)
            raise ValueError(f"--robot: {error}") from None
    return sensor_option(config, args)


def cell_option(config: Config, name: str) -> Config:
    """`config` with the cell file `name` (a bundled cell or a path) in place of its `cell` and
    `sensor` sections (a section the file leaves out takes the defaults)."""
    from vprobot.config import Config, config_document
    from vprobot.config.cell import cell_file, read_cell_file
    from vprobot.files.schema import from_mapping

    try:
        path = cell_file(name)
        sections = read_cell_file(path)
    except ValueError as error:  # these name the file already
        raise ValueError(f"--cell: {error}") from None
    try:
        return from_mapping(Config, {**config_document(config), "cell": sections.get("cell", {}),
                                     "sensor": sections.get("sensor", {})})
    except ValueError as error:
        raise ValueError(f"--cell: {path}: {error}") from None


def cell_source(args: argparse.Namespace) -> Path:
    """The file the cell of `config_of(args)` comes from, for messages: `--cell`'s, else the
    cell file the config names (`cell: NAME`), else the config file (or the default)."""
    from vprobot.config.cell import cell_file
    from vprobot.files.schema import read_yaml

    if getattr(args, "cell", None):
        return cell_file(args.cell)
    config = Path(args.config) if args.config else DEFAULT_CONFIG
    named = (read_yaml(config) or {}).get("cell")
    return cell_file(named) if isinstance(named, str) else config


def sensor_option(config: Config, args: argparse.Namespace) -> Config:
    """`config` with the `--sensor` preset, when given, in place of its sensor (same mount),
    then with the `--sensing` model, when given."""
    from vprobot.config import with_sensing, with_sensor

    for option, apply in (("sensor", with_sensor), ("sensing", with_sensing)):
        if value := getattr(args, option, None):
            try:
                config = apply(config, value)
            except ValueError as error:  # named as the user gave it
                raise ValueError(f"--{option}: {error}") from None
    return config


def write_json(path: str | None, document: dict[str, Any]) -> None:
    """Write `document` to `path` when one is given, and say so."""
    if path:
        from vprobot.plan import write_json as write

        print(f"wrote {write(path, document)}")


def number(kind: type, low: float, strict: bool, what: str,
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


NON_NEGATIVE_INT = number(int, 0, False, "an integer >= 0")
POSITIVE_INT = number(int, 0, True, "an integer >= 1")
POSITIVE_FLOAT = number(float, 0.0, True, "a number > 0")


def planner_name(text: str) -> str:
    """An argparse type: a planner name, `agent` or `agent:PATH` (the view count goes in
    `--views`)."""
    from vprobot.planners.runner import parse_planner

    try:
        return parse_planner(text, counted=False)[0]
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def stop_rule(text: str) -> str:
    """An argparse type: a stop rule (`goal`, `estimate:0.9`, `views:5`, ...)."""
    from vprobot.stopping.rules import parse_stop

    try:
        parse_stop(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def add(commands: Commands, name: str, handler: Handler, help_text: str,
        config: bool = True) -> argparse.ArgumentParser:
    """A subcommand `name` that `handler` runs, with `--config` unless `config` is False."""
    sub = commands.add_parser(name, help=help_text, description=help_text)
    sub.set_defaults(handler=handler, prog=sub.prog)
    if config:  # train and sweep take their configuration from a profile instead
        sub.add_argument("--config", help="YAML config (default: configs/default.yaml)")
    return sub


def add_robot(sub: argparse.ArgumentParser) -> None:
    """`--cell`, `--robot` and the sensor options."""
    sub.add_argument("--cell", metavar="CELL",
                     help=f"cell file to use instead of the config's cell and sensor sections "
                     f"(docs/your-cell.md): {', '.join(available_cells())} (configs/cells/) or "
                     f"a cell file's path; --robot, --sensor and --sensing then change it")
    sub.add_argument("--robot", metavar="ROBOT",
                     help=f"robot to use instead of the config's: "
                          f"{', '.join(available_robots())} or a robot folder")
    add_sensor(sub)


def add_sensor(sub: argparse.ArgumentParser) -> None:
    """`--sensor` and `--sensing`."""
    sub.add_argument("--sensor", metavar="PRESET",
                     help=f"sensor preset to use instead of the config's sensor, on the "
                     f"config's mount: {', '.join(available_sensors())} (configs/sensors/) or "
                     f"a preset's YAML file")
    sub.add_argument("--sensing", metavar="MODEL", help=LateHelp(_sensing_help))


def _sensing_help() -> str:
    # The sensing models' registry imports them (NumPy); only --help and a command pay that.
    from vprobot.sensing import SENSING_MODELS

    return (f"sensing model instead of the sensor's: {', '.join(SENSING_MODELS)} "
            f"(docs/sensor.md#sensing); structured_light needs a preset with its figures "
            f"(`vprobot sensors`)")


def add_stop(sub: argparse.ArgumentParser,
             many: Sequence[str] | Callable[[], Sequence[str]] | None = None) -> None:
    """`--stop RULE`, or with `many` (their default) `--stop RULE [RULE ...]`; `many` may be a
    function giving the default, which the help names and the command fills in when `--stop`
    is not given (a default that only a heavy module knows)."""

    def help_text() -> str:
        from vprobot.stopping.rules import STOPS, stop_names

        rules = many() if callable(many) else many
        described = [f"{name}: {STOPS.fact(name, 'description')}" for name in STOPS
                     if STOPS.fact(name, "description")]
        return (f"when to stop{'' if rules is None else ' (each rule in turn)'}: "
                f"{', '.join(stop_names())}; {', '.join(described)} "
                f"(docs/planners.md#stop-rules); default: "
                f"{'goal' if rules is None else ' '.join(rules)}")

    sub.add_argument("--stop", type=stop_rule, nargs=None if many is None else "+",
                     default=None if many is None or callable(many) else list(many),
                     help=LateHelp(help_text))
    sub.add_argument("--estimator", metavar="PATH",
                     help="coverage estimator (estimator.npz of `vprobot stop fit`) for "
                     "--stop estimate and the per-view estimates; default: the bundled one")


@contextlib.contextmanager
def naming_the_cell(args: argparse.Namespace) -> Iterator[None]:
    """A cell that fails its own check (`vprobot.cell.check`) is reported with the file it
    came from: the cell's message names the key, this the file."""
    from vprobot.cell.check import CellError

    try:
        yield
    except CellError as error:
        raise CellError(f"{cell_source(args)}: {error}") from None
