"""The parameter-shared training environment of the RL baselines.

:func:`make_training_vec_env` is :func:`infoseek.baselines.make_vec`: ``n_envs`` batched copies of
the environment, every agent of every copy one slot of a Stable-Baselines3 ``VecEnv``, so one
policy is trained on the transitions of all agents (parameter sharing). Its infos hold only
scalars plus SB3's ``"TimeLimit.truncated"`` (SB3 bootstraps the value at time-limit
truncations) and, at the end of an episode, the Monitor-style ``"episode"`` record SB3 logs as
``rollout/ep_rew_mean`` (conventions: :mod:`infoseek.baselines.vector`). ``num_cpus >= 2`` splits
the copies over that many worker processes. Seeding: ``seed(s)`` (what SB3 calls) seeds copy
``k`` with ``s + k`` at the next reset; later automatic resets continue each copy's own seed
sequence, so a training run is reproducible from its seed. Evaluation and
:func:`infoseek.baselines.load_policy` use the PettingZoo environment.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from infoseek.baselines.vector import SearchVecEnv, make_vec

__all__ = ["make_training_vec_env"]


def make_training_vec_env(
    env_id: str,
    env_kwargs: Mapping[str, Any] | None = None,
    *,
    n_envs: int = 1,
    num_cpus: int = 0,
) -> SearchVecEnv:
    """The SB3 ``VecEnv`` of ``n_envs`` copies of ``env_id``, one slot per agent per copy.

    Args:
        env_id: Registered environment id (``"bearings_v0"``, ...).
        env_kwargs: Environment keywords (``n_agents``, ``action_type``, ...).
        n_envs: Number of environment copies (>= 1); the VecEnv has ``n_envs * n_agents`` slots.
        num_cpus: Worker processes for the copies (0 or 1: in this process; at most
            ``n_envs`` are used).

    Returns:
        The vectorised environment (seed it with ``.seed(s)`` or let SB3 do it).

    Raises:
        ValueError: ``n_envs < 1`` or ``num_cpus < 0``.
    """
    if isinstance(n_envs, bool) or not isinstance(n_envs, int) or n_envs < 1:
        raise ValueError(f"n_envs must be an integer >= 1, got {n_envs!r}")
    if isinstance(num_cpus, bool) or not isinstance(num_cpus, int) or num_cpus < 0:
        raise ValueError(f"num_cpus must be an integer >= 0, got {num_cpus!r}")
    workers = max(1, min(num_cpus, n_envs))
    return make_vec(env_id, num_envs=n_envs, n_workers=workers, **dict(env_kwargs or {}))
