"""`vprobot view`: a plan, or an evaluated episode's plan, in the browser."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any
from urllib.parse import unquote

from vprobot.cli.common import NON_NEGATIVE_INT, Commands, add, config_of, number
from vprobot.files.outputs import check_output_file

PORT = number(int, 0, False, "a port in 0..65535 (0: any free one)", high=65535)


def add_view(commands: Commands) -> None:
    view = add(commands, "view", command_view,
               "Show a plan in the browser: the cell, the views as numbered frusta, the "
               "measured, missed and lost points, and the robot along its timed cycle on a "
               "slider (docs/viewer.md).")
    view.add_argument("plan", help="plan JSON (docs/plan-format.md), or an evaluation folder "
                      "(`vprobot evaluate --out`) with --episode and --planner")
    view.add_argument("--episode", type=NON_NEGATIVE_INT,
                      help="of an evaluation folder: the episode (its index in the folder's "
                      "episode list, the `episode` column of its tables)")
    view.add_argument("--planner", help="of an evaluation folder: the planner as its tables "
                      "name it (e.g. bscp, agent~8, 'nbv --stop grid')")
    view.add_argument("--carrier", choices=["robot", "free"],
                      help="of an evaluation folder: the carrier (default robot)")
    view.add_argument("--html", help="write the page to this .html file (self-contained, works "
                      "offline) instead of serving it")
    view.add_argument("--host", default="127.0.0.1",
                      help="address to serve on (default 127.0.0.1: this machine only)")
    view.add_argument("--port", type=PORT, default=8080,
                      help="port to serve on (default 8080; 0: any free one)")


def _evaluated_plan(args: argparse.Namespace, folder: Path) -> tuple[Path, dict[str, Any]]:
    """The plan of the evaluated episode `--episode`, `--planner`, `--carrier` in `folder`,
    and the config its episodes ran with."""
    from vprobot.evaluation import PLANS_FOLDER, SETTINGS_NAME, plan_path

    if args.episode is None or args.planner is None:
        raise ValueError(f"{folder} is a folder: give an evaluation folder with --episode and "
                         f"--planner, or a plan JSON")
    plans = folder / PLANS_FOLDER
    if not plans.is_dir():
        raise ValueError(f"{folder} holds no evaluated plans ({PLANS_FOLDER}/): evaluations "
                         f"keep them since `vprobot view`; run the evaluation again")
    carrier = args.carrier or "robot"
    path = plan_path(folder, args.episode, carrier, args.planner)
    if not path.is_file():
        stored = sorted({file.stem for file in plans.glob(f"{args.episode}/{carrier}/*.json")})
        have = ", ".join(unquote(name) for name in stored) or "none"
        raise ValueError(f"{folder} has no plan of planner {args.planner!r} on episode "
                         f"{args.episode} ({carrier}); its planners there: {have}")
    try:
        settings = json.loads((folder / SETTINGS_NAME).read_text())["config"]
    except (OSError, ValueError, KeyError, TypeError):
        settings = {}
    return path, settings


def command_view(args: argparse.Namespace) -> int:
    """Serve the plan's page on `--host`:`--port`, or write it to `--html`."""
    from vprobot.config import Config
    from vprobot.files.progress import showing_progress
    from vprobot.files.schema import from_mapping
    from vprobot.render import episode_from_plan
    from vprobot.render.page import page_server, plan_page, write_page

    check_output_file(args.html, "--html", (".html",))
    source = Path(args.plan)
    config = config_of(args)
    if source.is_dir():
        plan, settings = _evaluated_plan(args, source)
        if settings and args.config is None:
            config = from_mapping(Config, settings)
        title = f"{source.name}: episode {args.episode}, {args.planner} ({args.carrier or 'robot'})"
    else:
        given = [f"--{name}" for name in ("episode", "planner", "carrier")
                 if getattr(args, name) is not None]
        if given:
            raise ValueError(f"{', '.join(given)} choose an episode of an evaluation folder; "
                             f"{source} is a plan file")
        plan, title = source, source.name
    with showing_progress():
        scene, record = episode_from_plan(config, plan)
    page = plan_page(scene, record, title)
    if args.html:
        print(f"wrote {write_page(page, args.html)} ({len(page.html) / 1e6:.1f} MB, "
              f"{page.views} views, {page.duration_s:.1f} s of motion)")
        return 0
    server = page_server(page, args.host, args.port)
    port = server.server_address[1]
    print(f"serving {plan} at http://{args.host}:{port}/ (Ctrl-C to stop)", flush=True)
    with server:
        server.serve_forever()
    return 0
