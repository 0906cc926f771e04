"""A Stable-Baselines3 ``VecEnv`` over a batched :class:`~infoseek.envs.core.SearchCore`.

``make_vec(env_id, num_envs=B, **kwargs)`` steps ``B`` environments of ``env_id`` at once and
exposes every agent of every environment as one slot, ``B * A`` slots in all (environment
``b``'s agent ``i`` is slot ``b * A + i``), so one policy is trained on the transitions of all
agents (parameter sharing). Observations, actions and rewards are those of the PettingZoo
environment (same layout, same spaces); with the same seed and actions, environment ``b``
follows the trajectory of ``make(env_id).reset(seed=seed + b)`` bit for bit.

SB3 conventions:

* ``step`` returns ``(obs (B*A, obs_dim) float32, rewards (B*A,) float32, dones (B*A,) bool,
  infos)``; an environment whose episode ended (every agent localised with
  ``terminate_on_localization``, or ``max_cycles`` reached) is reset at once (auto-reset):
  its slots' ``obs`` are the new episode's first observations, and each of its slots' info
  holds ``"terminal_observation"`` (the last observation of the ended episode),
  ``"TimeLimit.truncated"`` (ended by ``max_cycles`` rather than by localisation; SB3 then
  bootstraps the value) and ``"episode": {"r", "l", "t"}`` (the slot's return and length, the
  Monitor record SB3 logs as ``rollout/ep_rew_mean``).
* every slot's info also holds the agent's ``"posterior_mass"`` and ``"entropy"``, and
  ``"TimeLimit.truncated"`` (``False`` except at the end of a truncated episode).
* ``seed(s)`` (what SB3 calls) makes the next ``reset`` seed environment ``b`` with ``s + b``;
  later automatic resets continue each environment's own seed sequence, so a run is
  reproducible from its seed.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvStepReturn

from infoseek.envs.core import SearchCore

__all__ = ["SearchVecEnv", "make_vec"]


class SearchVecEnv(VecEnv):
    """``B`` batched search environments as an SB3 ``VecEnv`` of ``B * A`` agent slots.

    Args:
        core: The batched core (its config gives the spaces).
        env_id: The environment id (reported by :meth:`get_attr` as ``"env_id"``).
    """

    def __init__(self, core: SearchCore, env_id: str = "") -> None:
        self.core = core
        self.env_id = env_id
        self.n_agents = core.config.n_agents
        super().__init__(
            core.n_envs * self.n_agents,
            core.config.observation_space,
            core.config.action_space,
        )
        self._base_seed: int | None = None
        self._actions: NDArray[Any] | None = None
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(core.n_envs, dtype=np.int64)
        self._start = time.perf_counter()

    @property
    def n_envs(self) -> int:
        """Number of batched environments ``B`` (``num_envs`` counts agent slots)."""
        return self.core.n_envs

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the next :meth:`reset`: environment ``b`` gets ``seed + b``."""
        self._base_seed = seed
        return [None if seed is None else seed + k // self.n_agents for k in range(self.num_envs)]

    def reset(self) -> NDArray[np.float32]:
        """Reset every environment; returns ``(B * A, obs_dim)`` observations."""
        seed, self._base_seed = self._base_seed, None
        b = self.core.n_envs
        self.core.reset(list(range(b)), [None if seed is None else seed + e for e in range(b)])
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return self.core.observations().reshape(self.num_envs, -1)

    def step_async(self, actions: NDArray[Any]) -> None:
        """Store one action per slot (``(B * A,)`` discrete or ``(B * A, control_dim)``)."""
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        """Step every environment, auto-reset the finished ones (module docstring)."""
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async(actions)")
        controls = self.core.config.decode_actions(self._actions, self.core.n_envs, "actions")
        self._actions = None
        result = self.core.step(controls)
        a = self.n_agents
        rewards = result.rewards.reshape(-1)
        self._returns += rewards
        self._lengths += 1
        done_envs = np.flatnonzero(result.terminated | result.truncated)
        masses = self.core.masses.reshape(-1)
        entropies = self.core.entropies.reshape(-1)
        infos: list[dict[str, Any]] = [
            {
                "posterior_mass": float(masses[k]),
                "entropy": float(entropies[k]),
                "TimeLimit.truncated": False,
            }
            for k in range(self.num_envs)
        ]
        observations = result.observations.reshape(self.num_envs, -1)
        elapsed = round(time.perf_counter() - self._start, 6)
        for e in done_envs:
            for k in range(e * a, (e + 1) * a):
                infos[k]["terminal_observation"] = observations[k].copy()
                infos[k]["TimeLimit.truncated"] = bool(result.truncated[e])
                infos[k]["episode"] = {
                    "r": float(self._returns[k]),
                    "l": int(self._lengths[e]),
                    "t": elapsed,
                }
            self._returns[e * a : (e + 1) * a] = 0.0
            self._lengths[e] = 0
        if done_envs.size:
            self.core.reset(done_envs, [None] * done_envs.size)
            fresh = self.core.observations()
            for e in done_envs:
                observations[e * a : (e + 1) * a] = fresh[e]
        dones = np.repeat(result.terminated | result.truncated, a)
        return observations, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        """Nothing to release (the core holds arrays only)."""

    def _slots(self, indices: None | int | Iterable[int]) -> list[int]:
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices: None | int | Iterable[int] = None) -> list[Any]:
        """A setting of the environment (``SearchConfig`` attribute) once per slot."""
        source = self if attr_name in ("env_id", "render_mode") else self.core.config
        if attr_name == "render_mode":
            return [None for _ in self._slots(indices)]
        value = getattr(source, attr_name)
        return [value for _ in self._slots(indices)]

    def set_attr(
        self, attr_name: str, value: Any, indices: None | int | Iterable[int] = None
    ) -> None:
        """Settings are fixed for the batch: always raises."""
        raise AttributeError(
            f"set_attr({attr_name!r}): the environments of a SearchVecEnv share one fixed "
            "configuration; build a new one with make_vec(..., **kwargs)"
        )

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: None | int | Iterable[int] = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        """Not supported: the environments are rows of one array core."""
        raise AttributeError(
            f"env_method({method_name!r}): a SearchVecEnv has no per-slot environment objects"
        )

    def env_is_wrapped(
        self, wrapper_class: type, indices: None | int | Iterable[int] = None
    ) -> list[bool]:
        """No slot is wrapped (there are no per-slot Gymnasium environments)."""
        return [False for _ in self._slots(indices)]


def make_vec(env_id: str, num_envs: int = 1, **kwargs: Any) -> SearchVecEnv:
    """The SB3 ``VecEnv`` of ``num_envs`` batched copies of ``env_id``, one slot per agent.

    Args:
        env_id: A registered environment id (``"bearings_v0"``, ``"beacon_v0"``, ...).
        num_envs: Number of environments ``B >= 1``; the ``VecEnv`` has ``B * n_agents`` slots.
        **kwargs: Environment keywords (those of the PettingZoo environment).

    Raises:
        ValueError: ``num_envs < 1``, an unknown ``env_id`` or a bad environment keyword.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
        raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    from infoseek.envs.registration import make

    env = make(env_id, **kwargs)
    config = env.unwrapped.config
    env.close()
    return SearchVecEnv(SearchCore(config, int(num_envs)), env_id)
