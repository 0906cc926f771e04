"""Particle resampling schemes and the effective sample size.

Every sampler maps normalised weights ``w`` (``(N,)``) to ``n`` ancestor indices whose
counts ``c_i`` satisfy ``E[c_i] = n w_i`` (unbiasedness). They differ in variance:

* multinomial: ``n`` i.i.d. uniforms ``U_k``, ancestor ``= F^{-1}(U_k)`` with ``F`` the
  cumulative weights (largest variance);
* stratified: one uniform per stratum, ``U_k = (k + V_k) / n`` with independent ``V_k``;
* systematic (the "low variance sampler" used in section III.A of Hoffmann et al. 2006):
  one shared uniform, ``U_k = (k + V) / n``. Every count is ``floor(n w_i)`` or
  ``ceil(n w_i)``. Cost ``O(N + n)`` (one pass of a merge via ``searchsorted`` on sorted input).

The effective sample size ``ESS = 1 / sum_i w_i^2`` ranges from 1 (one particle carries all the
mass) to ``N`` (uniform weights).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = [
    "effective_sample_size",
    "gather_rows",
    "multinomial_resample",
    "normalize_weights",
    "stratified_resample",
    "systematic_resample",
    "systematic_resample_rows",
]


def normalize_weights(weights: object) -> FloatArray:
    """Validate and normalise particle weights.

    Args:
        weights: ``(N,)`` non-negative finite weights with a positive sum.

    Returns:
        ``(N,)`` weights summing to one.

    Raises:
        ValueError: Wrong shape, negative/non-finite entries, or zero total mass.
    """
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1 or w.shape[0] == 0:
        raise ValueError(f"weights must have shape (N,) with N >= 1, got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError("weights must be finite (got NaN or inf)")
    if np.any(w < 0):
        raise ValueError("weights must be non-negative")
    total = w.sum()
    if not total > 0:
        raise ValueError("weights must have a positive sum")
    return w / total


def _check_args(rng: object, n: object, n_weights: int) -> int:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if n is None:
        return n_weights
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise ValueError(f"n must be a non-negative integer or None, got {n!r}")
    return int(n)


def _invert_cdf(w: FloatArray, points: FloatArray) -> IntArray:
    """Ancestor indices ``F^{-1}(points)`` for sorted or unsorted points in ``[0, 1)``."""
    cdf = np.cumsum(w)
    cdf[-1] = 1.0  # guard against round-off leaving the last point beyond the total
    idx = np.searchsorted(cdf, points, side="right")
    return np.minimum(idx, w.shape[0] - 1).astype(np.int64)


def systematic_resample(
    weights: FloatArray, rng: np.random.Generator, n: int | None = None
) -> IntArray:
    """Systematic (low-variance) resampling.

    Args:
        weights: ``(N,)`` non-negative weights (normalised internally).
        rng: Random generator (one uniform is drawn).
        n: Number of indices to draw (default ``N``).

    Returns:
        ``(n,)`` int64 ancestor indices, sorted ascending; index ``i`` appears
        ``floor(n w_i)`` or ``ceil(n w_i)`` times.
    """
    w = normalize_weights(weights)
    count = _check_args(rng, n, w.shape[0])
    points = (rng.random() + np.arange(count)) / max(count, 1)
    return _invert_cdf(w, points)


@kernel
def _systematic_rows(weights: FloatArray, uniforms: FloatArray) -> IntArray:
    k_rows, n = weights.shape
    idx = np.empty((k_rows, n), dtype=np.int64)
    cdf = np.empty(n)
    for k in range(k_rows):
        total = pairwise_sum(weights[k])
        running = 0.0
        for i in range(n):
            running += weights[k, i] / total
            cdf[i] = running
        cdf[n - 1] = 1.0  # guard against round-off leaving the last point beyond the total
        j = 0
        for i in range(n):
            point = (uniforms[k] + i) / n
            while j < n and cdf[j] <= point:  # searchsorted(side="right") of sorted points
                j += 1
            idx[k, i] = min(j, n - 1)
    return idx


def systematic_resample_rows(weights: FloatArray, uniforms: FloatArray) -> IntArray:
    """Systematic resampling of ``K`` weight vectors at once, one shared uniform per row.

    Row ``k`` is exactly :func:`systematic_resample` of ``weights[k]`` with ``rng.random()``
    returning ``uniforms[k]`` (the same arithmetic in one compiled pass per row: the
    normalisation, the running sum of the cumulative weights and a merge of the sorted points
    into them).

    Args:
        weights: ``(K, N)`` non-negative weights with positive row sums (normalised here).
        uniforms: ``(K,)`` uniforms in ``[0, 1)``.

    Returns:
        ``(K, N)`` int64 ancestor indices, each row sorted ascending.
    """
    w = np.ascontiguousarray(weights, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] == 0 or np.shape(uniforms) != (w.shape[0],):
        raise ValueError(
            f"weights must be (K, N) and uniforms (K,), got {w.shape} and {np.shape(uniforms)}"
        )
    return _systematic_rows(w, np.ascontiguousarray(uniforms, dtype=np.float64))  # type: ignore[no-any-return]


@kernel
def _gather_rows(particles: FloatArray, rows: IntArray, idx: IntArray) -> FloatArray:
    r_rows, n = idx.shape
    d = particles.shape[2]
    out = np.empty((r_rows, n, d))
    for r in range(r_rows):
        source = particles[rows[r]]
        for i in range(n):
            for j in range(d):
                out[r, i, j] = source[idx[r, i], j]
    return out


def gather_rows(particles: FloatArray, rows: IntArray, idx: IntArray) -> FloatArray:
    """``(R, N', d)`` particles ``particles[rows[r], idx[r, i]]``: the resampled sets of ``rows``.

    Args:
        particles: ``(K, N, d)`` particle sets.
        rows: ``(R,)`` the sets resampled.
        idx: ``(R, N')`` ancestor indices of each (from :func:`systematic_resample_rows`).
    """
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    k_rows, n = particles.shape[:2]
    if (
        idx.shape[0] != rows.shape[0]
        or rows.size
        and (rows.min() < 0 or rows.max() >= k_rows or idx.min() < 0 or idx.max() >= n)
    ):
        raise ValueError(
            f"rows {rows.shape} and idx {idx.shape} must index the {k_rows} sets of {n} particles"
        )
    return _gather_rows(particles, rows, idx)  # type: ignore[no-any-return]


def stratified_resample(
    weights: FloatArray, rng: np.random.Generator, n: int | None = None
) -> IntArray:
    """Stratified resampling: one independent uniform in each stratum ``[k/n, (k+1)/n)``.

    Args:
        weights: ``(N,)`` non-negative weights (normalised internally).
        rng: Random generator.
        n: Number of indices to draw (default ``N``).

    Returns:
        ``(n,)`` int64 ancestor indices, sorted ascending.
    """
    w = normalize_weights(weights)
    count = _check_args(rng, n, w.shape[0])
    points = (rng.random(count) + np.arange(count)) / max(count, 1)
    return _invert_cdf(w, points)


def multinomial_resample(
    weights: FloatArray, rng: np.random.Generator, n: int | None = None
) -> IntArray:
    """Multinomial resampling: ``n`` i.i.d. draws from the categorical distribution ``w``.

    Args:
        weights: ``(N,)`` non-negative weights (normalised internally).
        rng: Random generator.
        n: Number of indices to draw (default ``N``).

    Returns:
        ``(n,)`` int64 ancestor indices (in draw order).
    """
    w = normalize_weights(weights)
    count = _check_args(rng, n, w.shape[0])
    return _invert_cdf(w, rng.random(count))


def effective_sample_size(weights: FloatArray) -> float:
    """Effective sample size ``1 / sum w_i^2`` of (normalised internally) weights.

    Args:
        weights: ``(N,)`` non-negative weights.

    Returns:
        ESS in ``[1, N]``.
    """
    w = normalize_weights(weights)
    return float(1.0 / np.dot(w, w))
