r"""Information of many future observations at once: the Bhattacharyya pairwise-distance bound.

The receding-horizon planner scores a whole team's observations over several future steps,
far more than the grid estimators of :mod:`infoseek.planners.information` can take jointly
(they stop at three). For a belief :math:`\sum_n w_n \delta(\theta - \theta_n)` and
conditionally independent observations :math:`Z = (z_1, \dots, z_K)` at poses
:math:`p_1, \dots, p_K`, :math:`p(Z)` is the mixture :math:`\sum_n w_n q_n(Z)` with
:math:`q_n(Z) = \prod_k p(z_k \mid \theta_n, p_k)`, and for any mixture the pairwise-distance
estimator (Kolchinsky & Tracey, *Entropy* 2017)

.. math::  \hat I_D = -\sum_n w_n \log \sum_m w_m e^{-D(q_n, q_m)}

bounds :math:`I(Z; \theta) = H(Z) - H(Z \mid \theta)` from below when :math:`D` is the
Bhattacharyya distance :math:`D_B = -\log \int \sqrt{q_n q_m}` (and from above for the
Kullback-Leibler divergence). It is exact in both limits: 0 when the components coincide, the
entropy of the weights when they do not overlap. The Bhattacharyya coefficient of product
densities is the product of the per-observation coefficients, so
:math:`D_B(n, m) = -\sum_k \log \rho_k(n, m)`, and for an additive-noise sensor
(:class:`~infoseek.envs.sensors.base.AdditiveNoiseSensor`, ``z = h(p, theta) + eta``)
:math:`\rho_k(n, m) = \rho(h(p_k, \theta_n) - h(p_k, \theta_m))` depends on the difference of
the two noise-free predictions only, with :math:`\rho(\delta) = \int \sqrt{f(r) f(r - \delta)}
\, dr` for the noise density :math:`f` (``exp(-delta^2 / (8 sigma^2))`` for Gaussian noise).
:class:`HorizonInformation` tabulates :math:`\log \rho` once from the sensor's
``noise_log_density`` (a circular autocorrelation by FFT on periodic observations, zero-padded
on others) and evaluates :math:`\log \rho` of every particle pair at a pose as one
``(N, N)`` table lookup, so a set of ``K`` observations costs ``K N^2`` lookups plus one
``N^2`` log-sum-exp, whatever ``K``: the cost is quadratic in the planning particles and
linear in the number of observations. The lookups, their sums over a sequence of poses and the
log-sum-exp's sums and shifts run as compiled kernels (:mod:`~infoseek.planners.horizon_affinity`,
:mod:`~infoseek.planners.horizon_bound`) that give the bits of the NumPy expressions they
replace.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.horizon_affinity import AffinityTable, log_affinity, pair_term_sums
from infoseek.planners.horizon_bound import bound_rows

FloatArray = NDArray[np.float64]

__all__ = ["HorizonInformation"]

#: Points of the noise grid over one observation period (or the padded non-periodic range).
TABLE_POINTS = 4096
#: Floor of ``log rho``: pairs this far apart contribute ``exp(-60)``, nothing in float64 sums.
LOG_AFFINITY_FLOOR = -60.0


class HorizonInformation:
    """Pairwise-distance information bound of many observations of one additive-noise sensor.

    Args:
        sensor: A sensor with one observation coordinate and the additive-noise methods
            ``predict`` and ``noise_log_density``.

    Raises:
        TypeError: The sensor lacks ``predict`` / ``noise_log_density`` or has more than one
            observation coordinate.
    """

    def __init__(self, sensor: Any) -> None:
        missing = [m for m in ("predict", "noise_log_density") if not hasattr(sensor, m)]
        if missing or int(getattr(sensor, "obs_dim", 0)) != 1:
            raise TypeError(
                f"the horizon information needs an additive-noise sensor with a 1-D observation "
                f"(predict and noise_log_density), got {type(sensor).__name__}"
            )
        self.sensor = sensor
        low, high = float(sensor.domain.low[0]), float(sensor.domain.high[0])
        self.periodic = bool(sensor.domain.periodic[0])
        self.period = high - low
        self._delta0, self._step, self._table = self._tabulate(low, high)
        self._affinity = AffinityTable(
            self._table, self._delta0, self._step, self.period if self.periodic else None
        )

    def _tabulate(self, low: float, high: float) -> tuple[float, float, FloatArray]:
        """``(first delta, spacing, log rho table)`` of the noise's Bhattacharyya coefficient."""
        width = high - low
        n = TABLE_POINTS
        if self.periodic:
            step = width / n
            r = (np.arange(n) - n // 2) * step  # residuals centred on 0, one period
            root = np.exp(0.5 * self.sensor.noise_log_density(r[:, None]))
            spectrum = np.fft.rfft(np.fft.ifftshift(root))
            rho = np.fft.irfft(spectrum * np.conj(spectrum), n) * step  # rho(k * step)
            rho = np.fft.fftshift(rho)  # index j <-> delta = (j - n/2) * step
            delta0 = -(n // 2) * step
        else:
            step = 2.0 * width / n  # predictions differ by at most the domain width
            r = (np.arange(n) - n // 2) * step
            root = np.exp(0.5 * self.sensor.noise_log_density(r[:, None]))
            padded = np.concatenate([root, np.zeros(n)])
            spectrum = np.fft.rfft(padded)
            full = np.fft.irfft(spectrum * np.conj(spectrum), 2 * n) * step
            rho = np.concatenate([full[-(n // 2) :], full[: n - n // 2]])
            delta0 = -(n // 2) * step
        table = np.log(np.maximum(rho / rho.max(), math.exp(LOG_AFFINITY_FLOOR)))
        return delta0, step, table

    def log_affinity(self, delta: FloatArray) -> FloatArray:
        """``log rho(delta)`` (linear interpolation in the table; 0 at ``delta = 0``).

        Args:
            delta: Float64 differences of predictions, any shape, finite.
        """
        return log_affinity(delta, self._affinity)

    def _predictions(self, particles: FloatArray, poses: FloatArray) -> FloatArray:
        """``(..., N)`` noise-free predictions of every particle at ``(..., pose_dim)`` poses."""
        return np.asarray(self.sensor.predict(poses, particles), dtype=np.float64)[..., 0]

    def pose_terms(self, particles: FloatArray, poses: FloatArray) -> FloatArray:
        """``(P, N, N)`` ``log rho`` of every particle pair for each of ``(P, pose_dim)``
        poses (the summands of ``-D_B``)."""
        predictions = self._predictions(particles, poses)
        return pair_term_sums(predictions[:, None, :], self._affinity)

    def pose_term_sums(self, particles: FloatArray, poses: FloatArray) -> FloatArray:
        """``(G, N, N)`` pair terms summed over each group of ``(G, H, pose_dim)`` poses:
        ``pose_terms(particles, poses[g]).sum(axis=0)`` bit for bit, without the
        ``(G, H, N, N)`` terms (a sequence's ``H`` observations)."""
        return pair_term_sums(self._predictions(particles, poses), self._affinity)

    @staticmethod
    def value(log_rho: FloatArray, weights: FloatArray) -> FloatArray:
        """The bound ``-sum_n w_n log sum_m w_m exp(log_rho[..., n, m])`` of every leading
        index of ``(..., N, N)`` summed pair terms (nats)."""
        log_rho = np.asarray(log_rho, dtype=np.float64)
        n = log_rho.shape[-1]
        empty = np.empty((0, n, n))
        rows = bound_rows(log_rho.reshape(-1, n, n), empty, np.log(weights))
        return -(rows.reshape(log_rho.shape[:-1]) @ weights)

    @staticmethod
    def bound(own: FloatArray, partners: FloatArray, weights: FloatArray) -> FloatArray:
        """``(C,)`` :meth:`value` of ``own[c] + partners[0] + partners[1] + ...`` (summed in
        that order) for ``(C, N, N)`` ``own`` and ``(K, N, N)`` ``partners``, without forming
        the sums."""
        rows = bound_rows(own, partners, np.log(weights))
        return -(rows @ weights)
