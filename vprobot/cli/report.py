"""`vprobot report`: the README's tables, agents beside the baselines, two evaluation tables
compared cell by cell, and a committed evaluation folder checked against its regeneration."""

from __future__ import annotations

import argparse
from pathlib import Path

from vprobot.cli.common import NON_NEGATIVE_INT, Commands, add
from vprobot.files.outputs import check_output_file


def add_report(commands: Commands) -> None:
    report = commands.add_parser("report", help="Tables and comparisons of committed results.")
    reports = report.add_subparsers(dest="report_command", required=True)
    tables = add(reports, "tables", command_tables,
                 "Write the README's table of a cell: each planner and agent on the three test "
                 "lists (agents over seeds, against the optimum of the same episodes).",
                 config=False)
    tables.add_argument("--folders", type=Path, required=True,
                        help="the folder holding the cell's motors/, families-test/ and shapes/ "
                        "(of `vprobot evaluate`)")
    tables.add_argument("--carrier", choices=("robot", "free"), default="robot",
                        help="the rows of this carrier (default: robot)")
    tables.add_argument("--agents", nargs="*", type=_labelled_folder, default=[],
                        metavar="LABEL=DIR",
                        help="agents trained with `vprobot train --seeds`: DIR holds "
                        "seed-<n>/test/LIST/")
    tables.add_argument("--planners", nargs="+", metavar="PLANNER",
                        help="the folders' planners shown, in this order (default: all)")
    tables.add_argument("--agents-after", default="nbv@grid", metavar="PLANNER",
                        help="the row after which the agents' rows go (default: nbv@grid)")
    tables.add_argument("--out", required=True, help="the Markdown file to write")
    baselines = add(reports, "baselines", command_baselines,
                    "Write agents trained with `vprobot train --seeds` (mean, min-max over "
                    "seeds) beside the repository's baselines, one table per test list.",
                    config=False)
    baselines.add_argument("--agents", nargs="+", type=_labelled_folder, required=True,
                           metavar="LABEL=DIR", help="folders holding a seeds.csv, each with a "
                           "label")
    baselines.add_argument("--out", required=True, help="the Markdown file to write")
    baselines.add_argument("--targets", action="store_true",
                           help="add issue 21's targets, met or missed by how much")
    compare = add(reports, "compare", command_compare,
                  "Compare two `vprobot evaluate` tables cell by cell, timing columns left out: "
                  "print each cell that moved; exit 1 if any did.", config=False)
    compare.add_argument("old", type=Path, help="the reference table: evaluation.csv or "
                         "evaluation_episodes.csv")
    compare.add_argument("new", type=Path, help="the table of the same kind to check; each of "
                         "its rows must be in OLD")
    check = add(reports, "check", command_check,
                "Run a committed evaluation folder's command again (its episode list, recorded "
                "config and estimator, an empty cache) and compare "
                "the tables cell by cell: print each cell that differs; exit 1 if any does.",
                config=False)
    check.add_argument("folder", type=Path, help="a committed evaluation folder, e.g. "
                       "results/motors")
    check.add_argument("--episodes", type=NON_NEGATIVE_INT, nargs="+", metavar="INDEX",
                       help="indices into its episodes.json (default: all, and the summary "
                       "table is compared too)")
    check.add_argument("--planners", nargs="+", metavar="PLANNER",
                       help="default: those of its table")
    check.add_argument("--carriers", nargs="+", choices=("robot", "free"),
                       help="default: those of its table")


def _labelled_folder(text: str) -> tuple[str, Path]:
    """An argparse type: `LABEL=DIR`."""
    label, separator, folder = text.partition("=")
    if not separator or not label or not folder:
        raise argparse.ArgumentTypeError(f"must be LABEL=DIR, got {text!r}")
    return label, Path(folder)


def command_tables(args: argparse.Namespace) -> int:
    """Write the table, and print it."""
    from vprobot.files.atomic import write_text
    from vprobot.report.tables import table

    check_output_file(args.out, "--out", (".md",))
    text = table(args.folders, args.carrier, dict(args.agents), args.planners,
                 args.agents_after)
    write_text(Path(args.out), text)
    print(text, end="")
    return 0


def command_baselines(args: argparse.Namespace) -> int:
    from vprobot.files.atomic import write_text
    from vprobot.report.baselines import comparison

    check_output_file(args.out, "--out", (".md",))
    command = (f"vprobot report baselines --agents "
               f"{' '.join(f'{label}={folder}' for label, folder in args.agents)} "
               f"--out {args.out}{' --targets' if args.targets else ''}")
    write_text(Path(args.out), comparison(args.agents, command, args.targets))
    print(f"wrote {args.out}")
    return 0


def command_compare(args: argparse.Namespace) -> int:
    """Print the moved cells and a count; 1 if any cell moved."""
    from vprobot.report.compare import compare_tables

    lines, rows, compared = compare_tables(args.old, args.new)
    for line in lines:
        print(line)
    print(f"{rows} rows, {compared} cells compared, {len(lines)} moved")
    return 1 if lines else 0


def command_check(args: argparse.Namespace) -> int:
    """Regenerate into a temporary folder, print the cells that differ and a count; 1 if any
    cell differs."""
    import subprocess
    import tempfile

    from vprobot.report.check import differences, episode_count, regenerate
    from vprobot.report.compare import read_rows

    count = episode_count(args.folder)
    if args.episodes and max(args.episodes) >= count:
        raise ValueError(f"--episodes {' '.join(map(str, args.episodes))}: {args.folder} has "
                         f"episodes 0 to {count - 1}")
    with tempfile.TemporaryDirectory(prefix="check-results-") as temporary:
        out = Path(temporary) / "regenerated"
        try:
            regenerate(args.folder, out, args.episodes, args.planners, args.carriers,
                       scratch=Path(temporary))
        except subprocess.CalledProcessError as error:
            raise ValueError(f"the regeneration's `vprobot evaluate` exited with "
                             f"{error.returncode} (its message is above)") from None
        moved = differences(args.folder, out, args.episodes)
        rows = len(read_rows(out / "tables" / "evaluation_episodes.csv"))
    for line in moved:
        print(line)
    print(f"{args.folder}: {rows} episode rows regenerated, {len(moved)} cells differ")
    return 1 if moved else 0
