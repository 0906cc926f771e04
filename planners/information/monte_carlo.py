r"""Unbiased Monte Carlo MI for any sensor and any number of observations.

Draw ``S`` particles ``theta_s ~ w``, draw ``z_s ~ p(z | theta_s)`` with ``sensor.sample`` at
the ``k`` poses, and average ``log p(z_s | theta_s) - log p(z_s)`` with ``p(z_s)`` the exact
particle mixture (eq. 15). The estimate is unbiased for the particle belief's MI; its standard
error is reported (:attr:`~infoseek.planners.information.base.MIEstimate.stderr`). It needs a
``numpy.random.Generator``, which the caller owns (a planner passes its own). Cost
``O(S N k)`` likelihood evaluations per pose set.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy.special import logsumexp

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import BeliefMI, FloatArray, JointEntropies, MIEstimator
from infoseek.planners.information.channels import BATCH_BUDGET

__all__ = ["MonteCarloEstimator"]


class MonteCarloEstimator(MIEstimator):
    """Monte Carlo MI with the exact particle mixture (module docstring).

    Args:
        sensor: Any sensor.
        n_samples: Samples per pose set, an integer ``>= 2``.
        rng: The generator the samples are drawn from.

    Raises:
        ValueError: ``rng`` is not a ``numpy.random.Generator`` or ``n_samples < 2``.
    """

    name: ClassVar[str] = "monte_carlo"
    max_observations: ClassVar[int | None] = None
    options: ClassVar[tuple[str, ...]] = ("n_samples", "rng")
    stochastic: ClassVar[bool] = True

    def __init__(
        self, sensor: Sensor, n_samples: int = 4096, rng: np.random.Generator | None = None
    ) -> None:
        super().__init__(sensor)
        if not isinstance(rng, np.random.Generator):
            raise ValueError(
                "MI estimator 'monte_carlo' needs rng=numpy.random.Generator (planners pass "
                f"their own), got {type(rng).__name__}"
            )
        if isinstance(n_samples, bool) or int(n_samples) != n_samples or n_samples < 2:
            raise ValueError(f"n_samples must be an integer >= 2, got {n_samples!r}")
        self.n_samples = int(n_samples)
        self.rng = rng

    def joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        n_sets = pose_sets.shape[0]
        values = np.empty(n_sets)
        stderrs = np.empty(n_sets)
        for c in range(n_sets):
            values[c], stderrs[c] = self._estimate(belief, pose_sets[c])
        nan = np.full(n_sets, np.nan)
        return JointEntropies(values, stderrs, nan, nan.copy())

    def _estimate(self, belief: BeliefMI, poses: FloatArray) -> tuple[float, float]:
        """``(mean, stderr)`` for one ``(k, pose_dim)`` pose set."""
        particles, weights = belief.particles, belief.weights
        n, k = particles.shape[0], poses.shape[0]
        log_weights = np.log(np.maximum(weights, 0.0), where=weights > 0, out=np.full(n, -np.inf))
        chunk = max(1, BATCH_BUDGET // (2 * k * n))
        terms = []
        for start in range(0, self.n_samples, chunk):
            size = min(chunk, self.n_samples - start)
            index = self.rng.choice(n, size=size, p=weights)
            z = np.asarray(
                self.sensor.sample(poses[None, :, :], particles[index][:, None, :], self.rng)
            )
            log_lik = np.asarray(
                self.sensor.log_likelihood(z, poses[None, :, :], particles), dtype=np.float64
            ).sum(axis=1)  # (S, N)
            log_evidence = logsumexp(log_lik + log_weights, axis=1)
            terms.append(log_lik[np.arange(size), index] - log_evidence)
        values = np.concatenate(terms)
        if not np.all(np.isfinite(values)):
            raise ValueError(
                "Monte Carlo MI produced non-finite terms (sensor likelihood underflow)"
            )
        return float(values.mean()), float(values.std(ddof=1) / math.sqrt(values.size))
