"""RLlib PPO (new API stack) on an infoseek team, with one policy shared by every agent.

The recipe:

1. ``ray.rllib.env.wrappers.pettingzoo_env.ParallelPettingZooEnv`` turns the PettingZoo parallel
   environment into an RLlib ``MultiAgentEnv``; ``ray.tune.registry.register_env`` registers a
   constructor under a name, which receives the ``env_config`` dict (here: the environment's
   keyword arguments).
2. ``PPOConfig().multi_agent(policies={"shared"}, policy_mapping_fn=...)`` maps every agent to
   the one module ``"shared"``: parameter sharing, possible because all agents have the same
   observation and action spaces.
3. Sampling and learning stay in this process (``num_env_runners=0``, no remote learners), and
   ``ray.init(num_cpus=..., include_dashboard=False)`` starts a small local Ray instance;
   ``ray.shutdown()`` always runs at the end.

**Set torch to one thread on small machines.** In this local setup the sampling and the PPO
updates run in the driver process, whose torch uses every core by default. On a loaded 2-core
machine the default run's iterations (1920 team steps = 3840 agent transitions, 4 epochs of
128-transition minibatches) took 7-12 s each after ``torch.set_num_threads(1)`` (depending on
the other load) and 52-96 s with torch's default of 2 threads (same returns): the small matrix
products of a PPO update gain nothing from a second thread on a busy machine and lose much to
contention. ``--torch-threads 0`` keeps torch's default for comparison; every iteration's
duration is printed. (Ray sets ``OMP_NUM_THREADS`` of its worker processes to their CPU count
when it is unset, which covers remote env runners if you add ``num_env_runners > 0``.)

RLlib counts ``train_batch_size_per_learner`` in team steps: with 2 agents a batch of 100 team
steps is 200 agent transitions. ``--smoke`` runs one iteration of 100 team steps (200
transitions); the default run is 10 iterations of 1920 team steps.

Run: ``python examples/rllib_ppo.py [--smoke] [--torch-threads N] [--env beacon_v0]``.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass
from typing import Any

import ray
import torch
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
from ray.tune.registry import register_env

import infoseek.envs


@dataclass(frozen=True)
class RLlibRun:
    """What the PPO iterations sampled and how long each took."""

    iterations: int
    env_steps: int
    """Team steps (``train_batch_size_per_learner`` counts these)."""
    agent_steps: int
    """Agent transitions: ``n_agents * env_steps``."""
    module_steps: dict[str, int]
    """Transitions per RL module: all of them went through ``"shared"``."""
    episode_return_mean: float
    iteration_seconds: list[float]
    torch_threads: int


def env_name(env_id: str) -> str:
    """Register ``env_id`` with RLlib (as the returned name) and return that name."""
    name = f"infoseek_{env_id}"

    def create(config: dict[str, Any]) -> ParallelPettingZooEnv:
        return ParallelPettingZooEnv(infoseek.envs.make(env_id, **dict(config)))

    register_env(name, create)
    return name


def ppo_config(
    env_id: str,
    env_kwargs: dict[str, Any],
    *,
    batch_size: int,
    minibatch_size: int,
    num_epochs: int,
    seed: int,
) -> PPOConfig:
    """A PPO config with one shared module, sampling and learning in this process."""
    return (
        PPOConfig()
        .environment(env_name(env_id), env_config=env_kwargs)
        .env_runners(num_env_runners=0)
        .multi_agent(
            policies={"shared"},
            policy_mapping_fn=lambda agent_id, episode, **kwargs: "shared",
        )
        .training(
            train_batch_size_per_learner=batch_size,
            minibatch_size=minibatch_size,
            num_epochs=num_epochs,
        )
        .debugging(seed=seed)
    )


def train(
    env_id: str = "bearings_v0",
    *,
    iterations: int = 10,
    batch_size: int = 1920,
    minibatch_size: int = 128,
    num_epochs: int = 4,
    n_agents: int = 2,
    n_particles: int = 200,
    max_cycles: int = 40,
    torch_threads: int = 1,
    num_cpus: int = 1,
    seed: int = 0,
) -> RLlibRun:
    """Run ``iterations`` PPO iterations of ``batch_size`` team steps each.

    RLlib counts the batch in environment (team) steps, so an iteration trains on
    ``n_agents * batch_size`` agent transitions.

    ``torch_threads`` is applied with ``torch.set_num_threads`` (0: leave torch's default).
    """
    if iterations < 1:
        raise ValueError(f"iterations must be >= 1, got {iterations}")
    if torch_threads > 0:
        torch.set_num_threads(torch_threads)
    env_kwargs = {"n_agents": n_agents, "n_particles": n_particles, "max_cycles": max_cycles}
    ray.init(num_cpus=num_cpus, include_dashboard=False)
    try:
        config = ppo_config(
            env_id,
            env_kwargs,
            batch_size=batch_size,
            minibatch_size=minibatch_size,
            num_epochs=num_epochs,
            seed=seed,
        )
        algorithm = config.build_algo()
        durations: list[float] = []
        result: dict[str, Any] = {}
        for _ in range(iterations):
            start = time.perf_counter()
            result = algorithm.train()
            durations.append(time.perf_counter() - start)
        algorithm.stop()
    finally:
        ray.shutdown()
    runners = result["env_runners"]
    return RLlibRun(
        iterations=len(durations),
        env_steps=int(runners["num_env_steps_sampled_lifetime"]),
        agent_steps=int(sum(runners["num_agent_steps_sampled_lifetime"].values())),
        module_steps={
            module: int(count)
            for module, count in runners["num_module_steps_sampled_lifetime"].items()
        },
        episode_return_mean=float(runners.get("episode_return_mean", math.nan)),
        iteration_seconds=durations,
        torch_threads=torch.get_num_threads(),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="one iteration of 200 transitions")
    parser.add_argument("--env", default="bearings_v0", choices=["bearings_v0", "beacon_v0"])
    parser.add_argument(
        "--torch-threads", type=int, default=1, help="torch threads (0: torch's default)"
    )
    parser.add_argument("--iterations", type=int, default=10, help="iterations of the full run")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.smoke:
        run = train(
            args.env,
            iterations=1,
            batch_size=100,
            minibatch_size=100,
            num_epochs=1,
            max_cycles=20,
            torch_threads=args.torch_threads,
            seed=args.seed,
        )
    else:
        run = train(
            args.env, iterations=args.iterations, torch_threads=args.torch_threads, seed=args.seed
        )
    for k, seconds in enumerate(run.iteration_seconds):
        print(f"iteration {k}: {seconds:.2f} s with {run.torch_threads} torch thread(s)")
    print(
        f"{run.iterations} iterations: {run.env_steps} env steps, {run.agent_steps} agent "
        f"steps ({run.module_steps}); mean team episode return {run.episode_return_mean:.3f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
