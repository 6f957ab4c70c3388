"""One table per test list: seed-averaged agent rows (`vprobot train --seeds`) beside baselines.

The agents' `seeds.csv` give mean and min-max over seeds; the baselines come from a
`vprobot evaluate` folder on the same episode list (checked: its `episodes.json` must equal the
bundled list, so agents and baselines are scored on the same episodes).

Usage:
    python scripts/compare_with_baselines.py --agents motors=results/families/motors \
        mix=results/families/mix --out results/families/comparison.md
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

from vprobot.episode.specs import bundled_episode_list

BASELINES = {"test-v1": "results/motors", "families-test-v1": "results/families-test",
             "shapes-v1": "results/shapes"}
"""The committed baseline evaluation of each test list."""
PLANNERS = ("uniform4", "uniform5", "uniform6", "nbv", "nbv@grid", "bscp", "oracle")
"""The baseline rows shown: the model-free ones, then the two that use the model."""
METRICS = (("coverage_pct", "{:.1f}"), ("acquisitions", "{:.2f}"), ("success_pct", "{:.0f}"))


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def agent_cell(row: dict[str, str], key: str, fmt: str) -> str:
    return (f"{fmt.format(float(row[key]))} ({fmt.format(float(row[key + '_min']))}-"
            f"{fmt.format(float(row[key + '_max']))})")


def table(name: str, agents: dict[str, Path]) -> list[str]:
    baseline_dir = Path(BASELINES[name])
    listed = json.loads(bundled_episode_list(name).read_text())["episodes"]
    if json.loads((baseline_dir / "episodes.json").read_text())["episodes"] != listed:
        raise SystemExit(f"{baseline_dir}/episodes.json is not the episode list {name}")
    lines = [f"### {name}", "", "| planner | seeds | coverage % | acquisitions | at goal % |",
             "|---|---|---|---|---|"]
    for label, folder in agents.items():
        rows = [row for row in read_csv(folder / "seeds.csv") if row["evaluation"] == name]
        for row in rows:
            cells = [agent_cell(row, key, fmt) for key, fmt in METRICS]
            lines.append(f"| agent ({label}) | {row['seeds']} | {' | '.join(cells)} |")
    for row in read_csv(baseline_dir / "evaluation.csv"):
        if row["carrier"] == "robot" and row["planner"] in PLANNERS:
            cells = [fmt.format(float(row[key])) for key, fmt in METRICS]
            lines.append(f"| {row['planner']} | - | {' | '.join(cells)} |")
    return [*lines, ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agents", nargs="+", required=True, metavar="LABEL=DIR",
                        help="folders holding a seeds.csv, each with a label")
    parser.add_argument("--out", type=Path, required=True, help="the markdown file to write")
    args = parser.parse_args()
    agents = {}
    for item in args.agents:
        label, sep, folder = item.partition("=")
        if not sep or not (Path(folder) / "seeds.csv").is_file():
            raise SystemExit(f"--agents {item}: expected LABEL=DIR with DIR/seeds.csv")
        agents[label] = Path(folder)
    lines = ["# Agents (mean, min-max over seeds) beside the baselines, robot in the loop", "",
             "Written by `python scripts/compare_with_baselines.py "
             f"--agents {' '.join(args.agents)} --out {args.out}`; agents from their "
             "`seeds.csv`, baselines from `results/motors`, `results/families-test` and "
             "`results/shapes` (the same episodes).", ""]
    for name in BASELINES:
        lines += table(name, agents)
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
