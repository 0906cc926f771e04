"""Parameter-shared training environments for SB3: the batched vector env, or (worker processes)
PettingZoo parallel env -> SuperSuit -> SB3 VecEnv.

In one process :func:`make_training_vec_env` returns :func:`infoseek.envs.make_vec`, whose
batched core steps every copy at once (same transitions, same info conventions as below).
Either way every agent of every environment copy becomes one slot of a Stable-Baselines3
``VecEnv``, so one policy is trained on the transitions of all agents (parameter sharing). With
worker processes (``num_cpus >= 2``) the chain is::

    parallel env -> TrainingInfoFilter -> supersuit.pettingzoo_env_to_vec_env_v1  (A slots)
        -> supersuit.concat_vec_envs_v1(n_envs copies)             (n_envs * A slots)
        -> SeededSB3VecEnv                                          (the SB3 VecEnv)

**Why the info filter (SB3 training only).** The environment's ``infos[agent]`` carry the
``(A, state_dim)`` vehicle states (and, with ``belief_in_infos=True``, the belief view).
SuperSuit forwards infos unchanged, and with worker processes (``num_cpus >= 2``) it pickles
them through pipes every step, which is pure overhead for training (SB3 never reads them).
:class:`TrainingInfoFilter` keeps only the scalar entries (``"entropy"``,
``"posterior_mass"``, ``"ess"``, ...) and adds ``"TimeLimit.truncated"`` (true when the episode
ended by ``max_cycles`` rather than by localisation), which SB3 reads to bootstrap the value at
time-limit truncations (PPO) and to mark timeouts in the replay buffer (SAC/TD3), and, at the
end of an episode, ``"episode": {"r": return, "l": length, "t": 0.0}`` (the Monitor-style record
SB3 turns into ``rollout/ep_rew_mean`` and ``rollout/ep_len_mean``). Those two keys follow SB3's
conventions (present only at steps), so the filter is for this SB3 chain only; other frameworks
take the environment itself, whose infos already have fixed keys (see ``examples/``). Evaluation
and :func:`infoseek.baselines.load_policy` use the real, unfiltered environment.

**Seeding.** SuperSuit's SB3 adapter does not implement ``VecEnv.seed`` (the SuperSuit vector
env has no ``seed`` method), so :class:`SeededSB3VecEnv` stores the seed SB3 gives it and passes
it to the next ``reset``: copy ``k`` is reset with ``seed + k``; later automatic resets continue
each copy's own ``numpy.random.SeedSequence`` (the environment spawns fresh child streams per
episode), so a training run is reproducible from its seed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import supersuit
from pettingzoo.utils.env import ParallelEnv
from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

from infoseek.envs import make
from infoseek.envs.vector import SearchVecEnv, make_vec

__all__ = ["SeededSB3VecEnv", "TrainingInfoFilter", "make_training_vec_env", "scalar_infos"]


def scalar_infos(info: Mapping[str, Any]) -> dict[str, Any]:
    """The entries of one agent's info dict that are Python/NumPy scalars (bool, int, float)."""
    return {
        key: value
        for key, value in info.items()
        if isinstance(value, bool | int | float | np.bool_ | np.integer | np.floating)
    }


class TrainingInfoFilter(ParallelEnv):
    """Parallel-env wrapper for training: scalar infos only, plus ``"TimeLimit.truncated"``.

    Observations, rewards, terminations, truncations, spaces and agents are passed through
    unchanged; ``unwrapped`` is the wrapped environment's.

    Args:
        env: A PettingZoo parallel environment (an :class:`~infoseek.envs.InformationSeekingEnv`).
    """

    def __init__(self, env: ParallelEnv) -> None:
        self.env = env
        self.metadata = env.metadata
        self.possible_agents = list(env.possible_agents)
        self.render_mode = getattr(env, "render_mode", None)
        self._returns: dict[str, float] = dict.fromkeys(self.possible_agents, 0.0)
        self._length = 0

    @property
    def agents(self) -> list[str]:  # type: ignore[override]
        return self.env.agents

    @property
    def unwrapped(self) -> ParallelEnv:
        return self.env.unwrapped

    def observation_space(self, agent: str) -> Any:
        return self.env.observation_space(agent)

    def action_space(self, agent: str) -> Any:
        return self.env.action_space(agent)

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        observations, infos = self.env.reset(seed=seed, options=options)
        self._returns = dict.fromkeys(self.possible_agents, 0.0)
        self._length = 0
        return observations, {agent: scalar_infos(info) for agent, info in infos.items()}

    def step(self, actions: Mapping[str, Any]) -> tuple[Any, Any, Any, Any, Any]:
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        self._length += 1
        filtered = {}
        for agent, info in infos.items():
            entry = scalar_infos(info)
            self._returns[agent] += float(rewards.get(agent, 0.0))
            ended = bool(terminations.get(agent, False) or truncations.get(agent, False))
            entry["TimeLimit.truncated"] = bool(
                truncations.get(agent, False) and not terminations.get(agent, False)
            )
            if ended:
                entry["episode"] = {"r": self._returns[agent], "l": self._length, "t": 0.0}
            filtered[agent] = entry
        return observations, rewards, terminations, truncations, filtered

    def render(self) -> Any:
        return self.env.render()

    def close(self) -> None:
        self.env.close()


class SeededSB3VecEnv(SB3VecEnvWrapper):
    """SuperSuit's SB3 adapter with a working ``seed`` (applied at the next ``reset``)."""

    def __init__(self, venv: Any) -> None:
        super().__init__(venv)
        self._pending_seed: int | None = None

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._pending_seed = seed
        return [None if seed is None else seed + k for k in range(self.num_envs)]

    def reset(self, seed: int | None = None, options: Any = None) -> np.ndarray:
        if seed is None:
            seed, self._pending_seed = self._pending_seed, None
        observations, self.reset_infos = self.venv.reset(seed=seed)
        return observations


def make_training_vec_env(
    env_id: str,
    env_kwargs: Mapping[str, Any] | None = None,
    *,
    n_envs: int = 1,
    num_cpus: int = 0,
) -> SearchVecEnv | SeededSB3VecEnv:
    """The SB3 ``VecEnv`` of ``n_envs`` copies of ``env_id``, one slot per agent per copy.

    In one process (``num_cpus <= 1``) it is :func:`infoseek.envs.make_vec` (the batched
    core); with ``num_cpus >= 2`` worker processes, the SuperSuit chain above.

    Args:
        env_id: Registered environment id (``"bearings_v0"``, ...).
        env_kwargs: Environment keywords (``n_agents``, ``action_type``, ...).
        n_envs: Number of environment copies (>= 1); the VecEnv has ``n_envs * n_agents`` slots.
        num_cpus: Worker processes for the copies (0 or 1: in this process).

    Returns:
        The vectorised environment (seed it with ``.seed(s)`` or let SB3 do it).

    Raises:
        ValueError: ``n_envs < 1`` or ``num_cpus < 0``.
    """
    if int(n_envs) < 1:
        raise ValueError(f"n_envs must be >= 1, got {n_envs}")
    if int(num_cpus) < 0:
        raise ValueError(f"num_cpus must be >= 0, got {num_cpus}")
    if int(num_cpus) <= 1:
        # one process: the batched core steps every copy at once
        return make_vec(env_id, num_envs=int(n_envs), **dict(env_kwargs or {}))
    env = TrainingInfoFilter(make(env_id, **dict(env_kwargs or {})))
    markov = supersuit.pettingzoo_env_to_vec_env_v1(env)
    venv = supersuit.concat_vec_envs_v1(markov, int(n_envs), num_cpus=int(num_cpus))
    return SeededSB3VecEnv(venv)
