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
linear in the number of observations.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

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
        """``log rho(delta)`` (linear interpolation in the table; 0 at ``delta = 0``)."""
        if self.periodic:
            delta = np.mod(delta + 0.5 * self.period, self.period) - 0.5 * self.period
        position = (delta - self._delta0) / self._step
        last = self._table.size - 1
        np.clip(position, 0.0, last - 1e-9, out=position)
        index = position.astype(np.intp)
        position -= index
        low = self._table[index]
        return low + position * (self._table[index + 1] - low)

    def pose_terms(self, particles: FloatArray, poses: FloatArray) -> FloatArray:
        """``(P, N, N)`` ``log rho`` of every particle pair for each of ``(P, pose_dim)``
        poses (the summands of ``-D_B``)."""
        predictions = np.asarray(self.sensor.predict(poses, particles), dtype=np.float64)[..., 0]
        return self.log_affinity(predictions[:, :, None] - predictions[:, None, :])

    @staticmethod
    def value(log_rho: FloatArray, weights: FloatArray) -> FloatArray:
        """The bound ``-sum_n w_n log sum_m w_m exp(log_rho[..., n, m])`` of every leading
        index of ``(..., N, N)`` summed pair terms (nats)."""
        shifted = log_rho + np.log(weights)[None, :]
        top = shifted.max(axis=-1, keepdims=True)
        inner = np.log(np.exp(shifted - top).sum(axis=-1)) + top[..., 0]
        return -(inner @ weights)
