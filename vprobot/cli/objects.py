"""`vprobot motors` and `objects`: the synthetic motors and the other part families."""

from __future__ import annotations

import argparse

from vprobot.cli.common import NON_NEGATIVE_INT, Commands, add, number
from vprobot.files.outputs import check_output_folder

MAX_COUNT = 10_000
"""Most objects one `motors generate` or `objects generate` writes (0.1 to 1 s each)."""
COUNT = number(int, 0, True, f"an integer in 1..{MAX_COUNT}", MAX_COUNT)


def add_motors(commands: Commands) -> None:
    motors = commands.add_parser("motors", help="Synthetic starter motors.")
    motor_commands = motors.add_subparsers(dest="motors_command", required=True)
    generate = add(motor_commands, "generate", command_motors_generate,
                   "Generate seeded starter motors, or the bundled sets (--bundled).")
    generate.add_argument("--count", type=COUNT, help=f"number of motors (1..{MAX_COUNT})")
    generate.add_argument("--seed", type=NON_NEGATIVE_INT,
                          help="seed of the set: motor i depends only on (seed, i), so a "
                          "larger count extends a smaller one (default 0: the paper's motors)")
    generate.add_argument("--bundled", action="store_true",
                          help="the bundled sets instead, byte for byte: train/ (20 motors of "
                          "seed 0) and test/ (5 of seed 1), named motor_<iii>; --out defaults "
                          "to the package's assets/motors/")
    generate.add_argument("--out", help="output folder (required without --bundled)")


def add_objects(commands: Commands) -> None:
    objects = commands.add_parser("objects", help="Seeded part families besides motors.")
    object_commands = objects.add_subparsers(dest="objects_command", required=True)
    add(object_commands, "list", command_objects, "List the part families and their parameters.",
        config=False)
    parts = add(object_commands, "generate", command_objects,
                "Write seeded instances of a part family (STL + parameter JSON), or the "
                "bundled non-motor objects (--bundled).", config=False)
    parts.add_argument("--family", type=_family_name,
                       help="part family (see `vprobot objects list`)")
    parts.add_argument("--count", type=COUNT, help=f"number of instances (1..{MAX_COUNT})")
    parts.add_argument("--seed", type=NON_NEGATIVE_INT,
                       help="seed of the first instance; the others follow it (default 0)")
    parts.add_argument("--bundled", action="store_true",
                       help="the bundled objects of the shapes-v1 list instead, byte for byte: "
                       "bracket, pipe_tee, torus (fixed shapes, no family); --out defaults to "
                       "the package's assets/objects/")
    parts.add_argument("--out", help="output folder (required without --bundled)")
    prepare = add(object_commands, "cache", command_objects,
                  "Build the objects a profile trains on and their ground truth once (training "
                  "otherwise builds each when it first draws it).", config=False)
    prepare.add_argument("profile",
                         help="agent profile YAML, e.g. configs/agents/cpu-families.yaml")
    prepare.add_argument("--set", nargs="+", default=[], metavar="SECTION.KEY=VALUE",
                         help="override profile settings, as in `vprobot train`")


def _family_name(text: str) -> str:
    """An argparse type: a registered part family."""
    from vprobot.families import FAMILIES

    try:
        return FAMILIES[text].name
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def command_motors_generate(args: argparse.Namespace) -> int:
    """A seeded set of `--count` motors, or with `--bundled` the bundled sets."""
    from vprobot.files.paths import MOTORS_DIR
    from vprobot.motors import generate_bundled_motors, generate_motors

    if args.bundled:
        if args.count is not None or args.seed is not None:
            raise ValueError("--bundled writes the bundled sets (train/: 20 motors of seed 0, "
                             "test/: 5 of seed 1); --count and --seed are not allowed with it")
        out = check_output_folder(args.out or MOTORS_DIR, "--out")
        paths = generate_bundled_motors(out)
    else:
        if args.count is None or args.out is None:
            raise ValueError("--count and --out are required (or --bundled)")
        out = check_output_folder(args.out, "--out")
        paths = generate_motors(args.count, args.seed or 0, out)
    print(f"wrote {len(paths)} motors to {out}")
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
        from vprobot.env.inspect_env import build_training_objects
        from vprobot.files.paths import cache_root
        from vprobot.training.train import profile_config

        count = build_training_objects(profile_config(args.profile, args.set))
        print(f"{count} training objects and their ground truth are in {cache_root()}")
        return 0
    if args.bundled:
        from vprobot.families.shapes import write_bundled_shapes
        from vprobot.files.paths import OBJECTS_DIR

        if args.family is not None or args.count is not None or args.seed is not None:
            raise ValueError("--bundled writes the bundled objects (bracket, pipe_tee, torus); "
                             "--family, --count and --seed are not allowed with it")
        out = check_output_folder(args.out or OBJECTS_DIR, "--out")
        paths = write_bundled_shapes(out)
        print(f"wrote {len(paths)} objects to {out}")
        return 0
    if args.family is None or args.count is None or args.out is None:
        raise ValueError("--family, --count and --out are required (or --bundled)")
    out = check_output_folder(args.out, "--out")
    paths = generate_instances(args.family, args.count, args.seed or 0, out)
    print(f"wrote {len(paths)} {args.family} parts to {out}")
    return 0

