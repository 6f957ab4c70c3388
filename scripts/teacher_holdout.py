"""How well each imitation target carries over to teacher states it was not fitted to.

Fits the candidate Q-network of an agent profile to the first shards of its teacher folder with
each `agent.pretrain_target`, then scores the greedy choice on the last shards (other episodes
of the training objects, never a validation or test object): how often it is a member of some
smallest remaining cover (its views to the goal are the state's fewest), how many views beyond
the fewest it costs on the mean (both over the states whose goal is in reach), and the coverage
it adds against the teacher's best; for the targets with the head of the views left, that
head's mean absolute error in views, beside the error of the fitted states' median. A
diagnostic of the targets in seconds of CPU a target, not model selection: that stays with the
validation list (`vprobot train`).

    python scripts/teacher_holdout.py vprobot/configs/agents/real-cover.yaml \
        --out results/generalist/real-cover/holdout.csv
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

from vprobot.agents.candidate_q import CandidateDQN
from vprobot.agents.models import build_model
from vprobot.config import load_config, replace
from vprobot.files.atomic import atomic_output
from vprobot.training.pretrain import TeacherStates, fit, loss_column, read_shards

TARGETS = ("values", "cover", "views")


class _Spaces(gym.Env):
    """The candidate env's spaces, read from the teacher's states: the model needs no cell."""

    def __init__(self, states: TeacherStates) -> None:
        self.observation_space = gym.spaces.Dict({
            key: gym.spaces.Box(-np.inf, np.inf, value.shape[1:], np.float32)
            for key, value in states.observations.items()})
        self.action_space = gym.spaces.Discrete(states.values.shape[1])


def score(model: CandidateDQN, states: TeacherStates, typical_left: float) -> dict[str, float]:
    """Over the states whose goal is in reach: the greedy choice's membership in a smallest
    cover and views beyond the fewest; over all: its gain against the best candidate's; and the
    head of the views left's mean absolute error beside that of `typical_left` (the fitted
    states' median) for every state."""
    actions, _ = model.predict(states.observations, deterministic=True)
    allowed = states.observations["mask"] > 0.5
    views = np.where(allowed, states.cover_views, np.inf)
    fewest = views.min(axis=1)
    rows = np.arange(len(actions))
    chosen = views[rows, actions]
    known = np.isfinite(fewest)
    best_gain = np.where(allowed, states.values, -np.inf).max(axis=1)
    scores = {"in_reach": float(known.sum()),
              "member_pct": 100 * float(np.mean(chosen[known] <= fewest[known])),
              "views_beyond": float(np.mean(chosen[known] - fewest[known])),
              "gain_pct_of_best": 100 * float(states.values[rows, actions].sum()
                                              / best_gain.sum()),
              "views_left_mae": float("nan"), "median_left_mae": float("nan")}
    q_net = model.policy.q_net
    if q_net.views_left_head is not None:
        left = states.views_left  # the labels `fit` fits the head to
        known = np.isfinite(left)
        with torch.no_grad():
            predicted = q_net.views_left(
                {key: torch.as_tensor(value[known]) for key, value in states.observations.items()})
        scores["views_left_mae"] = float(np.mean(np.abs(predicted.numpy() - left[known])))
        scores["median_left_mae"] = float(np.mean(np.abs(typical_left - left[known])))
    return scores


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("profile", type=Path, help="agent profile with a teacher_dir")
    parser.add_argument("--held-out", type=int, default=2, help="last shards held out")
    parser.add_argument("--epochs", type=int, default=100)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--targets", nargs="+", choices=TARGETS, default=list(TARGETS))
    parser.add_argument("--net-arch", type=int, nargs="+",
                        help="hidden widths of the network (default: the profile's)")
    parser.add_argument("--out", type=Path, required=True, help="CSV to write")
    args = parser.parse_args()
    config = load_config(args.profile)
    if args.net_arch:
        config = replace(config, "agent", net_arch=tuple(args.net_arch))
    if (config.agent.algorithm, config.agent.encoder) != ("dqn", "candidates"):
        parser.error(f"{args.profile} is not a candidate agent's profile (agent.algorithm dqn, "
                     f"agent.encoder candidates)")
    if not config.agent.teacher_dir:
        parser.error(f"{args.profile} sets no agent.teacher_dir")
    files = sorted(Path(config.agent.teacher_dir).glob("shard-*.npz"))
    if len(files) <= args.held_out or args.held_out < 1:
        parser.error(f"--held-out must lie in 1 .. {len(files) - 1} ({len(files)} shards in "
                     f"{config.agent.teacher_dir}), got {args.held_out}")
    fitted, held = read_shards(files[:-args.held_out]), read_shards(files[-args.held_out:])
    left = fitted.views_left
    typical_left = float(np.median(left[np.isfinite(left)]))
    torch.set_num_threads(1)
    rows = []
    for target in args.targets:
        for seed in args.seeds:
            run = replace(config, "agent", pretrain_target=target)
            model = build_model(run, _Spaces(fitted), seed=seed, device="cpu")
            assert isinstance(model, CandidateDQN)  # checked above: dqn over candidates
            loss = fit(model, fitted, args.epochs, seed, target)[loss_column(target)]
            for name, states in (("fitted", fitted), ("held_out", held)):
                rows.append({"target": target, "seed": seed, "epochs": args.epochs,
                             "net_arch": " ".join(map(str, config.agent.net_arch)),
                             "states": name, "count": len(states), "final_loss": loss[-1],
                             **score(model, states, typical_left)})
                print(", ".join(f"{key} {value:.4g}" if isinstance(value, float)
                                else f"{key} {value}" for key, value in rows[-1].items()))
    with atomic_output(args.out) as temporary, temporary.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
