r"""Gordon roughening of resampled particles, compiled (see :mod:`infoseek.envs.belief`).

After resampling, every particle ``x`` of a belief moves to

.. math::  x' = x + \sigma \odot \eta, \qquad \eta \sim \mathcal N(0, I_d),

with a per-coordinate standard deviation :math:`\sigma` chosen by the belief (the roughening
rule, or a tempering-move scale). A non-periodic coordinate that leaves its interval
:math:`[l, h]` is folded back by mirror reflection at the walls
(:func:`~infoseek.envs.targets.reflect_into_interval`); a periodic one is wrapped into
:math:`[l, h)` (:meth:`~infoseek.envs.targets.TargetSpace.wrap`).

Each set draws its normals from its own generator inside the kernel, the numbers
``Generator.standard_normal`` draws in the same order: for NumPy's default PCG64 generators one
call serves every set (:mod:`infoseek.envs.pcg64`, about four times as fast as NumPy's own
draws), for other bit generators one call per set through numba's ``Generator`` support. The
arithmetic is that of the NumPy form it replaced, in the same order (bit for bit in the pinned
numerical environment).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.envs.pcg64 import standard_normal, state_addresses

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
def _folded(value: float, low: float, high: float, periodic: bool) -> float:
    """``value`` wrapped into ``[low, high)`` (periodic) or mirrored into ``[low, high]``."""
    if periodic:
        period = high - low
        wrapped = (value - low) % period
        if wrapped >= period:
            wrapped = 0.0
        return low + wrapped
    if value < low or value > high:
        width = high - low
        folded = (value - low) % (2.0 * width)
        if folded > width:
            folded = 2.0 * width - folded
        return min(max(low + folded, low), high)
    return value


@kernel
def _jitter_row(
    particles: FloatArray,
    std: FloatArray,
    low: FloatArray,
    high: FloatArray,
    periodic: BoolArray,
    rng: np.random.Generator,
    out: FloatArray,
) -> None:
    """One ``(N, d)`` set: normals drawn from ``rng`` in C order (as
    ``rng.standard_normal(out=...)`` fills an ``(N, d)`` array), scaled, added, folded."""
    n, d = particles.shape
    for i in range(n):
        for j in range(d):
            value = rng.standard_normal() * std[j] + particles[i, j]
            out[i, j] = _folded(value, low[j], high[j], periodic[j])


@kernel
def _jitter_rows(
    particles: FloatArray,
    std: FloatArray,
    low: FloatArray,
    high: FloatArray,
    periodic: BoolArray,
    addresses: NDArray[np.uint64],
    out: FloatArray,
) -> None:
    """:func:`_jitter_row` for every set ``r``, drawing from the PCG64 state at
    ``addresses[r]`` (:mod:`infoseek.envs.pcg64`: the same numbers)."""
    r_rows, n, d = particles.shape
    for r in range(r_rows):
        address = addresses[r]
        for i in range(n):
            for j in range(d):
                value = standard_normal(address) * std[r, j] + particles[r, i, j]
                out[r, i, j] = _folded(value, low[j], high[j], periodic[j])


def jitter(
    particles: FloatArray,
    std: FloatArray,
    rngs: Sequence[np.random.Generator],
    low: FloatArray,
    high: FloatArray,
    periodic: BoolArray,
) -> FloatArray:
    """Roughened copies ``particles + std * noise`` folded or wrapped into the box (module
    docstring), set ``r`` drawing its normals from ``rngs[r]``.

    Args:
        particles: ``(R, N, d)`` equally weighted particle sets.
        std: ``(R, d)`` standard deviation of each set's coordinates.
        rngs: ``R`` generators.
        low: ``(d,)`` lower bounds of the box.
        high: ``(d,)`` upper bounds of the box.
        periodic: ``(d,)`` which coordinates wrap.

    Returns:
        ``(R, N, d)`` new particles inside the box.
    """
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    r_rows, _, d = particles.shape
    if std.shape != (r_rows, d) or len(rngs) != r_rows:
        raise ValueError(
            f"std must have shape {(r_rows, d)} and rngs {r_rows} entries, got {std.shape} "
            f"and {len(rngs)}"
        )
    std = np.ascontiguousarray(std, dtype=np.float64)
    low = np.ascontiguousarray(low, dtype=np.float64)
    high = np.ascontiguousarray(high, dtype=np.float64)
    periodic = np.ascontiguousarray(periodic, dtype=np.bool_)
    out = np.empty_like(particles)
    addresses = state_addresses(rngs)
    if addresses is not None:  # every set's own PCG64 stream, in one call
        _jitter_rows(particles, std, low, high, periodic, addresses, out)
        return out
    for r, rng in enumerate(rngs):  # one generator per set: the draws stay in its own stream
        _jitter_row(particles[r], std[r], low, high, periodic, rng, out[r])
    return out
