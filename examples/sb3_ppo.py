"""Stable-Baselines3 PPO on infoseek: a team with one shared policy, and a single vehicle.

**Team, parameter sharing.** ``infoseek.baselines.make_training_vec_env(env_id, env_kwargs,
n_envs=k)`` turns ``k`` copies of the parallel environment into one SB3 ``VecEnv`` with one slot
per agent per copy (``k * n_agents`` slots), so a single PPO model learns from every agent's
transitions. It is ``infoseek.baselines.make_vec``: the copies are rows of one batched simulator
(no per-copy environment objects), with SB3's conventions (a working ``seed``, auto-reset,
``"TimeLimit.truncated"`` and ``"episode"`` records, infos of numbers only). The
trained model acts for every agent through ``infoseek.baselines.TrainedPolicy`` and is scored
on seeded episodes of the real environment by ``infoseek.baselines.evaluate_policy``.

**Single vehicle.** ``import infoseek.envs`` registers ``infoseek/Bearings-v0`` and
``infoseek/Beacon-v0`` with Gymnasium: one vehicle as an ordinary ``gymnasium.Env``, which SB3
trains like any other.

``main`` sets torch to one thread: SB3's small networks gain nothing from more on a busy
machine (on two loaded cores the smoke run's team training took 2.6 s with one thread and 7.5 s
with torch's default two; ``examples/rllib_ppo.py`` has the larger measurement). One timestep
is one agent transition. ``--smoke`` trains each form for 256 timesteps; the
default run trains the team for 20,480 and the single vehicle for 10,240 timesteps (about 40 s
on two loaded cores). The complete training pipeline (observation features, evaluation curve,
checkpoints, resuming) is ``infoseek.baselines.train`` / ``infoseek train``.

Run: ``python examples/sb3_ppo.py [--smoke] [--env beacon_v0]``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import gymnasium
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.evaluation import evaluate_policy as sb3_evaluate_policy

import infoseek.envs
from infoseek.baselines import TrainedPolicy, evaluate_policy, make_training_vec_env
from infoseek.baselines.evaluation import evaluation_seeds
from infoseek.envs.single_agent import GYMNASIUM_IDS

GYMNASIUM_ID = {env_id: gym_id for gym_id, env_id in GYMNASIUM_IDS.items()}
"""infoseek environment id -> its single-vehicle Gymnasium id."""


@dataclass(frozen=True)
class PPORun:
    """What one PPO run trained and how the result scored."""

    form: str
    timesteps: int
    n_slots: int
    mean_return: float
    returns: list[float]
    seconds: float


def train_shared(
    env_id: str = "bearings_v0",
    *,
    timesteps: int = 20_480,
    n_agents: int = 2,
    n_envs: int = 4,
    n_steps: int = 256,
    n_particles: int = 200,
    max_cycles: int = 40,
    eval_episodes: int = 5,
    seed: int = 0,
) -> PPORun:
    """Train one PPO policy shared by all agents, then evaluate it on seeded team episodes."""
    env_kwargs = {"n_agents": n_agents, "n_particles": n_particles, "max_cycles": max_cycles}
    venv = make_training_vec_env(env_id, env_kwargs, n_envs=n_envs)
    start = time.perf_counter()
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=n_steps,
        batch_size=min(64, n_steps * venv.num_envs),
        n_epochs=4,
        seed=seed,
        device="cpu",
    )
    model.learn(total_timesteps=timesteps)
    seconds = time.perf_counter() - start
    venv.close()
    env = infoseek.envs.make(env_id, **env_kwargs)
    scores = evaluate_policy(TrainedPolicy(model), env, evaluation_seeds(eval_episodes))
    return PPORun(
        form="shared",
        timesteps=int(model.num_timesteps),
        n_slots=int(model.n_envs),
        mean_return=float(np.mean(scores.episode_return)),
        returns=[float(value) for value in scores.episode_return],
        seconds=seconds,
    )


def train_single(
    env_id: str = "bearings_v0",
    *,
    timesteps: int = 10_240,
    n_steps: int = 512,
    n_particles: int = 200,
    max_cycles: int = 40,
    eval_episodes: int = 5,
    seed: int = 0,
) -> PPORun:
    """Train PPO on the single-vehicle Gymnasium form, then evaluate it with SB3's evaluator."""
    env = gymnasium.make(GYMNASIUM_ID[env_id], n_particles=n_particles, max_cycles=max_cycles)
    start = time.perf_counter()
    model = PPO(
        "MlpPolicy",
        env,
        n_steps=n_steps,
        batch_size=min(64, n_steps),
        n_epochs=4,
        seed=seed,
        device="cpu",
    )
    model.learn(total_timesteps=timesteps)
    seconds = time.perf_counter() - start
    vec_env = model.get_env()  # SB3 wrapped the env in a Monitor and a DummyVecEnv
    assert vec_env is not None
    episode_returns, _ = sb3_evaluate_policy(
        model, vec_env, n_eval_episodes=eval_episodes, return_episode_rewards=True
    )
    returns = np.atleast_1d(np.asarray(episode_returns, dtype=float))
    env.close()
    return PPORun(
        form="single",
        timesteps=int(model.num_timesteps),
        n_slots=int(model.n_envs),
        mean_return=float(np.mean(returns)),
        returns=[float(value) for value in returns],
        seconds=seconds,
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="256 timesteps per form")
    parser.add_argument("--env", default="bearings_v0", choices=sorted(GYMNASIUM_ID))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    if args.smoke:
        runs = [
            train_shared(
                args.env, timesteps=256, n_envs=2, n_steps=32, max_cycles=20, eval_episodes=1
            ),
            train_single(args.env, timesteps=256, n_steps=128, max_cycles=20, eval_episodes=1),
        ]
    else:
        runs = [train_shared(args.env, seed=args.seed), train_single(args.env, seed=args.seed)]
    for run in runs:
        print(
            f"{run.form}: {run.timesteps} timesteps over {run.n_slots} VecEnv slots in "
            f"{run.seconds:.1f} s; evaluation returns {[round(r, 3) for r in run.returns]} "
            f"(mean {run.mean_return:.3f})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
