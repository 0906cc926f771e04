"""Collect episodes of an infoseek environment with Tianshou's multi-agent machinery.

The recipe:

1. Tianshou's ``tianshou.env.PettingZooEnv`` wraps an *AEC* environment
   (``infoseek.envs.make(env_id, parallel=False, ...)``, or ``infoseek.envs.bearings_v0.env()``):
   agents act one at a time in index order, so one Tianshou step is one agent's turn and an
   episode of ``max_cycles`` cycles has ``n_agents * max_cycles`` steps. Each observation is a
   dict with ``agent_id``, ``obs`` and, for discrete actions, the action ``mask``; the reward is
   the vector of every agent's reward.
2. ``MultiAgentOffPolicyAlgorithm`` holds one algorithm per agent and routes each turn to the
   agent whose turn it is. Here every agent plays ``MARLRandomDiscreteMaskedOffPolicyAlgorithm``
   (uniformly random among the allowed actions), so the environment uses
   ``action_type="discrete"``; a trained per-agent algorithm drops in at the same place.
3. ``DummyVectorEnv`` runs several copies in this process and ``Collector.collect(n_episode=k)``
   gathers exactly ``k`` finished episodes; its statistics hold each episode's length and
   return (one return per agent).

Building the multi-agent algorithm and the collector's buffer JIT-compiles Tianshou's numba
helpers once per process: about 10 s on two loaded cores, which dominates a smoke run.

``--smoke`` collects 2 episodes of 10 cycles over 2 copies; the default collects 8 episodes of
the default 60 cycles over 4 copies.

Run: ``python examples/tianshou_collect.py [--smoke] [--env beacon_v0]``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from tianshou.algorithm import MARLRandomDiscreteMaskedOffPolicyAlgorithm
from tianshou.algorithm.multiagent.marl import MultiAgentOffPolicyAlgorithm
from tianshou.data import Collector, CollectStats
from tianshou.env import DummyVectorEnv, PettingZooEnv

import infoseek.envs


@dataclass(frozen=True)
class Collection:
    """What the collector gathered."""

    n_episodes: int
    n_steps: int
    episode_lengths: list[int]
    returns: np.ndarray
    """Shape ``(n_episodes, n_agents)``: each agent's return in each episode."""


def env_factory(env_id: str, **kwargs: object) -> Callable[[], PettingZooEnv]:
    """A constructor of the Tianshou form of ``env_id`` (AEC, discrete actions)."""

    def make() -> PettingZooEnv:
        aec = infoseek.envs.make(env_id, parallel=False, action_type="discrete", **kwargs)
        return PettingZooEnv(aec)

    return make


def collect(
    env_id: str = "bearings_v0",
    *,
    n_episodes: int = 8,
    n_envs: int = 4,
    n_agents: int = 2,
    n_particles: int = 200,
    max_cycles: int = 60,
    seed: int = 0,
) -> Collection:
    """Collect ``n_episodes`` episodes of random play over ``n_envs`` environment copies."""
    make = env_factory(env_id, n_agents=n_agents, n_particles=n_particles, max_cycles=max_cycles)
    env = make()
    algorithm = MultiAgentOffPolicyAlgorithm(
        algorithms=[
            MARLRandomDiscreteMaskedOffPolicyAlgorithm(env.action_space) for _ in env.agents
        ],
        env=env,
    )
    venv = DummyVectorEnv([make for _ in range(n_envs)])
    venv.seed([seed + k for k in range(n_envs)])
    np.random.seed(seed)  # noqa: NPY002 (the random policies draw from the global generator)
    collector: Collector[CollectStats] = Collector(algorithm, venv)
    collector.reset()
    stats = collector.collect(n_episode=n_episodes)
    venv.close()
    return Collection(
        n_episodes=int(stats.n_collected_episodes),
        n_steps=int(stats.n_collected_steps),
        episode_lengths=[int(length) for length in stats.lens],
        returns=np.asarray(stats.returns, dtype=float).reshape(len(stats.lens), -1),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="2 episodes of 10 cycles")
    parser.add_argument("--env", default="bearings_v0", choices=["bearings_v0", "beacon_v0"])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    if args.smoke:
        result = collect(args.env, n_episodes=2, n_envs=2, max_cycles=10, seed=args.seed)
    else:
        result = collect(args.env, seed=args.seed)
    print(
        f"{args.env}: {result.n_episodes} episodes, {result.n_steps} agent turns, "
        f"lengths {result.episode_lengths}"
    )
    for k, returns in enumerate(result.returns):
        per_agent = ", ".join(f"{value:.3f}" for value in returns)
        print(f"  episode {k}: returns per agent [{per_agent}], team {returns.sum():.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
