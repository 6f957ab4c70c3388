"""Probe the candidate agent's imitation alone: teacher states, a fit, the validation score.

    python scripts/probe_imitation.py --episodes 150 --epochs 300 [--listwise 0.01 0.02]

Collects `--episodes` teacher episodes with the cpu-candidates profile (one env, seed 0;
cached in --cache by episode count), fits a fresh DQN's Q-network to them and prints the
fit's regret on its own states (the teacher's best value minus that of the network's greedy
pick, beside a uniform allowed pick's) and the greedy policy's summary on the validation
episodes (`vprobot.episode.specs.validation_episodes`; never a test list). `--zero-gains` maps the
value -1 of allowed candidates to 0, as the teacher of commit c947c57 on does itself;
`--listwise LAMBDA TAU` adds LAMBDA x the cross-entropy of softmax(Q / TAU) against
softmax(values / TAU) to the squared error, on a held-out fifth of the states.
The record of what was tried is results/generalist/README.md.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.utils import obs_as_tensor

from vprobot.agents.candidate_q import MASK_KEY, allowed_rows
from vprobot.agents.evaluation import evaluate_policy, evaluation_env, policy_summary
from vprobot.agents.pretrain import TeacherStates, collect, fit
from vprobot.agents.training import build_model, make_vec_env, profile_config
from vprobot.episode.specs import validation_episodes

PROFILE = "configs/agents/cpu-candidates.yaml"


def load_states(config, episodes: int, cache: Path) -> TeacherStates:
    path = cache / f"states_{episodes}.npz"
    if path.is_file():
        data = np.load(path)
        return TeacherStates({key[4:]: data[key] for key in data if key.startswith("obs_")},
                             data["values"])
    start = time.perf_counter()
    states = collect(config, episodes, seed=0)
    print(f"collect {time.perf_counter() - start:.0f}s", flush=True)
    cache.mkdir(parents=True, exist_ok=True)
    np.savez(path, values=states.values,
             **{f"obs_{key}": value for key, value in states.observations.items()})
    return states


def regrets(model, states: TeacherStates, rows: np.ndarray) -> tuple[float, float]:
    observations = {key: value[rows] for key, value in states.observations.items()}
    actions, _ = model.predict(observations, deterministic=True)
    values = np.where(observations[MASK_KEY] > 0.5, states.values[rows], np.nan)
    best = np.nanmax(values, axis=1)
    chosen = states.values[rows][np.arange(len(actions)), actions]
    return float(np.mean(best - chosen)), float(np.mean(best - np.nanmean(values, axis=1)))


def fit_listwise(model, states: TeacherStates, rows: np.ndarray, epochs: int, weight: float,
                 temperature: float) -> None:
    q_net = model.policy.q_net
    optimizer = torch.optim.Adam(q_net.parameters(), lr=model.lr_schedule(1.0))
    rng = np.random.default_rng(0)
    for _ in range(epochs):
        order = rng.permutation(rows)
        for start in range(0, len(order), model.batch_size):
            batch = order[start:start + model.batch_size]
            obs = obs_as_tensor({key: value[batch]
                                 for key, value in states.observations.items()}, "cpu")
            target = torch.as_tensor(states.values[batch])
            allowed = allowed_rows(obs[MASK_KEY])
            q = q_net(obs)
            mse = ((q - target) * allowed.float()).square().sum() / allowed.float().sum()
            logits = (q / temperature).masked_fill(~allowed, -1e9)
            wanted = torch.softmax((target / temperature).masked_fill(~allowed, -1e9), dim=1)
            cross_entropy = -(wanted * torch.log_softmax(logits, dim=1)).sum(1).mean()
            loss = mse + weight * cross_entropy
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    model.policy.q_net_target.load_state_dict(q_net.state_dict())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=150)
    parser.add_argument("--epochs", type=int, default=300)
    parser.add_argument("--zero-gains", action="store_true")
    parser.add_argument("--listwise", type=float, nargs=2, metavar=("LAMBDA", "TAU"))
    parser.add_argument("--cache", type=Path, default=Path("runs/probe_imitation"))
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = profile_config(PROFILE, ["agent.n_envs=1"])
    states = load_states(config, args.episodes, args.cache)
    if args.zero_gains:
        allowed = states.observations[MASK_KEY] > 0.5
        states.values = np.where((states.values == -1) & allowed, 0.0,
                                 states.values).astype(np.float32)
    model = build_model(config, make_vec_env(config, 0, [0], None), 0, "cpu")
    start = time.perf_counter()
    everything = np.arange(len(states))
    if args.listwise is None:
        losses = fit(model, states, args.epochs, seed=0)
        print(f"states {len(states)} fit {time.perf_counter() - start:.0f}s losses "
              f"{losses[0]:.4f} -> {losses[-1]:.4f}", flush=True)
        print("regret, uniform regret", regrets(model, states, everything), flush=True)
    else:
        held_out = np.random.default_rng(0).permutation(len(states))[: len(states) // 5]
        rows = np.setdiff1d(everything, held_out)
        fit_listwise(model, states, rows, args.epochs, *args.listwise)
        print(f"states {len(states)} fit {time.perf_counter() - start:.0f}s", flush=True)
        print("regret, uniform regret: fitted", regrets(model, states, rows), "held out",
              regrets(model, states, held_out), flush=True)
    print(json.dumps(policy_summary(evaluate_policy(model, evaluation_env(config),
                                                    validation_episodes(config)))))


if __name__ == "__main__":
    main()
