r"""Summaries of ``K`` weighted particle beliefs, compiled: means, mass near a point, mass grids.

For row ``k`` with particles :math:`\theta_{k,n}` and normalised weights :math:`w_{k,n}`:

* :func:`weighted_means`: :math:`\sum_n w_{k,n} \theta_{k,n}` (the MMSE estimate of eq. 12 for
  non-periodic coordinates), the matrix-vector product NumPy computed through BLAS;
* :func:`masses_within`: :math:`\min(1, \sum_{n:\ \lVert p_{k,n} - c_k\rVert^2 \le r^2}
  w_{k,n})` over the planar positions :math:`p` (the localisation mass), the weights inside
  summed in particle order by NumPy's pairwise rule;
* :func:`mass_grids`: the weights accumulated, in particle order, on a ``gx x gy`` grid over the
  position box (points outside count in the edge cells), each grid normalised to sum 1.

The arithmetic is that of the NumPy forms they replaced, so the results are the same bit for bit
in the pinned numerical environment (:mod:`infoseek.envs.compiled`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum

FloatArray = NDArray[np.float64]

__all__ = ["mass_grids", "masses_within", "weighted_means"]


@kernel
def _weighted_means(particles: FloatArray, weights: FloatArray) -> FloatArray:
    k_rows, _, d = particles.shape
    out = np.empty((k_rows, d))
    for k in range(k_rows):
        mean = np.dot(weights[k], particles[k])
        for j in range(d):  # element by element: no broadcasting checks to compile
            out[k, j] = mean[j]
    return out


def weighted_means(particles: FloatArray, weights: FloatArray) -> FloatArray:
    """``(K, d)`` weighted means of ``(K, N, d)`` particles with ``(K, N)`` weights."""
    return _weighted_means(*_rows(particles, weights))  # type: ignore[no-any-return]


@kernel
def _masses_within(
    particles: FloatArray, weights: FloatArray, centers: FloatArray, radius_sq: float
) -> FloatArray:
    k_rows, n, _ = particles.shape
    out = np.empty(k_rows)
    inside = np.empty(n)
    for k in range(k_rows):
        count = 0
        for i in range(n):
            dx = particles[k, i, 0] - centers[k, 0]
            dy = particles[k, i, 1] - centers[k, 1]
            if dx * dx + dy * dy <= radius_sq:
                inside[count] = weights[k, i]
                count += 1
        out[k] = min(1.0, pairwise_sum(inside[:count]))
    return out


def masses_within(
    particles: FloatArray, weights: FloatArray, centers: FloatArray, radius: float
) -> FloatArray:
    """``(K,)`` weight of the particles whose position lies within ``radius`` of the position
    part of ``(K, >= 2)`` ``centers`` (at most 1)."""
    particles, weights = _rows(particles, weights)
    centers = np.ascontiguousarray(centers, dtype=np.float64)
    if centers.ndim != 2 or centers.shape[0] != particles.shape[0] or centers.shape[1] < 2:
        raise ValueError(f"centers must be ({particles.shape[0]}, >= 2), got {centers.shape}")
    return _masses_within(particles, weights, centers, float(radius) ** 2)  # type: ignore[no-any-return]


@kernel
def _mass_grids(
    particles: FloatArray, weights: FloatArray, low: FloatArray, width: FloatArray, gx: int, gy: int
) -> FloatArray:
    k_rows, n, _ = particles.shape
    fx, fy = gx / width[0], gy / width[1]
    out = np.zeros((k_rows, gx * gy))
    for k in range(k_rows):
        grid = out[k]
        for i in range(n):
            cx = int(math.floor((particles[k, i, 0] - low[0]) * fx))
            cy = int(math.floor((particles[k, i, 1] - low[1]) * fy))
            cx = min(max(cx, 0), gx - 1)
            cy = min(max(cy, 0), gy - 1)
            grid[cx * gy + cy] += weights[k, i]
        total = pairwise_sum(grid)
        for c in range(gx * gy):
            grid[c] = grid[c] / total
    return out


def mass_grids(
    particles: FloatArray,
    weights: FloatArray,
    low: FloatArray,
    width: FloatArray,
    shape: tuple[int, int],
) -> FloatArray:
    """``(K, gx, gy)`` normalised position mass of every belief on the ``shape`` grid over the
    box ``[low, low + width]`` of the first two coordinates."""
    particles, weights = _rows(particles, weights)
    gx, gy = int(shape[0]), int(shape[1])
    low = np.ascontiguousarray(low, dtype=np.float64)
    width = np.ascontiguousarray(width, dtype=np.float64)
    grids = _mass_grids(particles, weights, low, width, gx, gy)
    return grids.reshape(particles.shape[0], gx, gy)  # type: ignore[no-any-return]


def _rows(particles: FloatArray, weights: FloatArray) -> tuple[FloatArray, FloatArray]:
    """C-contiguous float64 ``(K, N, d)`` particles and ``(K, N)`` weights, or a ``ValueError``."""
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    weights = np.ascontiguousarray(weights, dtype=np.float64)
    if particles.ndim != 3 or weights.shape != particles.shape[:2]:
        raise ValueError(
            f"particles must be (K, N, d) and weights (K, N), got {particles.shape} and "
            f"{weights.shape}"
        )
    return particles, weights
