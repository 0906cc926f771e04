"""Seeded evaluation episodes of any policy on the real (unfiltered) parallel environment.

For each seed ``s`` one episode is run with ``env.reset(seed=s)`` and ``policy.act`` until the
episode ends. Per episode and agent ``i`` the quantities are

* entropy reduction ``H_i(0) - H_i(T)`` (nats; ``infos[agent]["entropy"]`` after ``reset`` and
  after the last step; the training reward summed without the separation penalty),
* final posterior mass ``m_i(T)`` = ``infos[agent]["posterior_mass"]`` after the last step (mass
  of the agent's belief within ``localization_radius`` of its own MMSE estimate, the metric of
  the paper's Fig. 1),
* mean posterior mass ``(1/T) sum_{t=1..T} m_i(t)`` (area under the Fig. 1 curve, rewards fast
  localisation),
* return ``sum_t r_i(t)``,

and :class:`EvaluationResult` reports their means over agents and episodes. A deterministic
policy on seeded episodes gives identical results on every call (the environment draws all its
randomness from ``reset(seed)``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["EvaluationResult", "evaluate_policy", "evaluation_seeds"]

FloatArray = NDArray[np.float64]

#: First seed of the evaluation episodes used during training (kept apart from small seeds).
EVALUATION_SEED_BASE = 1_000_000


def evaluation_seeds(n_episodes: int, base: int = EVALUATION_SEED_BASE) -> list[int]:
    """The seeds ``base, base + 1, ..., base + n_episodes - 1``."""
    if int(n_episodes) < 1:
        raise ValueError(f"n_episodes must be >= 1, got {n_episodes}")
    return [int(base) + k for k in range(int(n_episodes))]


@dataclass(frozen=True)
class EvaluationResult:
    """Per-episode metrics (each ``(n_episodes,)``, averaged over agents) and their means.

    Attributes:
        seeds: Episode seeds, in order.
        entropy_reduction: ``H(0) - H(T)`` per episode (nats).
        final_posterior_mass: Posterior mass after the last step per episode.
        mean_posterior_mass: Posterior mass averaged over the steps of each episode.
        episode_return: Summed reward per episode.
        episode_length: Steps per episode.
    """

    seeds: tuple[int, ...]
    entropy_reduction: FloatArray
    final_posterior_mass: FloatArray
    mean_posterior_mass: FloatArray
    episode_return: FloatArray
    episode_length: NDArray[np.int64]

    def summary(self) -> dict[str, float]:
        """Means over episodes, keyed like the training-curve CSV columns."""
        return {
            "mean_entropy_reduction": float(np.mean(self.entropy_reduction)),
            "mean_final_posterior_mass": float(np.mean(self.final_posterior_mass)),
            "mean_posterior_mass": float(np.mean(self.mean_posterior_mass)),
            "mean_return": float(np.mean(self.episode_return)),
            "mean_episode_length": float(np.mean(self.episode_length)),
        }


def evaluate_policy(
    policy: Any,
    env: Any,
    seeds: Iterable[int],
    *,
    reset_policy: Callable[[Any, int], None] | None = None,
) -> EvaluationResult:
    """Run one episode per seed and collect the metrics of the module docstring.

    Args:
        policy: Object with ``act(observations, infos) -> {agent: action}``.
        env: The parallel environment (reused; reset with each seed).
        seeds: Episode seeds (at least one).
        reset_policy: Optional ``f(policy, seed)`` called before each episode (e.g. to reseed a
            stochastic policy).

    Returns:
        The per-episode metrics.

    Raises:
        ValueError: no seeds, or an episode that ends before its first step.
    """
    seed_list = [int(s) for s in seeds]
    if not seed_list:
        raise ValueError("seeds must contain at least one seed")
    reductions, finals, means, returns, lengths = [], [], [], [], []
    for seed in seed_list:
        if reset_policy is not None:
            reset_policy(policy, seed)
        reduction, final, mean, episode_return, steps = _episode_metrics(policy, env, seed)
        reductions.append(reduction)
        finals.append(final)
        means.append(mean)
        returns.append(episode_return)
        lengths.append(steps)
    return EvaluationResult(
        seeds=tuple(seed_list),
        entropy_reduction=np.asarray(reductions),
        final_posterior_mass=np.asarray(finals),
        mean_posterior_mass=np.asarray(means),
        episode_return=np.asarray(returns),
        episode_length=np.asarray(lengths, dtype=np.int64),
    )


def _episode_metrics(policy: Any, env: Any, seed: int) -> tuple[float, float, float, float, int]:
    """One episode of ``policy`` on ``env`` reset with ``seed``: its entropy reduction, final
    and mean posterior mass and return (means over the agents live after the reset), and its
    steps.

    Raises:
        ValueError: No live agents after the reset, or an episode that ends before its first
            step.
    """
    observations, infos = env.reset(seed=seed)
    agents = list(env.agents)
    if not agents:
        raise ValueError(f"episode with seed {seed} has no live agents after reset")
    initial_entropy = np.array([infos[a]["entropy"] for a in agents], dtype=np.float64)
    mass_sum = np.zeros(len(agents))
    episode_return = np.zeros(len(agents))
    last_infos = infos
    steps = 0
    while env.agents:
        actions = policy.act(observations, infos)
        observations, rewards, _, _, infos = env.step(actions)
        steps += 1
        mass_sum += [infos[a]["posterior_mass"] for a in agents]
        episode_return += [rewards[a] for a in agents]
        last_infos = infos
    if steps == 0:
        raise ValueError(f"episode with seed {seed} ended before its first step")
    final_entropy = np.array([last_infos[a]["entropy"] for a in agents], dtype=np.float64)
    return (
        float(np.mean(initial_entropy - final_entropy)),
        float(np.mean([last_infos[a]["posterior_mass"] for a in agents])),
        float(np.mean(mass_sum / steps)),
        float(np.mean(episode_return)),
        steps,
    )
