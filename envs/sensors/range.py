r"""Range sensor with additive Gaussian noise.

Measurement model
-----------------
A vehicle at planar position :math:`p = (x, y)` measures the distance to the target position
:math:`\theta_{1:2}` plus Gaussian noise,

.. math::

    z = \lVert \theta_{1:2} - p \rVert + \eta, \qquad \eta \sim \mathcal N(0, \sigma^2),

so that
:math:`p(z \mid \theta) = \varphi\bigl((z - \lVert\theta_{1:2} - p\rVert)/\sigma\bigr)/\sigma`
with :math:`\varphi` the standard normal density. Negative observations are possible (the noise is
not truncated), which keeps the likelihood an exact Gaussian.

Observation domain
------------------
``[-6 sigma, max_range + 6 sigma]``, not periodic. For a target within ``max_range`` of the
vehicle the predicted range lies in ``[0, max_range]``, so the likelihood mass outside the domain
is at most :math:`\Phi(-6) \approx 9.9\times10^{-10}` on each side; the default
``max_range = 60`` covers the diagonal (56.6) of the paper's 40 x 40 search square. Targets
farther than ``max_range`` are still handled exactly by :meth:`RangeSensor.log_likelihood` and
:meth:`RangeSensor.sample`; only quadrature over :attr:`RangeSensor.domain` would then miss mass.

Bin probabilities
-----------------
:meth:`RangeSensor.bin_probabilities` returns
:math:`\Phi((b - \mu)/\sigma) - \Phi((a - \mu)/\sigma)` for each bin :math:`[a, b)`, taking the
difference of upper-tail probabilities when both arguments are positive (no cancellation).
"""

from __future__ import annotations

import math

import numpy as np

from infoseek.envs.sensors.arrays import (
    LOG_SQRT_2PI,
    as_edges,
    as_particles,
    as_points,
    check_broadcast,
    check_positive,
    check_rng,
    float_dtype,
    normal_bin_masses,
    planar_offsets,
)
from infoseek.envs.sensors.base import FloatArray, ObservationDomain

__all__ = ["RangeSensor"]


class RangeSensor:
    """Range sensor: noisy Euclidean distance from the vehicle to the target position.

    Attributes:
        name: ``"range"``.
        pose_dim: 2 (vehicle position ``(x, y)``).
        target_dim: 2 (target position; wider particles/targets use their first two coordinates).
        obs_dim: 1.
        domain: ``[-6 sigma, max_range + 6 sigma]``, not periodic.
        sigma: Range noise standard deviation.
        max_range: Largest vehicle-target distance the observation domain is sized for.
    """

    name = "range"
    pose_dim = 2
    target_dim = 2
    obs_dim = 1

    def __init__(self, sigma: float = 0.5, max_range: float = 60.0) -> None:
        """Create the sensor.

        Args:
            sigma: Range noise standard deviation, finite and ``> 0``.
            max_range: Largest distance covered by :attr:`domain`, finite and ``> 0``.

        Raises:
            ValueError: If a parameter is not finite or not positive.
            TypeError: If a parameter is not a real number.
        """
        self.sigma = check_positive(sigma, "sigma", "RangeSensor")
        self.max_range = check_positive(max_range, "max_range", "RangeSensor")
        self.domain = ObservationDomain(
            low=(-6.0 * self.sigma,), high=(self.max_range + 6.0 * self.sigma,), periodic=(False,)
        )
        self._log_norm = -math.log(self.sigma) - LOG_SQRT_2PI

    def __repr__(self) -> str:
        return f"RangeSensor(sigma={self.sigma!r}, max_range={self.max_range!r})"

    @staticmethod
    def _range(poses: FloatArray, particles: FloatArray) -> FloatArray:
        """``(..., N)`` distances (inputs already validated)."""
        return np.hypot(
            particles[:, 0] - poses[..., 0, None], particles[:, 1] - poses[..., 1, None]
        )

    def predict(self, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Noise-free ranges.

        Args:
            poses: ``(..., 2)`` vehicle positions.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(..., N, 1)`` distances; float32 when both inputs are float32 arrays.
        """
        owner = "RangeSensor.predict"
        dtype = float_dtype(poses, particles)
        poses = as_points(poses, "poses", 2, owner, dtype)
        particles = as_particles(particles, "particles", 2, owner, allow_wider=True, dtype=dtype)
        return self._range(poses, particles)[..., None]

    def noise_log_density(self, residual: FloatArray) -> FloatArray:
        """Log density of the Gaussian range noise.

        Args:
            residual: ``(..., 1)`` values of ``z - predict``.

        Returns:
            ``(...)`` log densities.
        """
        residual = as_points(residual, "residual", 1, "RangeSensor.noise_log_density")[..., 0]
        return self._log_norm - 0.5 * (residual / self.sigma) ** 2

    def sample(
        self, poses: FloatArray, targets: FloatArray, rng: np.random.Generator
    ) -> FloatArray:
        """Draw noisy ranges.

        Args:
            poses: ``(..., 2)`` vehicle positions.
            targets: ``(..., >= 2)`` target states, broadcasting against ``poses``.
            rng: Source of the range noise.

        Returns:
            ``(..., 1)`` observations.
        """
        owner = "RangeSensor.sample"
        rng = check_rng(rng, owner)
        delta = planar_offsets(poses, targets, owner)
        distance = np.hypot(delta[..., 0], delta[..., 1])
        return (distance + self.sigma * rng.standard_normal(distance.shape))[..., None]

    def log_likelihood(self, z: FloatArray, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Gaussian ``log p(z | theta)`` for every particle.

        Args:
            z: ``(..., 1)`` observed ranges.
            poses: ``(..., 2)`` vehicle positions; batch shape broadcasts against ``z``.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(..., N)`` log densities.
        """
        owner = "RangeSensor.log_likelihood"
        z = as_points(z, "z", 1, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 2, owner, allow_wider=True)
        check_broadcast(z, poses, owner)
        scaled = (z[..., 0, None] - self._range(poses, particles)) * (1.0 / self.sigma)
        return self._log_norm - 0.5 * scaled * scaled

    def bin_probabilities(
        self, edges: FloatArray, poses: FloatArray, particles: FloatArray
    ) -> FloatArray:
        """Exact probability that ``z`` falls in each bin ``[edges[q], edges[q+1])``.

        Args:
            edges: ``(Q+1,)`` strictly increasing edges (normally spanning :attr:`domain`).
            poses: ``(..., 2)`` vehicle positions.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(..., N, Q)`` bin probabilities. Rows sum to ``1 - (mass outside the edges)``,
            i.e. to within ``2e-9`` of 1 for edges spanning the domain and targets within
            ``max_range``.
        """
        owner = "RangeSensor.bin_probabilities"
        edges = as_edges(edges, self.domain, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 2, owner, allow_wider=True)
        x = (edges - self._range(poses, particles)[..., None]) * (1.0 / self.sigma)
        return normal_bin_masses(x)
