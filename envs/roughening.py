r"""Gordon roughening of resampled particles, compiled (see :mod:`infoseek.envs.belief`).

After resampling, every particle ``x`` of a belief moves to

.. math::  x' = x + \sigma \odot \eta, \qquad \eta \sim \mathcal N(0, I_d),

with a per-coordinate standard deviation :math:`\sigma` chosen by the belief (the roughening
rule, or a tempering-move scale). A non-periodic coordinate that leaves its interval
:math:`[l, h]` is folded back by mirror reflection at the walls
(:func:`~infoseek.envs.targets.reflect_into_interval`); a periodic one is wrapped into
:math:`[l, h)` (:meth:`~infoseek.envs.targets.TargetSpace.wrap`).

The normals are drawn by the caller, each belief from its own generator, so the kernel is pure
arithmetic: one pass over the ``(R, N, d)`` particles doing the NumPy operations of the
previous form, in the same order (bit for bit in the pinned numerical environment).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = ["coordinate_ranges", "jitter"]


@kernel
def _coordinate_ranges(particles: FloatArray) -> FloatArray:
    r_rows, n, d = particles.shape
    spread = np.empty((r_rows, d))
    for r in range(r_rows):
        for j in range(d):
            low = high = particles[r, 0, j]
            for i in range(1, n):
                value = particles[r, i, j]
                if value < low:
                    low = value
                if value > high:
                    high = value
            spread[r, j] = high - low
    return spread


def coordinate_ranges(particles: FloatArray) -> FloatArray:
    """``(R, d)`` ``max - min`` of every coordinate of ``(R, N, d)`` particle sets."""
    return _coordinate_ranges(np.ascontiguousarray(particles, dtype=np.float64))  # type: ignore[no-any-return]


@kernel
def _jitter(
    particles: FloatArray,
    noise: FloatArray,
    std: FloatArray,
    low: FloatArray,
    high: FloatArray,
    periodic: BoolArray,
) -> FloatArray:
    r_rows, n, d = particles.shape
    out = np.empty_like(particles)
    for r in range(r_rows):
        for i in range(n):
            for j in range(d):
                value = noise[r, i, j] * std[r, j] + particles[r, i, j]
                if periodic[j]:
                    period = high[j] - low[j]
                    wrapped = (value - low[j]) % period
                    if wrapped >= period:
                        wrapped = 0.0
                    value = low[j] + wrapped
                elif value < low[j] or value > high[j]:
                    width = high[j] - low[j]
                    folded = (value - low[j]) % (2.0 * width)
                    if folded > width:
                        folded = 2.0 * width - folded
                    value = min(max(low[j] + folded, low[j]), high[j])
                out[r, i, j] = value
    return out


def jitter(
    particles: FloatArray,
    noise: FloatArray,
    std: FloatArray,
    low: FloatArray,
    high: FloatArray,
    periodic: BoolArray,
) -> FloatArray:
    """Roughened copies ``particles + std * noise`` folded or wrapped into the box (module
    docstring).

    Args:
        particles: ``(R, N, d)`` equally weighted particle sets.
        noise: ``(R, N, d)`` standard normal draws.
        std: ``(R, d)`` standard deviation of each set's coordinates.
        low: ``(d,)`` lower bounds of the box.
        high: ``(d,)`` upper bounds of the box.
        periodic: ``(d,)`` which coordinates wrap.

    Returns:
        ``(R, N, d)`` new particles inside the box.
    """
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    if noise.shape != particles.shape or std.shape != (particles.shape[0], particles.shape[2]):
        raise ValueError(
            f"noise must have the shape of particles {particles.shape} and std "
            f"{(particles.shape[0], particles.shape[2])}, got {noise.shape} and {std.shape}"
        )
    return _jitter(  # type: ignore[no-any-return]
        particles,
        np.ascontiguousarray(noise, dtype=np.float64),
        np.ascontiguousarray(std, dtype=np.float64),
        np.ascontiguousarray(low, dtype=np.float64),
        np.ascontiguousarray(high, dtype=np.float64),
        np.ascontiguousarray(periodic, dtype=np.bool_),
    )
