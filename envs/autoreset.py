"""Auto-resetting batches of search environments, in this process or in a worker process.

:class:`AutoResetBatch` steps a :class:`~infoseek.envs.core.SearchCore` and restarts every
environment whose episode ended, with the SB3 conventions documented in
:mod:`infoseek.baselines.vector` (terminal observation, ``TimeLimit.truncated``, episode records).
:class:`WorkerBatch` runs one in a worker process (``multiprocessing`` spawn context, so no
state is inherited) behind the same ``reset`` / ``step_async`` / ``step_wait`` calls;
:class:`~infoseek.baselines.vector.SearchVecEnv` splits its environments over several of them to
use several cores. Only numpy arrays and small dicts cross the pipe.
"""

from __future__ import annotations

import multiprocessing
import time
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs import heap
from infoseek.envs.core import SearchCore

__all__ = ["AutoResetBatch", "WorkerBatch", "build_core"]

StepOutput = tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.bool_], list[dict]]


def build_core(env_id: str, n_envs: int, kwargs: dict[str, Any]) -> SearchCore:
    """A core of ``n_envs`` environments of ``env_id`` with the environment keywords
    ``kwargs`` (validated exactly as the PettingZoo environment validates them)."""
    from infoseek.envs.registration import make

    env = make(env_id, **kwargs)
    config = env.unwrapped.config
    env.close()
    return SearchCore(config, n_envs)


class AutoResetBatch:
    """A core whose finished environments restart at once (SB3 slot conventions).

    Args:
        core: The batched core; environment ``b``'s agent ``i`` is slot ``b * A + i``.
    """

    def __init__(self, core: SearchCore) -> None:
        self.core = core
        self.n_agents = core.config.n_agents
        self.n_slots = core.n_envs * self.n_agents
        self._returns = np.zeros(self.n_slots)
        self._lengths = np.zeros(core.n_envs, dtype=np.int64)
        self._start = time.perf_counter()
        self._actions: Any = None

    def reset(self, seeds: list[int | None]) -> NDArray[np.float32]:
        """Reset every environment (one seed each); returns ``(slots, obs_dim)`` observations."""
        self.core.reset(list(range(self.core.n_envs)), seeds)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return self.core.observations().reshape(self.n_slots, -1)

    def step_async(self, actions: Any) -> None:
        """Store the slots' actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> StepOutput:
        """Step, record finished episodes, restart them; ``(obs, rewards, dones, infos)``."""
        core, a = self.core, self.n_agents
        controls = core.config.decode_actions(self._actions, core.n_envs, "actions")
        self._actions = None
        result = core.step(controls)
        rewards = result.rewards.reshape(-1)
        self._returns += rewards
        self._lengths += 1
        ended = result.terminated | result.truncated
        masses, entropies = core.masses.reshape(-1), core.entropies.reshape(-1)
        infos: list[dict[str, Any]] = [
            {
                "posterior_mass": float(masses[k]),
                "entropy": float(entropies[k]),
                "TimeLimit.truncated": False,
            }
            for k in range(self.n_slots)
        ]
        observations = result.observations.reshape(self.n_slots, -1)
        done_envs = np.flatnonzero(ended)
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
            core.reset(done_envs, [None] * done_envs.size)
            fresh = core.observations()
            for e in done_envs:
                observations[e * a : (e + 1) * a] = fresh[e]
        return observations, rewards.astype(np.float32), np.repeat(ended, a), infos

    def close(self) -> None:
        """Nothing to release."""


def _worker(connection: Connection, env_id: str, n_envs: int, kwargs: dict[str, Any]) -> None:
    heap.tune_from_environment()  # as its parent chose (infoseek.envs.heap)
    try:
        batch = AutoResetBatch(build_core(env_id, n_envs, kwargs))
        connection.send(("ready", None))
    except Exception as error:  # reported to the parent, which raises it
        connection.send(("error", error))
        return
    while True:
        command, payload = connection.recv()
        try:
            if command == "reset":
                connection.send(("ok", batch.reset(payload)))
            elif command == "step":
                batch.step_async(payload)
                connection.send(("ok", batch.step_wait()))
            else:  # "close"
                connection.send(("ok", None))
                return
        except Exception as error:
            connection.send(("error", error))


class WorkerBatch:
    """An :class:`AutoResetBatch` of ``n_envs`` environments in a worker process.

    Args:
        env_id: The environment id.
        n_envs: Environments in this worker.
        kwargs: Environment keywords.
    """

    def __init__(self, env_id: str, n_envs: int, kwargs: dict[str, Any]) -> None:
        context = multiprocessing.get_context("spawn")
        self._connection, child = context.Pipe()
        self._process = context.Process(
            target=_worker, args=(child, env_id, n_envs, kwargs), daemon=True
        )
        self._process.start()
        child.close()
        self._closed = False
        self._receive()

    def _receive(self) -> Any:
        try:
            status, payload = self._connection.recv()
        except EOFError:
            raise RuntimeError(
                f"worker process {self._process.pid} exited (exit code "
                f"{self._process.exitcode}); a script that starts workers must guard its "
                "entry point with `if __name__ == '__main__':` (spawn start method)"
            ) from None
        if status == "error":
            raise payload
        return payload

    def reset(self, seeds: list[int | None]) -> NDArray[np.float32]:
        """Reset the worker's environments."""
        self._connection.send(("reset", seeds))
        return self._receive()

    def step_async(self, actions: Any) -> None:
        """Send the worker its slots' actions (it starts stepping at once)."""
        self._connection.send(("step", np.asarray(actions)))

    def step_wait(self) -> StepOutput:
        """The worker's step output."""
        return self._receive()

    def close(self) -> None:
        """Stop the worker process."""
        if self._closed:
            return
        self._closed = True
        try:
            self._connection.send(("close", None))
            self._receive()
        except (BrokenPipeError, EOFError, OSError):
            pass
        self._process.join(timeout=5)
        if self._process.is_alive():
            self._process.terminate()
