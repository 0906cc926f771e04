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

``n_workers > 1`` splits the ``B`` environments over that many worker processes (one core
each; :mod:`infoseek.envs.autoreset`): the same slots, seeds and numbers, stepped in parallel.

The adapter lives with the RL baselines because it is Stable-Baselines3's interface: the
batched simulator it wraps (:class:`~infoseek.envs.core.SearchCore`,
:mod:`infoseek.envs.autoreset`) needs no RL library, so ``import infoseek.envs`` imports none.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvStepReturn

from infoseek.envs.autoreset import AutoResetBatch, WorkerBatch, build_core
from infoseek.envs.config import SearchConfig
from infoseek.envs.core import check_seed

__all__ = ["SearchVecEnv", "make_vec"]


class SearchVecEnv(VecEnv):
    """``B`` batched search environments as an SB3 ``VecEnv`` of ``B * A`` agent slots.

    Args:
        config: The environments' settings (spaces, agent count).
        batches: The auto-resetting batches holding the environments, in slot order (one in
            this process, or one per worker process).
        env_counts: Environments in each batch.
        env_id: The environment id (reported by :meth:`get_attr` as ``"env_id"``).
    """

    def __init__(
        self,
        config: SearchConfig,
        batches: Sequence[AutoResetBatch | WorkerBatch],
        env_counts: Sequence[int],
        env_id: str = "",
    ) -> None:
        self.config = config
        self.env_id = env_id
        self.n_agents = config.n_agents
        self._batches = list(batches)
        self._env_counts = [int(c) for c in env_counts]
        self._offsets = np.concatenate([[0], np.cumsum(self._env_counts)]).astype(int)
        super().__init__(
            int(self._offsets[-1]) * self.n_agents, config.observation_space, config.action_space
        )
        self._base_seed: int | None = None
        self._pending = False

    @property
    def n_envs(self) -> int:
        """Number of batched environments ``B`` (``num_envs`` counts agent slots)."""
        return int(self._offsets[-1])

    @property
    def core(self) -> Any:
        """The :class:`~infoseek.envs.core.SearchCore` (in-process batches only)."""
        if len(self._batches) != 1 or not isinstance(self._batches[0], AutoResetBatch):
            raise AttributeError("core: the environments live in worker processes")
        return self._batches[0].core

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the next :meth:`reset`: environment ``b`` gets ``seed + b``."""
        check_seed(seed)
        self._base_seed = seed
        return [None if seed is None else seed + k // self.n_agents for k in range(self.num_envs)]

    def reset(self) -> NDArray[np.float32]:
        """Reset every environment; returns ``(B * A, obs_dim)`` observations."""
        seed, self._base_seed = self._base_seed, None
        parts = []
        for batch, start, count in zip(
            self._batches, self._offsets, self._env_counts, strict=False
        ):
            seeds = [None if seed is None else seed + start + e for e in range(count)]
            parts.append(batch.reset(seeds))
        return np.concatenate(parts)

    def step_async(self, actions: NDArray[Any]) -> None:
        """Hand every batch its slots' actions (``(B * A,)`` discrete or
        ``(B * A, control_dim)``); worker processes start stepping at once."""
        array = np.asarray(actions)
        if array.ndim == 0 or array.shape[0] != self.num_envs:
            # the full shape check, with the expected shape in the message
            self.config.decode_actions(array, self.n_envs, "actions")
        a = self.n_agents
        for batch, start, count in zip(
            self._batches, self._offsets, self._env_counts, strict=False
        ):
            batch.step_async(array[start * a : (start + count) * a])
        self._pending = True

    def step_wait(self) -> VecEnvStepReturn:
        """Step every environment, auto-reset the finished ones (module docstring)."""
        if not self._pending:
            raise RuntimeError("step_wait() without step_async(actions)")
        self._pending = False
        outputs = [batch.step_wait() for batch in self._batches]
        observations = np.concatenate([o[0] for o in outputs])
        rewards = np.concatenate([o[1] for o in outputs])
        dones = np.concatenate([o[2] for o in outputs])
        infos = [info for o in outputs for info in o[3]]
        return observations, rewards, dones, infos

    def close(self) -> None:
        """Stop the worker processes (nothing to release in process)."""
        for batch in self._batches:
            batch.close()

    def _slots(self, indices: None | int | Iterable[int]) -> list[int]:
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices: None | int | Iterable[int] = None) -> list[Any]:
        """A setting of the environment (``SearchConfig`` attribute) once per slot."""
        if attr_name == "render_mode":
            return [None for _ in self._slots(indices)]
        value = self.env_id if attr_name == "env_id" else getattr(self.config, attr_name)
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


def make_vec(env_id: str, num_envs: int = 1, n_workers: int = 1, **kwargs: Any) -> SearchVecEnv:
    """The SB3 ``VecEnv`` of ``num_envs`` batched copies of ``env_id``, one slot per agent.

    Args:
        env_id: A registered environment id (``"bearings_v0"``, ``"beacon_v0"``, ...).
        num_envs: Number of environments ``B >= 1``; the ``VecEnv`` has ``B * n_agents`` slots.
        n_workers: Worker processes sharing the environments (``1``: this process; at most
            ``num_envs``).
        **kwargs: Environment keywords (those of the PettingZoo environment).

    Raises:
        ValueError: ``num_envs < 1``, ``n_workers`` not in ``[1, num_envs]``, an unknown
            ``env_id`` or a bad environment keyword.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
        raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    if (
        isinstance(n_workers, bool)
        or not isinstance(n_workers, int | np.integer)
        or not 1 <= n_workers <= num_envs
    ):
        raise ValueError(
            f"n_workers must be an integer in [1, num_envs={num_envs}], got {n_workers!r}"
        )
    core = build_core(env_id, 1 if n_workers > 1 else int(num_envs), kwargs)
    if n_workers == 1:
        return SearchVecEnv(core.config, [AutoResetBatch(core)], [int(num_envs)], env_id)
    counts = [len(part) for part in np.array_split(np.arange(num_envs), n_workers)]
    workers: list[WorkerBatch] = []
    try:
        for count in counts:
            workers.append(WorkerBatch(env_id, count, dict(kwargs)))
    except BaseException:
        for worker in workers:
            worker.close()
        raise
    return SearchVecEnv(core.config, workers, counts, env_id)
