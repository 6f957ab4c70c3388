"""Bundle a training run's best model as one of vprobot's agents (vprobot/assets/agents/NAME/).

Copies the model, the run's resolved config, its command line (seed, commit), curves and
evaluations, and writes a README saying how it was trained and how it scored.
"""

from __future__ import annotations

import argparse
import csv
import shutil
from pathlib import Path

from vprobot.agents.trained import BUNDLED_AGENT, describe_sensor, load_run_config
from vprobot.training.runs import best_evaluation, current_names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the training run directory")
    parser.add_argument("--out", type=Path, default=BUNDLED_AGENT,
                        help="the bundled agent's folder (default: that of --planner agent)")
    parser.add_argument("--results", default=None,
                        help="where the agent's test-list results are (named in the README)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.copy(args.run / "best_model.zip", args.out / "model.zip")
    for name in ("config.yaml", "command.txt", "curves.png", "evaluations.csv"):
        shutil.copy(args.run / name, args.out / name)
    config = load_run_config(args.run)
    rows = [current_names(row) for row in
            csv.DictReader((args.run / "evaluations.csv").read_text().splitlines())]
    best = best_evaluation(args.run / "evaluations.csv", config.agent.select)
    first = next((row for row in rows if float(row["coverage_pct"]) >= 90.0), None)
    reached = (f"first at or above 90 % after {int(first['step']):,} steps, "
               f"{float(first['wall_s']) / 60:.1f} min" if first else "never at 90 %")
    command = (args.run / "command.txt").read_text().splitlines()
    fitted_to = {"values": "values", "cover": "remaining covers (membership in some smallest "
                 "cover)", "views": "views to the goal"}[config.agent.pretrain_target]
    pretrained = (f", the Q-network fitted to the teacher's {fitted_to} before any RL step"
                  if int(best["step"]) == 0 and config.agent.pretrain_episodes else "")
    decides = ", and decides itself when to stop" if config.env.stop_action else ""
    (args.out / "README.md").write_text(f"""# A bundled agent

Trained by `{command[0]}` ({command[1]}, {command[2]}): {config.agent.algorithm.upper()}, the
`{config.agent.encoder}` encoder on `{config.env.state}`, {config.env.action},
{config.env.reward}, carrier `{config.env.carrier}`{decides}; with the sensor
{describe_sensor(config.sensor)} (it plans with that sensor and sensing model only).
`model.zip` is the run's best evaluated model under `agent.select: {config.agent.select}`
(step {int(best['step']):,}{pretrained}): on the run's {int(float(best['episodes']))} evaluation
episodes, deterministic, at full sensor resolution, it covered
{float(best['coverage_pct']):.1f} % with {float(best["acquisitions"]):.2f} acquisitions,
reaching the goal in
{float(best['success_pct']):.0f} % of them, {float(best['reachable_pct'] or 100):.0f} % of its
requests reachable. Evaluations during training ({reached}): `evaluations.csv`; curves:
`curves.png`; the resolved configuration (`config.yaml`) tells the planner how the agent sees
and acts.{f" Its scores on the test lists: `{args.results}`." if args.results else ""}

Loaded with `vprobot plan --planner agent:{args.out.name}` (`--planner agent` for the default
one; CPU only, no network).
""")
    print(f"bundled {args.run} into {args.out}")


if __name__ == "__main__":
    main()
