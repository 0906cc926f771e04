"""An infoseek environment as a TorchRL environment: specs, a random rollout, the global state.

The recipe:

1. Build the PettingZoo parallel environment with ``infoseek.envs.make`` and pass it directly to
   ``torchrl.envs.libs.pettingzoo.PettingZooWrapper``; it needs no ``parallel=`` keyword (it
   sees that the environment is a ``ParallelEnv``). All agents ``vehicle_0``,
   ``vehicle_1``, ... form the one group ``"vehicle"``, so every per-agent entry has a leading
   agent dimension: ``("vehicle", "observation")`` is ``(n_agents, obs_dim)``, and each info
   entry ``("vehicle", "info", key)`` is ``(n_agents, *shape of the info value)``.
2. ``torchrl.envs.utils.check_env_specs`` runs a short rollout and compares it with the specs.
3. ``env.rollout(n)`` with random actions returns a TensorDict of batch size ``[n]``.

**The centralised state is opt-in.** The wrapper does not add ``env.state()`` by itself, even
though the environment has ``state()`` and ``state_space``: it must be built with
``return_state=True``. Then the spec gains a root entry ``"state"`` (a bounded spec made from
``env.state_space``) and every reset and step output carries it, shape
``env.state_space.shape``; this is what BenchMARL's MAPPO critic reads
(:mod:`infoseek.baselines.benchmarl_task`).

**Discrete actions.** With ``action_type="discrete"`` the environment's actions are
``Discrete(n)``; ``categorical_actions=True`` (the wrapper's default) keeps them as integer
indices, shape ``(n_agents,)``, while ``False`` would give one-hot vectors.

The AEC form (``infoseek.envs.make(env_id, parallel=False)``) also works, with
``use_mask=True``, which TorchRL requires for AEC environments.

Run: ``python examples/torchrl_check.py [--smoke] [--env beacon_v0]``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np
import torch
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.envs.utils import check_env_specs

import infoseek.envs

GROUP = "vehicle"


@dataclass(frozen=True)
class TorchRLCheck:
    """Shapes seen in a checked random rollout, next to the environment's own spaces."""

    action_type: str
    steps: int
    observation_shape: tuple[int, ...]
    env_observation_shape: tuple[int, ...]
    state_shape: tuple[int, ...]
    env_state_shape: tuple[int, ...]
    state_matches_env: bool
    info_shapes: dict[str, tuple[int, ...]]
    env_info_shapes: dict[str, tuple[int, ...]]
    action_shape: tuple[int, ...]
    total_reward: float


def wrap(env: object, *, seed: int = 0) -> PettingZooWrapper:
    """The TorchRL form of a PettingZoo parallel environment, with the centralised state."""
    return PettingZooWrapper(env, return_state=True, categorical_actions=True, seed=seed)


def check(
    env_id: str = "bearings_v0",
    *,
    action_type: str = "continuous",
    steps: int = 10,
    n_agents: int = 2,
    n_particles: int = 200,
    max_cycles: int = 20,
    seed: int = 0,
) -> TorchRLCheck:
    """Check the specs of the wrapped environment and roll out ``steps`` random steps."""
    kwargs = {"n_agents": n_agents, "n_particles": n_particles, "max_cycles": max_cycles}
    base = infoseek.envs.make(env_id, action_type=action_type, **kwargs)
    env = wrap(base, seed=seed)
    torch.manual_seed(seed)  # the random actions come from torch's global generator
    check_env_specs(env)
    rollout = env.rollout(steps)
    # The rollout stops without resetting, so the last "state" is the environment's state().
    last_state = torch.as_tensor(base.state())
    state_matches = bool(torch.equal(rollout["next", "state"][-1], last_state))
    # A fresh copy gives the per-agent reference shapes of the infos.
    agent = base.possible_agents[0]
    _, infos = infoseek.envs.make(env_id, action_type=action_type, **kwargs).reset(seed=seed)
    info_rollout = rollout["next", GROUP, "info"]
    return TorchRLCheck(
        action_type=action_type,
        steps=int(rollout.batch_size[0]),
        observation_shape=tuple(rollout["next", GROUP, "observation"].shape),
        env_observation_shape=tuple(base.observation_space(agent).shape),
        state_shape=tuple(rollout["next", "state"].shape),
        env_state_shape=tuple(base.state_space.shape),
        state_matches_env=state_matches,
        info_shapes={key: tuple(info_rollout[key].shape) for key in info_rollout.keys()},
        env_info_shapes={key: tuple(np.shape(value)) for key, value in infos[agent].items()},
        action_shape=tuple(rollout[GROUP, "action"].shape),
        total_reward=float(rollout["next", GROUP, "reward"].sum()),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="a 5-step rollout per action type")
    parser.add_argument("--env", default="bearings_v0", choices=["bearings_v0", "beacon_v0"])
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    steps = 5 if args.smoke else 60
    max_cycles = 20 if args.smoke else 60
    for action_type in ("continuous", "discrete"):
        result = check(args.env, action_type=action_type, steps=steps, max_cycles=max_cycles)
        print(f"{args.env}, {action_type} actions: check_env_specs passed")
        print(
            f"  rollout of {result.steps} steps: observation {result.observation_shape} "
            f"(env: {result.env_observation_shape} per agent), state {result.state_shape} "
            f"(env.state_space: {result.env_state_shape}; last one equals env.state(): "
            f"{result.state_matches_env}), action {result.action_shape}, "
            f"team reward {result.total_reward:.3f}"
        )
        for key, shape in result.info_shapes.items():
            print(f"  info {key}: {shape} (env: {result.env_info_shapes[key]} per agent)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
