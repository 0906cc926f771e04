"""Seeds of a trial: pure functions of the run and the trial, never of where it runs.

Trial ``k`` of group ``(planner, n_agents)`` in a run with root ``seed`` on environment ``env``
has

* ``env_seed = H("env", seed, env, k)``: seeds ``env.reset`` (true target, initial vehicle
  states, observation noise, belief particles). It depends on neither the planner nor the fleet
  size, so every group of a run faces the same true target in trial ``k`` (the environments
  draw it from the first child stream of their seed, whatever the fleet size): common random
  numbers, so the paired comparisons of the studies have less variance;
* ``policy_seed = H("policy", seed, env, planner, n_agents, k)``: seeds the policy's own stream.

``H`` is the first 8 bytes (little-endian) of SHA-256 of the fields' ``str`` joined by ``"|"``,
masked to 63 bits (:func:`derive_seed`). Backend, worker count and completion order enter
nowhere, so a trial rerun anywhere (a retry after a worker died included) is the same trial.
"""

from __future__ import annotations

import hashlib

__all__ = ["derive_seed", "trial_seeds"]


def derive_seed(*fields: object) -> int:
    """A 63-bit seed that is a pure function of ``fields`` (SHA-256 of their ``"|"`` join)."""
    text = "|".join(str(f) for f in fields)
    digest = hashlib.sha256(text.encode()).digest()
    return int.from_bytes(digest[:8], "little") & ((1 << 63) - 1)


def trial_seeds(seed: int, env: str, planner: str, n_agents: int, trial: int) -> tuple[int, int]:
    """``(env_seed, policy_seed)`` of one trial (module docstring)."""
    env_seed = derive_seed("env", seed, env, trial)
    policy_seed = derive_seed("policy", seed, env, planner, n_agents, trial)
    return env_seed, policy_seed
