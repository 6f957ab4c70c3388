"""A committed `vprobot evaluate` folder regenerated and compared with its tables (`vprobot
report check`).

Runs `vprobot evaluate` on the folder's own episode list (`episodes.json`) with the planners and
carriers of its table and its recorded config, into a given folder and with an empty cache (as a
fresh clone has), then compares every episode row cell by cell (`compare.moved_cells`: timing
columns left out) and, for a full regeneration, the summary table `evaluation.csv` too.

The committed tables were made with OpenBLAS's Haswell kernels, which vprobot pins on every
x86-64 CPU with AVX2 (`vprobot.compute.kernels`), the child included.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from vprobot.compute.processes import child_environment
from vprobot.evaluation import EPISODES_NAME, SETTINGS_NAME
from vprobot.extensions import plugins
from vprobot.files.paths import PACKAGE_DIR
from vprobot.report.compare import EPISODE_KEY, SUMMARY_KEY, moved_cells, read_rows

NEEDED = ("episodes.json", "evaluation.csv", EPISODES_NAME)
"""What makes a folder a committed evaluation folder."""


def episode_count(folder: Path) -> int:
    """The number of episodes of a committed evaluation folder.

    Raises:
        ValueError: If the folder lacks one of `NEEDED`.
    """
    if not all((folder / name).is_file() for name in NEEDED):
        raise ValueError(f"{folder} is not an evaluation folder: it needs {', '.join(NEEDED)}")
    return len(json.loads((folder / "episodes.json").read_text())["episodes"])


def regenerate(folder: Path, out: Path, episodes: Sequence[int] | None = None,
               planners: Sequence[str] | None = None,
               carriers: Sequence[str] | None = None, scratch: Path | None = None,
               cache: Path | None = None) -> None:
    """Run `vprobot evaluate` for (a subset of) a committed evaluation folder into `out`, in a
    child that ends with this process (`vprobot.compute.processes`) and loads its plugins.

    Args:
        folder: The committed folder (`episodes.json`, `evaluation.csv`).
        out: Where the regenerated tables go (a fresh folder; the tables in `out/tables`).
        episodes: Indices into the folder's episode list; None: all of them.
        planners: Planners to run; None: those of the committed table.
        carriers: Carriers to run; None: those of the committed table.
        scratch: A temporary folder holding `out`, which the child removes if this process
            ends before it (killed).
        cache: vprobot's cache for the child; None: an empty one in `out`, so that ground
            truths, generated objects and view bands are built by this code, as in a clone.

    Raises:
        subprocess.CalledProcessError: If the evaluation fails.
    """
    table = read_rows(folder / "evaluation.csv")
    planners = planners or list(dict.fromkeys(row["planner"] for row in table))
    carriers = carriers or list(dict.fromkeys(row["carrier"] for row in table))
    episode_list = json.loads((folder / "episodes.json").read_text())
    if episodes is not None:
        episode_list["episodes"] = [episode_list["episodes"][index] for index in episodes]
    out.mkdir(parents=True)
    (out / "list.json").write_text(json.dumps(episode_list))
    (out / "config.yaml").write_text(yaml.safe_dump(recorded_config(folder)))
    env = child_environment(scratch)
    env["VPROBOT_CACHE_DIR"] = str(cache if cache is not None else out / "cache")
    root = PACKAGE_DIR.parent
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(root), env.get("PYTHONPATH"))))
    subprocess.run([sys.executable, "-m", "vprobot.cli", *plugins.command_options(), "evaluate",
                    "--config", str(out / "config.yaml"), "--episodes", str(out / "list.json"),
                    "--planners", *planners, "--carriers", *carriers,
                    *(["--estimator", estimator] if (estimator := recorded_estimator(folder))
                      else []),
                    "--out", str(out / "tables")], check=True, cwd=root, env=env,
                   stdout=subprocess.DEVNULL)


def _settings(folder: Path) -> dict[str, Any]:
    path = folder / SETTINGS_NAME
    return json.loads(path.read_text()) if path.is_file() else {}


def recorded_config(folder: Path) -> dict[str, Any]:
    """The config a committed folder was evaluated with, as a config file's sections.

    Its settings record (`evaluation_settings.json`) has it; folders without one were made with
    the default config of their time. Records made before the robot planned its moves
    (`kinematics.path_planner`, issue 32) moved along straight joint-space lines.
    """
    config: dict[str, Any] = _settings(folder).get("config", {})
    config.setdefault("kinematics", {}).setdefault("path_planner", "line")
    return config


def recorded_estimator(folder: Path) -> str | None:
    """The estimator file a committed folder's settings record names, if any."""
    estimator: str | None = _settings(folder).get("estimator")
    return estimator


def differences(folder: Path, out: Path, episodes: Sequence[int] | None = None) -> list[str]:
    """The cells of the committed folder that its regeneration in `out` does not reproduce.

    Args:
        folder: The committed folder.
        out: The folder `regenerate` wrote.
        episodes: The indices it regenerated; None: all (the summary table is compared too).
    """
    committed = read_rows(folder / EPISODES_NAME)
    new = read_rows(out / "tables" / EPISODES_NAME)
    if episodes is not None:
        # Back to the committed list's numbering.
        for row in new:
            row["episode"] = str(episodes[int(row["episode"])])
    moved, _ = moved_cells(committed, new, EPISODE_KEY)
    if episodes is None:
        regenerated = {_episode_key(row) for row in new}
        moved += [f"{_episode_key(row)}: not regenerated" for row in committed
                  if _episode_key(row) not in regenerated]
        summary, _ = moved_cells(read_rows(folder / "evaluation.csv"),
                                 read_rows(out / "tables" / "evaluation.csv"), SUMMARY_KEY)
        moved += summary
    return moved


def _episode_key(row: dict[str, str]) -> tuple[str, ...]:
    return tuple(row[name] for name in EPISODE_KEY)
