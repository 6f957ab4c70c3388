"""`vprobot train`, `teacher`, `sweep` and `curves`: training agents and looking at their runs."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from vprobot.cli.common import (
    NON_NEGATIVE_INT,
    POSITIVE_INT,
    Commands,
    add,
    add_sensor,
    sensor_option,
)
from vprobot.files.outputs import check_output_file, check_output_folder


def add_train(commands: Commands) -> None:
    training = add(commands, "train", command_train,
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


def add_teacher(commands: Commands) -> None:
    teacher = add(commands, "teacher", command_teacher,
                  "Roll out a profile's teacher episodes (agent.pretrain_episodes) into its "
                  "teacher folder, shard by shard, on several cores: the runs that share "
                  "agent.teacher_seed and agent.teacher_dir then read them; resumable.",
                  config=False)
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


def add_sweep(commands: Commands) -> None:
    study = add(commands, "sweep", command_sweep,
                "Run a study (a grid of agent configurations x seeds) as training runs on Ray.",
                config=False)
    study.add_argument("study", help="study YAML, e.g. configs/studies/state_algorithm.yaml")
    study.add_argument("--out", required=True, help="folder of the study's runs and table")
    study.add_argument("--resume", action="store_true",
                       help="go on with the study in --out; finished trials are not rerun")
    study.add_argument("--address", help="Ray cluster address (default: a local Ray)")
    study.add_argument("--workers", type=POSITIVE_INT,
                       help="CPUs of the local Ray, one per trial (default: all)")


def add_curves(commands: Commands) -> None:
    curves = add(commands, "curves", command_curves,
                 "Plot training curves (coverage, acquisitions, reward, travel) of runs.",
                 config=False)
    curves.add_argument("runs", nargs="+", help="run directories")
    curves.add_argument("--out", default="curves.png", help="PNG to write")
    curves.add_argument("--window", type=POSITIVE_INT, default=50,
                        help="episodes in the trailing mean")


def command_train(args: argparse.Namespace) -> int:
    """Train an agent into a run directory, or resume one."""
    from vprobot.training.train import profile_config, train

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
              else sensor_option(profile_config(args.profile, args.set, args.steps), args))
    if args.seeds is not None and config is not None:  # (--resume takes no --seeds)
        from vprobot.training.seeds import train_seeds

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
    from vprobot.training.pretrain import collect
    from vprobot.training.train import profile_config

    config = sensor_option(profile_config(args.profile, args.set), args)
    folder = args.out or config.agent.teacher_dir
    if folder is None:
        raise ValueError("give --out FOLDER, or a profile with agent.teacher_dir (the folder "
                         "its runs read the teacher's states from)")
    check_output_folder(folder, "--out" if args.out else "agent.teacher_dir")
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
    from vprobot.training.sweep import sweep

    check_output_folder(args.out, "--out")
    sweep(args.study, args.out, resume=args.resume, address=args.address,
          workers=args.workers)
    print((Path(args.out) / "study.md").read_text())
    return 0


def command_curves(args: argparse.Namespace) -> int:
    """Plot training curves of one or more runs."""
    from vprobot.training.curves import plot_curves

    check_output_file(args.out, "--out", (".png",))
    print(f"wrote {plot_curves(args.runs, args.out, args.window)}")
    return 0

