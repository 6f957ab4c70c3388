"""What a teacher folder's labels say: the remaining covers and the views to the goal.

Reads every shard of a teacher folder (`vprobot teacher`) and writes a JSON summary: states, how
many candidates are allowed, in how many states the goal is in reach, the fewest views to the
goal, how many candidates belong to some smallest cover, the size of the one cover the solver
names, and how often that cover has the fewest views where it reaches the goal in the views left.

    python scripts/teacher_labels.py runs/real-candidates/teacher \
        --out results/generalist/real-cover/labels.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from vprobot.files.atomic import write_text
from vprobot.training.pretrain import read_shards


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a teacher folder")
    parser.add_argument("--out", type=Path, required=True, help="JSON to write")
    args = parser.parse_args()
    files = sorted(args.folder.glob("shard-*.npz"))
    if not files:
        parser.error(f"{args.folder} holds no teacher shards (shard-*.npz)")
    states = read_shards(files)
    allowed = states.observations["mask"] > 0.5
    views = np.where(allowed, states.cover_views, np.inf)
    fewest = views.min(axis=1)
    reach = np.isfinite(fewest)
    members = (views <= fewest[:, None]) & reach[:, None]
    size = states.cover.sum(axis=1)
    reaches = states.cover_reaches
    summary = {
        "folder": str(args.folder), "shards": len(files), "states": len(states),
        "allowed_mean": float(allowed.sum(axis=1).mean()),
        "goal_in_reach_pct": 100 * float(reach.mean()),
        "fewest_views_mean": float(fewest[reach].mean()),
        "fewest_views_counts": {int(v): int(n) for v, n in
                                zip(*np.unique(fewest[reach], return_counts=True), strict=True)},
        "smallest_cover_members_mean": float(members[reach].sum(axis=1).mean()),
        "smallest_cover_members_median": float(np.median(members[reach].sum(axis=1))),
        "one_cover_size_mean": float(size.mean()),
        "one_cover_reaches_pct": 100 * float(reaches.mean()),
        "one_cover_proven_pct": 100 * float(states.cover_proven.mean()),
        "one_cover_is_fewest_where_it_reaches_pct":
            100 * float((size[reaches] == fewest[reaches]).mean()),
    }
    write_text(args.out, json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
