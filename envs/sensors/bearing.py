r"""Bearings-only sensor with a wrapped-normal likelihood (section IV.A of the paper).

Measurement model
-----------------
A vehicle at planar position :math:`(x, y)` measures the bearing of the ray to the target
:math:`\theta = (x_t, y_t)`,

.. math::

    z = \operatorname{wrap}\bigl(\operatorname{atan2}(y_t - y, x_t - x) + \eta\bigr),
    \qquad \eta \sim \mathcal N(0, \sigma^2),

with :math:`\operatorname{wrap}` mapping angles into :math:`[-\pi, \pi)`. The observation is
therefore a *wrapped normal* variable centred at the predicted bearing :math:`\mu`:

.. math::

    p(z \mid \theta) = \sum_{k \in \mathbb Z} \frac{1}{\sigma\sqrt{2\pi}}
        \exp\Bigl(-\frac{(r + 2\pi k)^2}{2\sigma^2}\Bigr),
    \qquad r = \operatorname{wrap}(z - \mu) \in [-\pi, \pi).

Evaluation (exact to double precision)
--------------------------------------
*Image sum* (``sigma < 2``). The distances :math:`|r + 2\pi k|` in increasing order are
:math:`|r|,\ 2\pi - |r|,\ 2\pi + |r|,\ 4\pi - |r|, \dots`. Factoring out the dominant term,

.. math::

    \log p = -\frac{r^2}{2\sigma^2} - \log(\sigma\sqrt{2\pi})
        + \log\Bigl(1 + \sum_{j \ge 1} e^{-(d_j^2 - r^2) / (2\sigma^2)}\Bigr),

where :math:`d_j` are the further distances. Every exponent is non-positive, so nothing
overflows and the ``log1p`` keeps full relative accuracy (also near :math:`|r| = \pi`, where the
first image is as large as the main term). Image :math:`j` has
:math:`d_j^2 - r^2 \ge 4\pi^2 m (m \pm 1)`-type lower bounds; the constructor keeps images
until the smallest omitted relative term is below :math:`e^{-42} \approx 6\times10^{-19}`
(one extra term for ``sigma < 0.97``, five for ``sigma`` just below 2; terms that are
negligible for every :math:`|r| \le \pi` are skipped).

*Theta (Fourier) series* (``sigma >= 2``). By Poisson summation,

.. math::

    p(z \mid \theta) = \frac{1}{2\pi}\Bigl(1 + 2\sum_{n \ge 1} e^{-n^2\sigma^2/2}\cos(n r)\Bigr),

truncated when :math:`e^{-n^2\sigma^2/2} < e^{-42}` (at most five terms). For
``sigma >= 2`` the bracket is at least ``0.7``, so there is no cancellation.

Bin probabilities
-----------------
For the mutual-information code, :meth:`BearingSensor.bin_probabilities` returns the exact mass
of each bin :math:`[a, b)`:
:math:`\sum_k \Phi((b - \mu + 2\pi k)/\sigma) - \Phi((a - \mu + 2\pi k)/\sigma)` (image sum,
differences of the normal CDF taken on the accurate side of zero), or, for ``sigma >= 2``,
:math:`(b - a)/(2\pi) + \frac1\pi\sum_n e^{-n^2\sigma^2/2}
(\sin n(b - \mu) - \sin n(a - \mu))/n`.

"""

from __future__ import annotations

import math
from typing import cast

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.arctangent import arctan2_float32
from infoseek.envs.sensors.arrays import (
    LOG_SQRT_2PI,
    TWO_PI,
    as_edges,
    as_particles,
    as_points,
    check_broadcast,
    check_positive,
    check_rng,
    float_dtype,
    normal_bin_masses,
    planar_offsets,
    wrap_into,
)
from infoseek.envs.sensors.base import FloatArray, ObservationDomain
from infoseek.envs.sensors.wrapped_normal import (
    ImageSum,
    bearings_of_groups,
    summed_log_likelihood,
    wrapped_log_density,
)

__all__ = ["BearingSensor"]

# Relative size below which an omitted image/Fourier term is negligible (e^-42 ~ 5.7e-19).
_NEGLIGIBLE_EXPONENT = 42.0
# Above this noise level the theta series needs fewer terms than the image sum.
_FOURIER_SIGMA = 2.0
# Bearings per block of groups in the filter's likelihood pass (arrays that stay in cache).
_BLOCK_ELEMENTS = 1 << 16


class BearingSensor:
    """Bearings-only sensor: noisy angle of the ray from the vehicle to the target.

    Observation ``z`` in ``[-pi, pi)`` (periodic); wrapped-normal likelihood (module docstring).

    Attributes:
        name: ``"bearing"``.
        pose_dim: 2 (vehicle position ``(x, y)``).
        target_dim: 2 (target position ``(x_t, y_t)``; wider particles use the first two).
        obs_dim: 1.
        domain: ``[-pi, pi)``, periodic.
        sigma: Standard deviation of the (unwrapped) Gaussian bearing noise, radians.
    """

    name = "bearing"
    pose_dim = 2
    target_dim = 2
    obs_dim = 1
    #: The kernel family has a single member (``ShiftKernelSensor``).
    max_kernel_shape = 0.0

    def __init__(self, sigma: float = 0.1) -> None:
        """Create the sensor.

        Args:
            sigma: Bearing noise standard deviation in radians, finite and ``> 0``.

        Raises:
            ValueError: If ``sigma`` is not finite or not positive.
            TypeError: If ``sigma`` is not a real number.
        """
        self.sigma = check_positive(sigma, "sigma", "BearingSensor")
        self.domain = ObservationDomain(low=(-math.pi,), high=(math.pi,), periodic=(True,))
        s2 = self.sigma**2
        self._use_fourier = self.sigma >= _FOURIER_SIGMA
        if self._use_fourier:
            n_terms = max(1, math.ceil(math.sqrt(2.0 * _NEGLIGIBLE_EXPONENT) / self.sigma))
            n = np.arange(1, n_terms + 1, dtype=np.float64)
            self._fourier_n = n
            self._fourier_coef = np.exp(-0.5 * n**2 * s2)
        else:
            # Image pairs m = 1, 2, ...: distances 2 pi m - |r| and 2 pi m + |r|. The smallest
            # relative exponent of pair m is (4 pi^2 m (m - 1)) / (2 s^2) (at |r| = pi); keep
            # pairs until the first omitted pair is negligible.
            m = 1
            while 4.0 * math.pi**2 * m * (m + 1) / (2.0 * s2) < _NEGLIGIBLE_EXPONENT:
                m += 1
            self._n_image_pairs = m
            # (a, sign) of every image term a + sign |r| that can matter (relative exponent
            # > -42 somewhere on |r| in [0, pi]).
            self._image_terms: list[tuple[float, float]] = []
            for k in range(1, m + 1):
                a = TWO_PI * k
                self._image_terms.append((a, -1.0))
                if a * a / (2.0 * s2) < _NEGLIGIBLE_EXPONENT:
                    self._image_terms.append((a, 1.0))
            # CDF images: argument (d + 2 pi k)/s with |d| <= 2 pi; |k| <= K suffices once
            # 2 pi K / s >= 9 (Phi(-9) ~ 1e-19).
            n_cdf = max(1, math.ceil(9.0 * self.sigma / TWO_PI))
            self._cdf_shifts = TWO_PI * np.arange(-n_cdf, n_cdf + 1, dtype=np.float64)
        self._log_norm = -math.log(self.sigma) - LOG_SQRT_2PI
        self._image_sum = (
            None if self._use_fourier else ImageSum(self.sigma, self._image_terms, self._log_norm)
        )

    def __repr__(self) -> str:
        return f"BearingSensor(sigma={self.sigma!r})"

    # -- model ------------------------------------------------------------------------------

    def predict(self, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Noise-free bearings.

        Args:
            poses: ``(..., 2)`` vehicle positions.
            particles: ``(N, >= 2)`` target hypotheses (first two coordinates used).

        Returns:
            ``(..., N, 1)`` bearings in ``[-pi, pi)``; float32 when both inputs are float32
            arrays (the planners' fast path), float64 otherwise.
        """
        dtype = float_dtype(poses, particles)
        poses = as_points(poses, "poses", 2, "BearingSensor.predict", dtype)
        particles = as_particles(
            particles, "particles", 2, "BearingSensor.predict", allow_wider=True, dtype=dtype
        )
        return self._bearing(poses, particles)[..., None]

    def _bearing(
        self, poses: FloatArray, particles: FloatArray, *, wrap: bool = True
    ) -> FloatArray:
        """``(..., N)`` bearings in ``[-pi, pi)`` (``(-pi, pi]`` unless ``wrap``).

        Inputs are already validated.
        """
        dx = particles[:, 0] - poses[..., 0, None]
        dy = particles[:, 1] - poses[..., 1, None]
        if dx.dtype == np.float32:  # the planners' predictions: the same bits whatever the libm
            dy32, dx32 = dy.astype(np.float32, copy=False), dx.astype(np.float32, copy=False)
            angle = cast(FloatArray, arctan2_float32(dy32, dx32))
        else:
            angle = np.arctan2(dy, dx)
        if wrap:
            # atan2 returns (-pi, pi]; map pi to -pi.
            angle[angle >= math.pi] -= TWO_PI
        return angle

    def noise_log_density(self, residual: FloatArray) -> FloatArray:
        """Log density of the wrapped-normal noise.

        Args:
            residual: ``(..., 1)`` values of ``z - predict`` (any real; wrapped internally).

        Returns:
            ``(...)`` log densities.
        """
        residual = as_points(residual, "residual", 1, "BearingSensor.noise_log_density")
        return self._wrapped_log_density(residual[..., 0])

    def _wrapped_log_density(self, residual: FloatArray) -> FloatArray:
        if self._use_fourier:
            r = np.abs(wrap_into(residual, -math.pi, TWO_PI))
            cos_terms = np.cos(np.multiply.outer(r, self._fourier_n)) @ self._fourier_coef
            return np.log1p(2.0 * cos_terms) - math.log(TWO_PI)
        # Image at distance a - |r| (a = 2 pi m) has relative exponent -(a^2 - 2 a |r|)/(2 s^2),
        # the one at a + |r| has -(a^2 + 2 a |r|)/(2 s^2); compiled in
        # :mod:`infoseek.envs.sensors.wrapped_normal`.
        assert self._image_sum is not None
        return wrapped_log_density(residual, self._image_sum)

    def kernel_parameters(
        self, poses: FloatArray, particles: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Centre (the noise-free bearing) and shape (always 0) of each particle's kernel.

        Args:
            poses: ``(..., 2)`` vehicle positions.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(centre, shape)``, each ``(..., N)``.
        """
        centre = self.predict(poses, particles)[..., 0].astype(np.float64)
        return centre, np.zeros_like(centre)

    def kernel_log_density(self, residual: FloatArray, shape: FloatArray) -> FloatArray:
        """Wrapped-normal noise log density at ``residual`` (``shape`` only broadcasts)."""
        residual = np.asarray(residual, dtype=np.float64)
        shape = np.asarray(shape, dtype=np.float64)
        return self._wrapped_log_density(residual + np.zeros_like(shape))

    # -- Sensor protocol ----------------------------------------------------------------------

    def sample(
        self, poses: FloatArray, targets: FloatArray, rng: np.random.Generator
    ) -> FloatArray:
        """Draw noisy bearings.

        Args:
            poses: ``(..., 2)`` vehicle positions.
            targets: ``(..., >= 2)`` target states, broadcasting against ``poses``.
            rng: Source of the bearing noise.

        Returns:
            ``(..., 1)`` bearings in ``[-pi, pi)``.
        """
        owner = "BearingSensor.sample"
        rng = check_rng(rng, owner)
        delta = planar_offsets(poses, targets, owner)
        mean = np.arctan2(delta[..., 1], delta[..., 0])
        noisy = mean + self.sigma * rng.standard_normal(mean.shape)
        return wrap_into(noisy, -math.pi, TWO_PI)[..., None]

    def log_likelihood(self, z: FloatArray, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Wrapped-normal ``log p(z | theta)`` for every particle.

        Args:
            z: ``(..., 1)`` observed bearings (any real; wrapped internally).
            poses: ``(..., 2)`` vehicle positions; batch shape broadcasts against ``z``.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(..., N)`` log densities on ``[-pi, pi)``.
        """
        owner = "BearingSensor.log_likelihood"
        z = as_points(z, "z", 1, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 2, owner, allow_wider=True)
        check_broadcast(z, poses, owner)
        residual = z[..., 0, None] - self._bearing(poses, particles, wrap=False)
        return self._wrapped_log_density(residual)

    def summed_log_likelihood(
        self, z: FloatArray, poses: FloatArray, particles: FloatArray, received: NDArray[np.bool_]
    ) -> FloatArray | None:
        """The filter's likelihood pass: for every belief, the sum of ``log p(z | theta)`` over
        the observations it received (compiled; the same numbers as summing
        :meth:`log_likelihood`).

        Args:
            z: ``(G, M, 1)`` observations of ``G`` groups (an environment's agents).
            poses: ``(G, M, 2)`` positions of the sensors that made them.
            particles: ``(K, N, >= 2)`` particles of ``K`` beliefs; belief ``k`` belongs to
                group ``k // (K / G)``.
            received: ``(K, M)`` which of its group's observations each belief received.

        Returns:
            ``(K, N)`` summed log-likelihoods, or ``None`` for ``sigma >= 2`` (theta series;
            the caller then sums :meth:`log_likelihood`).
        """
        if self._image_sum is None:
            return None
        groups = z.shape[0]
        per = particles.shape[0] // groups
        block = max(1, _BLOCK_ELEMENTS // (z.shape[1] * per * particles.shape[1]))
        if block >= groups:
            bearings = bearings_of_groups(particles, poses)
            return summed_log_likelihood(bearings, z[..., 0], received, self._image_sum)
        total = np.empty(particles.shape[:2])
        for start in range(0, groups, block):  # blocks of groups: the bearings stay in cache
            stop = min(start + block, groups)
            rows = slice(start * per, stop * per)
            bearings = bearings_of_groups(particles[rows], poses[start:stop])
            total[rows] = summed_log_likelihood(
                bearings, z[start:stop, :, 0], received[rows], self._image_sum
            )
        return total

    def bin_probabilities(
        self, edges: FloatArray, poses: FloatArray, particles: FloatArray
    ) -> FloatArray:
        """Exact probability that ``z`` falls in each bin ``[edges[q], edges[q+1])``.

        Args:
            edges: ``(Q+1,)`` strictly increasing edges within ``[-pi, pi]``.
            poses: ``(..., 2)`` vehicle positions.
            particles: ``(N, >= 2)`` target hypotheses.

        Returns:
            ``(..., N, Q)`` bin probabilities (rows sum to 1 when the edges span the domain).
        """
        owner = "BearingSensor.bin_probabilities"
        edges = as_edges(edges, self.domain, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 2, owner, allow_wider=True)
        mu = self._bearing(poses, particles)[..., None]  # (..., N, 1)
        d = edges - mu  # (..., N, Q+1), within [-2 pi, 2 pi]
        if self._use_fourier:
            da, db = d[..., :-1], d[..., 1:]
            widths = np.diff(edges) / TWO_PI
            total = np.zeros(d.shape[:-1] + (edges.shape[0] - 1,))
            for n, coef in zip(self._fourier_n, self._fourier_coef, strict=True):
                total += (coef / (math.pi * n)) * (np.sin(n * db) - np.sin(n * da))
            return np.clip(widths + total, 0.0, 1.0)
        x = (d[..., None, :] + self._cdf_shifts[:, None]) * (1.0 / self.sigma)  # (..., N, K, Q+1)
        probs = normal_bin_masses(x).sum(axis=-2)
        return np.clip(probs, 0.0, 1.0)
