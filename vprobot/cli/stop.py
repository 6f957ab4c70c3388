"""`vprobot stop fit`, `calibrate`, `error` and `study`: knowing when to stop without the
model."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from vprobot.cli.common import (
    NON_NEGATIVE_INT,
    POSITIVE_INT,
    Commands,
    LateHelp,
    add,
    add_robot,
    add_stop,
    config_of,
    number,
    planner_name,
)
from vprobot.files.outputs import check_output_folder

MODEL_FREE_HELP = ("model-free planners of the rollouts (default: random2 uniform4 uniform6 "
                   "uniform8 nbv)")


def _study_default(name: str) -> tuple[str, ...]:
    """A default of the stop study (`vprobot.stop_studies.study`, which imports the planners)."""
    from vprobot.stop_studies import study

    return getattr(study, name)


def _lists_help() -> str:
    lists = " ".join(_study_default("DEFAULT_LISTS"))
    return f"episode lists, bundled names or files (default: {lists})"


def _planners_help() -> str:
    return (f"planners (default: {' '.join(_study_default('DEFAULT_PLANNERS'))}: the bundled "
            f"agent, nbv and the bundled agent with a stop action)")


def add_stop_commands(commands: Commands) -> None:
    stop = commands.add_parser("stop", help="Knowing when to stop without the model.")
    stop_commands = stop.add_subparsers(dest="stop_command", required=True)
    stop_fit = add(stop_commands, "fit", command_stop_fit,
                   "Fit the model-free coverage estimate on rollouts of split v1 (training "
                   "objects; validation list for selection and the report) and widen its std "
                   "for unseen part families (each training family left out in turn); "
                   "resumable.")
    stop_fit.add_argument("--out", required=True,
                          help="folder for the rollouts, the family folds, the estimator and "
                               "the report")
    stop_fit.add_argument("--episodes", type=POSITIVE_INT, default=400,
                          help="training episodes, one planner each in turn (default 400)")
    stop_fit.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                          help="seed of the training episodes and the networks (default 0)")
    stop_fit.add_argument("--planners", nargs="+", type=planner_name, help=MODEL_FREE_HELP)

    stop_calibrate = add(stop_commands, "calibrate", command_stop_calibrate,
                         "Calibrate the stop rule `confident`: rollouts of model-free planners on "
                         "the split's calibration objects (parts no fit saw), the probability "
                         "that the goal is reached (conformal) and the threshold that bounds "
                         "false stops (Learn-then-Test); resumable.")
    add_robot(stop_calibrate)
    stop_calibrate.add_argument("--out", required=True,
                                help="folder for the rollouts, a copy of the estimator with "
                                     "its calibration (confidence.npz) and calibration.md")
    stop_calibrate.add_argument("--estimator", metavar="PATH",
                                help="the estimator.npz to calibrate (default: the bundled one "
                                     "of the sensor)")
    stop_calibrate.add_argument("--episodes", type=POSITIVE_INT, default=200,
                                help="calibration episodes, one planner each in turn; half "
                                     "calibrate the probability, half choose the threshold "
                                     "(default 200)")
    stop_calibrate.add_argument("--seed", type=NON_NEGATIVE_INT, default=0,
                                help="seed of the episodes' poses (default 0)")
    stop_calibrate.add_argument("--planners", nargs="+", type=planner_name,
                                help=MODEL_FREE_HELP)
    unit = number(float, 0.0, True, "a number in (0, 1)", high=1.0)
    stop_calibrate.add_argument("--risk", type=unit, default=0.05,
                                help="the share of false stops (below the goal) to bound "
                                     "(default 0.05)")
    stop_calibrate.add_argument("--delta", type=unit, default=0.1,
                                help="the chance that the bound fails on the calibration draw "
                                     "(default 0.1)")

    # The study's defaults are filled in by the commands (None: not given), and named by --help.
    stop_error = add(stop_commands, "error", command_stop_error,
                     "Score the coverage estimate on episode lists: its error per view count "
                     "and calibration on rollouts of model-free planners (resumable).")
    add_robot(stop_error)
    stop_error.add_argument("--out", required=True,
                            help="folder for the rollouts (LIST.csv) and error.md, error.csv")
    stop_error.add_argument("--episodes", nargs="+", help=LateHelp(_lists_help))
    stop_error.add_argument("--planners", nargs="+", type=planner_name, help=MODEL_FREE_HELP)
    stop_error.add_argument("--estimator", metavar="PATH",
                            help="an estimator.npz (default: the bundled one)")

    stop_study = add(stop_commands, "study", command_stop_study,
                     "Run the stop study: each stop rule with each planner it applies to, robot "
                     "in the loop, on episode lists (resumable).")
    add_robot(stop_study)
    stop_study.add_argument("--out", required=True,
                            help="folder for the study (study.md, .csv, .png; LIST/RULE/ "
                            "evaluations)")
    stop_study.add_argument("--episodes", nargs="+", help=LateHelp(_lists_help))
    stop_study.add_argument("--planners", nargs="+", type=planner_name,
                            help=LateHelp(_planners_help))
    add_stop(stop_study, many=lambda: _study_default("DEFAULT_RULES"))
    stop_study.add_argument("--workers", type=POSITIVE_INT, default=1,
                            help="episodes at once on Ray (one CPU each); 1: in this process")


def _given(values: Sequence[str] | None, default: str) -> list[str]:
    """An option's values, or the study's `default` when it was not given."""
    return list(_study_default(default) if values is None else values)


def command_stop_fit(args: argparse.Namespace) -> int:
    """Fit the model-free coverage estimate on rollouts of split v1 and report it."""
    from vprobot.stop_studies.report import fit_estimate

    check_output_folder(args.out, "--out")
    figures = fit_estimate(config_of(args), args.out, args.episodes, args.seed, args.planners)
    print((Path(args.out) / "estimate.md").read_text())
    print(f"estimator: {Path(args.out) / 'estimator.npz'}; validation MAE "
          f"{figures['mae_pp']:.2f} pp")
    return 0


def command_stop_calibrate(args: argparse.Namespace) -> int:
    """Calibrate the stop rule `confident` on rollouts of the split's calibration objects."""
    from vprobot.files.progress import showing_progress
    from vprobot.stop_studies.calibrate import calibrate_stop

    check_output_folder(args.out, "--out")
    with showing_progress():
        figures = calibrate_stop(config_of(args), args.out, args.estimator, args.episodes,
                                 args.seed, args.planners, args.risk, args.delta)
    print((Path(args.out) / "calibration.md").read_text())
    print(f"use it: --stop confident --estimator {Path(args.out) / 'estimator.npz'}"
          if figures["threshold"] is not None else
          "no threshold certified: --stop confident:P with a threshold P of your own")
    return 0


def command_stop_error(args: argparse.Namespace) -> int:
    """Score the coverage estimate on episode lists (rollouts of model-free planners)."""
    from vprobot.files.progress import showing_progress
    from vprobot.stop_studies.report import score_estimate

    check_output_folder(args.out, "--out")
    with showing_progress():
        score_estimate(config_of(args), args.out, _given(args.episodes, "DEFAULT_LISTS"),
                       args.planners, args.estimator)
    print((Path(args.out) / "error.md").read_text())
    return 0


def command_stop_study(args: argparse.Namespace) -> int:
    """Run the stop study: every stop rule with every planner it applies to, robot in the
    loop, on the episode lists."""
    from vprobot.files.progress import showing_progress
    from vprobot.stop_studies.study import stop_study

    check_output_folder(args.out, "--out")
    with showing_progress():
        stop_study(config_of(args), args.out, _given(args.episodes, "DEFAULT_LISTS"),
                   _given(args.planners, "DEFAULT_PLANNERS"), _given(args.stop, "DEFAULT_RULES"),
                   args.estimator, args.workers)
    print((Path(args.out) / "study.md").read_text())
    print(f"plot: {Path(args.out) / 'study.png'}")
    return 0

