"""What the occupancy grid says is still measurable, against the coverage, view by view (issue 45,
item 4: a model-free bound).

Runs `nbv` (budget `--views`, the simulator's goal off) on an episode list and, before every
request, counts the frontier voxels (unknown, next to free space) in the box that bounds the
occupied voxels that an offered candidate's sensor would measure (`ViewGains.measurable`: seen
with a visibility of at least 0.5, lit by its projector within both incidence limits), beside
the episode's true coverage. Writes one row per view to `--out` (CSV).

    python scripts/measurable_surface.py --config configs/cell_real.yaml \
        --episodes validation-v2 --out results/real/measurable_surface.csv
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vprobot.config import load_config
from vprobot.coverage.occupancy import OCCUPIED
from vprobot.episode import PartScene
from vprobot.episode.views import band_candidates, offered, request_directions
from vprobot.evaluation import evaluation_episodes
from vprobot.planners import nbv
from vprobot.planners.runner import run

COLUMNS = ("episode", "object", "views", "coverage", "occupied", "box_frontier",
           "box_measurable")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--episodes", required=True)
    parser.add_argument("--views", type=int, default=15)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    config = load_config(args.config)
    rows: list[dict[str, object]] = []
    step = nbv.VolumetricPlanner.next_view
    current: dict[str, object] = {}

    def counted(planner: nbv.VolumetricPlanner, episode: nbv.Episode) -> object:
        band = band_candidates(planner.config, planner.voxel_m)
        allowed = offered(band.directions, request_directions(episode.views, episode.center),
                          planner._failed)
        grid = episode.occupancy(planner.settings).grid
        cells = np.argwhere(grid.state == OCCUPIED)
        box = np.zeros(grid.state.shape, dtype=bool)
        if len(cells):
            low, high = cells.min(axis=0), cells.max(axis=0) + 1
            box[low[0]:high[0], low[1]:high[1], low[2]:high[2]] = True
        measurable = band.gains.measurable(grid, allowed, "frontier", 0.5)
        rows.append({**current, "views": len(episode.views),
                     "coverage": round(float(episode.coverage), 4),
                     "occupied": len(cells),
                     "box_frontier": int((grid.kind_mask("frontier") & box).sum()),
                     "box_measurable": int(box.reshape(-1)[measurable].sum())})
        return step(planner, episode)

    nbv.VolumetricPlanner.next_view = counted  # type: ignore[method-assign]
    for index, spec in enumerate(tqdm(evaluation_episodes(config, episodes=args.episodes))):
        current.update(episode=index, object=str(spec.part))
        scene = PartScene.load(config, spec.part_path, spec.scale)
        run(config, scene, "nbv", spec, stop=f"views:{args.views}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as file:
        writer = csv.DictWriter(file, COLUMNS)
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
