"""How `nbv`'s revisit gain was chosen (issue 45): `nbv` on a validation list of the realistic
cell under every weight of the revisit gain (`nbv.REVISIT_WEIGHT`; 0: without it, `nbv` as it was
before) and two angles (`view_gains.REVISIT_DEG`: 30, only the bin a voxel was measured from
counts as seen; 50, that bin and its neighbours), the robot in the loop, the simulator's goal.

Writes one row per setting and episode to `--out` (`settings.csv`: the setting, the episode, its
part, the acquisitions, the coverage, whether it reached the goal) and a summary table beside
it (`settings.md`); a run again skips the settings already written.

    python scripts/revisit_sweep.py --config configs/cell_real.yaml --episodes validation-v2 \\
        --out results/real/revisit --workers 2
"""

from __future__ import annotations

import argparse
import csv
import itertools
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from vprobot.config import load_config
from vprobot.coverage import view_gains
from vprobot.episode import PartScene
from vprobot.evaluation import evaluation_episodes
from vprobot.planners import nbv
from vprobot.planners.runner import run

WEIGHTS = (0.0, 1.0, 3.0, 10.0, 30.0)
ANGLES_DEG = (30.0, 50.0)
COLUMNS = ("weight", "angle_deg", "episode", "part", "acquisitions", "coverage", "success")


def _setting(config_path: str, episodes: str, weight: float, angle_deg: float
             ) -> list[dict[str, object]]:
    """Every episode of the list under one setting."""
    nbv.REVISIT_WEIGHT = weight
    view_gains._SEEN_NEAR = view_gains.seen_near(angle_deg)
    config = load_config(config_path)
    rows = []
    for index, spec in enumerate(evaluation_episodes(config, episodes=episodes)):
        scene = PartScene.load(config, spec.part_path, spec.scale)
        result = run(config, scene, "nbv", spec)
        rows.append({"weight": weight, "angle_deg": angle_deg, "episode": index,
                     "part": str(spec.part), "acquisitions": result.acquisitions,
                     "coverage": round(result.coverage, 4), "success": result.success})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--episodes", required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    table = args.out / "settings.csv"
    rows = list(csv.DictReader(table.open())) if table.exists() else []
    done = {(float(row["weight"]), float(row["angle_deg"])) for row in rows}
    # Without the gain the angle changes nothing: one run.
    settings = [(weight, angle) for weight, angle in itertools.product(WEIGHTS, ANGLES_DEG)
                if (weight, angle) not in done and not (weight == 0.0 and angle != ANGLES_DEG[-1])]
    args.out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(_setting, args.config, args.episodes, *setting)
                   for setting in settings]
        for future in futures:
            rows.extend(future.result())
            # Each setting's rows once it is whole: a run again starts from the next.
            with table.open("w", newline="") as file:
                writer = csv.DictWriter(file, COLUMNS)
                writer.writeheader()
                writer.writerows(rows)
    lines = ["| weight | angle deg | at goal | acquisitions, mean |", "|---|---|---|---|"]
    for (weight, angle), group in itertools.groupby(
            sorted(rows, key=lambda row: (float(row["weight"]), float(row["angle_deg"]))),
            key=lambda row: (float(row["weight"]), float(row["angle_deg"]))):
        episodes = list(group)
        at_goal = sum(str(row["success"]) == "True" for row in episodes)
        mean = np.mean([int(row["acquisitions"]) for row in episodes])
        lines.append(f"| {weight:g} | {angle:g} | {at_goal} of {len(episodes)} | {mean:.2f} |")
    (args.out / "settings.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
