r"""Means and spreads of periodic coordinates (angles) of weighted particle sets, compiled.

A periodic coordinate :math:`\alpha \in [l, l + P)` with harmonic :math:`h` (1 for a circular
angle, 2 for an axial one, whose period :math:`P` is half a turn) has the phase
:math:`\phi = (\alpha - l)\, 2\pi h / P`. Its weighted circular mean is

.. math::

    \bar\alpha = l + \frac{P}{2\pi h}\,\bigl(\operatorname{atan2}(\textstyle\sum_n w_n
        \sin\phi_n, \sum_n w_n \cos\phi_n) \bmod 2\pi\bigr),

(``l`` where rounding lands it on the far end ``l + P / h``), and the spread used by roughening
is the range of the residuals :math:`(\alpha - \bar\alpha + P / 2h) \bmod (P / h)` about the
equally weighted mean.

The weighted sums go through BLAS as NumPy's ``w @ cos(phase)`` did (``ddot`` for one periodic
coordinate, ``dgemv`` for several), the trigonometric functions are the C library's, so the
results are the NumPy form's bit for bit in the pinned numerical environment.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]

__all__ = ["circular_means", "circular_ranges"]


@kernel
def _weighted_sums(phase: FloatArray, weights: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(w @ cos(phase), w @ sin(phase))`` of ``(N, k)`` phases, as NumPy's matmul forms them."""
    n, k = phase.shape
    cos_phase, sin_phase = np.empty((n, k)), np.empty((n, k))
    for i in range(n):
        for j in range(k):
            cos_phase[i, j] = math.cos(phase[i, j])
            sin_phase[i, j] = math.sin(phase[i, j])
    c, s = np.empty(k), np.empty(k)
    if k == 1:  # NumPy's (N,) @ (N, 1) is a dot product
        c[0] = np.dot(weights, np.ascontiguousarray(cos_phase[:, 0]))
        s[0] = np.dot(weights, np.ascontiguousarray(sin_phase[:, 0]))
    else:
        c, s = np.dot(weights, cos_phase), np.dot(weights, sin_phase)
    return c, s


@kernel
def _circular_means(
    angles: FloatArray,
    weights: FloatArray,
    low: FloatArray,
    period: FloatArray,
    harmonic: FloatArray,
) -> FloatArray:
    r_rows, n, k = angles.shape
    factor = 2.0 * np.pi * harmonic / period
    turn = 2.0 * np.pi * harmonic
    out = np.empty((r_rows, k))
    phase = np.empty((n, k))
    for r in range(r_rows):
        for i in range(n):
            for j in range(k):
                phase[i, j] = (angles[r, i, j] - low[j]) * factor[j]
        c, s = _weighted_sums(phase, weights[r])
        for j in range(k):
            mean_phase = math.atan2(s[j], c[j]) % (2.0 * np.pi)
            mean = low[j] + mean_phase * period[j] / turn[j]
            out[r, j] = low[j] if mean >= low[j] + period[j] / harmonic[j] else mean
    return out


def circular_means(
    angles: FloatArray,
    weights: FloatArray,
    low: FloatArray,
    period: FloatArray,
    harmonic: FloatArray,
) -> FloatArray:
    """``(R, k)`` weighted circular (axial) means of ``(R, N, k)`` periodic coordinates.

    Args:
        angles: ``(R, N, k)`` periodic coordinates of ``R`` particle sets.
        weights: ``(R, N)`` normalised weights.
        low: ``(k,)`` lower bounds of the coordinates.
        period: ``(k,)`` their periods.
        harmonic: ``(k,)`` 2.0 for axial, 1.0 for circular coordinates.
    """
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    weights = np.ascontiguousarray(weights, dtype=np.float64)
    if angles.ndim != 3 or weights.shape != angles.shape[:2]:
        raise ValueError(
            f"angles must be (R, N, k) and weights (R, N), got {angles.shape} and {weights.shape}"
        )
    low, period, harmonic = (
        np.ascontiguousarray(a, dtype=np.float64) for a in (low, period, harmonic)
    )
    return _circular_means(angles, weights, low, period, harmonic)  # type: ignore[no-any-return]


@kernel
def _circular_ranges(
    angles: FloatArray, centers: FloatArray, period: FloatArray, harmonic: FloatArray
) -> FloatArray:
    r_rows, n, k = angles.shape
    out = np.empty((r_rows, k))
    for r in range(r_rows):
        for j in range(k):
            half = period[j] / (2.0 * harmonic[j])  # residuals live in [-half, half)
            lowest, highest = math.inf, -math.inf
            for i in range(n):
                resid = (angles[r, i, j] - centers[r, j] + half) % (2.0 * half)
                lowest, highest = min(lowest, resid), max(highest, resid)
            out[r, j] = highest - lowest
    return out


def circular_ranges(
    angles: FloatArray, low: FloatArray, period: FloatArray, harmonic: FloatArray
) -> FloatArray:
    """``(R, k)`` range of each set's residuals about its equally weighted circular mean."""
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    r_rows, n, _ = angles.shape
    uniform = np.full((r_rows, n), 1.0 / n)
    centers = circular_means(angles, uniform, low, period, harmonic)
    period, harmonic = (np.ascontiguousarray(a, dtype=np.float64) for a in (period, harmonic))
    return _circular_ranges(angles, centers, period, harmonic)  # type: ignore[no-any-return]
