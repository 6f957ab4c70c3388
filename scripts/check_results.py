"""Regenerate a committed `vprobot evaluate` folder and compare it with the committed tables.

Runs `vprobot evaluate` on the folder's own episode list (`episodes.json`) with the planners and
carriers of its table, into a temporary folder and with an empty cache (as a fresh clone has),
then compares every episode row cell by cell (`vprobot report compare`'s rule: timing columns
left out) and, for a full regeneration, the summary table `evaluation.csv` too. Prints each cell
that differs and exits 1 if any does.

The committed tables were made with OpenBLAS's Haswell kernels; on an x86-64 CPU with AVX-512
OpenBLAS picks other kernels whose rounding moves a few borderline ground-truth points (up to
about 0.5 pp of a mean). The regeneration therefore runs with `OPENBLAS_CORETYPE=Haswell`
unless the variable is set already.

Usage:
    python scripts/check_results.py results/motors                  # all of it (minutes)
    python scripts/check_results.py results/motors --episodes 0 3 --carriers free \\
        --planners random2 uniform4                                 # a subset (seconds)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import yaml

from vprobot.evaluation import SETTINGS_NAME
from vprobot.report.compare import moved_cells, read_rows

ROOT = Path(__file__).resolve().parents[1]
EPISODE_KEY = ("episode", "carrier", "planner")
"""What names an episode row."""


def regenerate(folder: Path, out: Path, episodes: Sequence[int] | None = None,
               planners: Sequence[str] | None = None,
               carriers: Sequence[str] | None = None) -> None:
    """Run `vprobot evaluate` for (a subset of) a committed evaluation folder into `out`.

    Args:
        folder: The committed folder (`episodes.json`, `evaluation.csv`).
        out: Where the regenerated tables go (a fresh folder).
        episodes: Indices into the folder's episode list; None: all of them.
        planners: Planners to run; None: those of the committed table.
        carriers: Carriers to run; None: those of the committed table.

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
    env = dict(os.environ)
    if platform.machine().lower() in ("x86_64", "amd64"):
        env.setdefault("OPENBLAS_CORETYPE", "Haswell")
    # An empty cache: ground truth and generated objects are built by this code, as in a clone.
    env["VPROBOT_CACHE_DIR"] = str(out / "cache")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(ROOT), env.get("PYTHONPATH"))))
    subprocess.run([sys.executable, "-m", "vprobot.cli", "evaluate", "--config",
                    str(out / "config.yaml"), "--episodes", str(out / "list.json"),
                    "--planners", *planners, "--carriers", *carriers,
                    *(["--estimator", estimator] if (estimator := recorded_estimator(folder))
                      else []),
                    "--out", str(out / "tables")], check=True, cwd=ROOT, env=env,
                   stdout=subprocess.DEVNULL)


def _settings(folder: Path) -> dict:
    path = folder / SETTINGS_NAME
    return json.loads(path.read_text()) if path.is_file() else {}


def recorded_config(folder: Path) -> dict:
    """The config a committed folder was evaluated with, as a config file's sections.

    Its settings record (`evaluation_settings.json`) has it; folders without one were made with
    the default config of their time. Records made before the robot planned its moves
    (`kinematics.path_planner`, issue 32) moved along straight joint-space lines.
    """
    config = _settings(folder).get("config", {})
    config.setdefault("kinematics", {}).setdefault("path_planner", "line")
    return config


def recorded_estimator(folder: Path) -> str | None:
    """The estimator file a committed folder's settings record names, if any."""
    return _settings(folder).get("estimator")


def differences(folder: Path, out: Path, episodes: Sequence[int] | None = None) -> list[str]:
    """The cells of the committed folder that its regeneration in `out` does not reproduce.

    Args:
        folder: The committed folder.
        out: The folder `regenerate` wrote.
        episodes: The indices it regenerated; None: all (the summary table is compared too).
    """
    committed = read_rows(folder / "evaluation_episodes.csv")
    new = read_rows(out / "tables" / "evaluation_episodes.csv")
    if episodes is not None:
        # Back to the committed list's numbering.
        for row in new:
            row["episode"] = str(episodes[int(row["episode"])])
    moved, _ = moved_cells(committed, new, EPISODE_KEY)
    if episodes is None:
        regenerated = {episode_key(row) for row in new}
        moved += [f"{episode_key(row)}: not regenerated" for row in committed
                  if episode_key(row) not in regenerated]
        summary, _ = moved_cells(read_rows(folder / "evaluation.csv"),
                                 read_rows(out / "tables" / "evaluation.csv"),
                                 ("planner", "carrier"))
        moved += summary
    return moved


def episode_key(row: dict[str, str]) -> tuple[str, ...]:
    return tuple(row[name] for name in EPISODE_KEY)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a committed evaluation folder, e.g. "
                        "results/motors")
    parser.add_argument("--episodes", type=int, nargs="+",
                        help="indices into its episodes.json (default: all)")
    parser.add_argument("--planners", nargs="+", help="default: those of its table")
    parser.add_argument("--carriers", nargs="+", help="default: those of its table")
    args = parser.parse_args()
    needed = ("episodes.json", "evaluation.csv", "evaluation_episodes.csv")
    if not all((args.folder / name).is_file() for name in needed):
        print(f"{args.folder} is not an evaluation folder: it needs {', '.join(needed)}",
              file=sys.stderr)
        return 2
    count = len(json.loads((args.folder / "episodes.json").read_text())["episodes"])
    if args.episodes and not all(0 <= index < count for index in args.episodes):
        print(f"--episodes {' '.join(map(str, args.episodes))}: {args.folder} has episodes 0 "
              f"to {count - 1}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="check-results-") as temporary:
        out = Path(temporary) / "regenerated"
        regenerate(args.folder, out, args.episodes, args.planners, args.carriers)
        moved = differences(args.folder, out, args.episodes)
        rows = len(read_rows(out / "tables" / "evaluation_episodes.csv"))
    for line in moved:
        print(line)
    print(f"{args.folder}: {rows} episode rows regenerated, {len(moved)} cells differ")
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main())
