"""Bundle a training run's best model as vprobot's agent (vprobot/assets/agents/cpu/).

Copies the model, the run's resolved config, its command line (seed, commit), curves and
evaluations, and writes a README saying how it was trained and how it scored.
"""

from __future__ import annotations

import argparse
import csv
import shutil
from pathlib import Path

from vprobot.agents.runs import current_names, evaluation_score
from vprobot.agents.trained import BUNDLED_AGENT, load_run_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the training run directory")
    parser.add_argument("--out", type=Path, default=BUNDLED_AGENT)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.copy(args.run / "best_model.zip", args.out / "model.zip")
    for name in ("config.yaml", "command.txt", "curves.png", "evaluations.csv"):
        shutil.copy(args.run / name, args.out / name)
    rows = [current_names(row) for row in
            csv.DictReader((args.run / "evaluations.csv").read_text().splitlines())]
    best = max(rows, key=evaluation_score)
    first = next((row for row in rows if float(row["coverage_pct"]) >= 90.0), None)
    reached = (f"first at or above 90 % after {int(first['step']):,} steps, "
               f"{float(first['wall_s']) / 60:.1f} min" if first else "never at 90 %")
    command = (args.run / "command.txt").read_text().splitlines()
    config = load_run_config(args.run)
    decides = ", and decides itself when to stop" if config.env.stop_action else ""
    (args.out / "README.md").write_text(f"""# A bundled agent

Trained by `{command[0]}` ({command[1]}, {command[2]}): {config.agent.algorithm.upper()}, the
`{config.agent.encoder}` encoder on `{config.env.state}` ({config.env.state_points} points),
{config.env.action}, {config.env.reward}, carrier `{config.env.carrier}`{decides}.
`model.zip` is the run's best evaluated model (step {int(best['step']):,}):
on the 15 shared test episodes, deterministic, at full sensor resolution, it covered
{float(best['coverage_pct']):.1f} % with {float(best['acquisitions']):.2f} acquisitions,
{float(best['reachable_pct'] or 100):.0f} % of its requests reachable. Evaluations during
training ({reached}): `evaluations.csv`; curves: `curves.png`; the resolved configuration
(`config.yaml`) tells the planner how the agent sees and acts.

Loaded with `vprobot plan --planner agent:{args.out}` (`--planner agent` for the default one;
CPU only, no network).
""")
    print(f"bundled {args.run} into {args.out}")


if __name__ == "__main__":
    main()
