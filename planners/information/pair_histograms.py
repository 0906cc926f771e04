r"""Compiled stencil histograms of pairs of observations (the ``fft`` estimator's ``k = 2`` grids).

**Full grid.** Each pose's predictions (float32, widened exactly) are assigned to the
``Q``-node grid in float64
(:meth:`~infoseek.planners.information.noise_kernel.NoiseKernel.assign`): position
``y = (x - low) / spacing`` (wrapped or clamped), nearest node ``j = floor(y + 1/2)`` (``Q``
becomes ``0`` on a periodic grid), offset ``delta = y - j`` and the quadratic weights

.. math::  s_{-1} = \tfrac12\delta^2 - \tfrac12\delta, \quad s_0 = 1 - \delta^2, \quad
    s_{+1} = \tfrac12\delta^2 + \tfrac12\delta.

The pair ``(a, b)`` histogram on the ``(Q + 2)^2`` grid padded by one guard node per side is

.. math::  H_{ab}[j_a + 1 + u, j_b + 1 + v] \mathrel{+}= (s^a_u w_n)\, s^b_v
    \qquad (n = 1 \dots N,\ u, v = -1, 0, 1 \text{ in this order}),

after which the guard rows and columns are folded back (across the seam on a periodic grid, onto
the edge node otherwise; rows first) and the ``Q x Q`` core is returned. These are the additions,
in the order, of the single ``numpy.bincount`` over the ``(C, M, N, 9)`` index array they replace,
so the histograms are the same bit for bit, without the index and value temporaries.

**Windowed scatter.** Window stencils (:mod:`~infoseek.planners.information.windows`) too wide
for a matrix product are accumulated the same way on the ``W_a x W_b`` window grid, weights
``(s^a_u w_n) s^b_v`` with float32 stencils, and rounded to float32 at the end.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.kernel_arrays import require, require_rows

__all__ = ["full_grid_pair_histograms", "windowed_scatter_histograms"]


@kernel
def _positions(
    predictions: NDArray[np.floating],
    low: float,
    scale: float,
    n_points: int,
    periodic: bool,
    out: FloatArray,
) -> None:
    """Float64 node positions of one pose's predictions (wrapped or clamped), into ``out``.

    Only values outside ``[0, Q)`` are wrapped (NumPy's remainder leaves the others alone), in a
    second pass: a remainder in the main loop would be evaluated for every value.
    """
    q = float(n_points)
    ceiling = q if periodic else q - 1.0  # wrap at >= Q, clamp above Q - 1
    outside = False
    for i in range(predictions.shape[0]):
        position = (float(predictions[i]) - low) * scale
        out[i] = position
        if position < 0.0 or position > ceiling or (periodic and position == ceiling):
            outside = True
    if not outside:
        return
    for i in range(out.shape[0]):
        value = float(out[i])
        if periodic:
            if value < 0.0 or value >= q:
                out[i] = value % q
        else:  # numpy.clip: the bound on ties
            value = value if value > 0.0 else 0.0
            out[i] = value if value < ceiling else ceiling


@kernel
def _assign(
    predictions: NDArray[np.floating], low: float, scale: float, n_points: int, periodic: bool
) -> tuple[NDArray[np.int64], FloatArray]:
    """``(nearest (P, N), stencil weights (P, N, 3))`` of predictions, in float64."""
    n_poses, n = predictions.shape
    nearest = np.empty((n_poses, n), dtype=np.int64)
    weights = np.empty((n_poses, n, 3))
    position = np.empty(n)
    for p in range(n_poses):
        _positions(predictions[p], low, scale, n_points, periodic, position)
        for i in range(n):
            node = math.floor(position[i] + 0.5)
            delta = position[i] - node
            if periodic and node >= n_points:
                node -= n_points
            nearest[p, i] = node
            half_sq = 0.5 * delta * delta
            weights[p, i, 0] = half_sq - 0.5 * delta
            weights[p, i, 1] = 1.0 - 2.0 * half_sq
            weights[p, i, 2] = half_sq + 0.5 * delta
    return nearest, weights


@kernel
def _fold(padded: FloatArray, periodic: bool) -> None:
    """Fold the guard rows, then the guard columns, of one ``(Q + 2)^2`` grid in place."""
    q = padded.shape[0] - 2
    low_into, high_into = (q, 1) if periodic else (1, q)
    for v in range(q + 2):
        padded[low_into, v] += padded[0, v]
        padded[high_into, v] += padded[q + 1, v]
    for u in range(q + 2):
        padded[u, low_into] += padded[u, 0]
        padded[u, high_into] += padded[u, q + 1]


@kernel
def _full_grid(
    nearest_a: NDArray[np.int64],
    weights_a: FloatArray,
    nearest_b: NDArray[np.int64],
    weights_b: FloatArray,
    particle_weights: FloatArray,
    n_points: int,
    periodic: bool,
) -> FloatArray:
    n_a, n = nearest_a.shape
    n_b = nearest_b.shape[0]
    q = n_points
    histograms = np.empty((n_a, n_b, q, q))
    padded = np.empty((q + 2, q + 2))
    for a in range(n_a):
        for b in range(n_b):
            padded[:] = 0.0
            for i in range(n):
                row, col = nearest_a[a, i], nearest_b[b, i]
                for u in range(3):
                    scaled = weights_a[a, i, u] * particle_weights[i]
                    for v in range(3):
                        padded[row + u, col + v] += scaled * weights_b[b, i, v]
            _fold(padded, periodic)
            for u in range(q):  # a loop, not a slice copy: numba's slice copy compiles its
                for v in range(q):  # shape-mismatch message (seconds of a first run)
                    histograms[a, b, u, v] = padded[u + 1, v + 1]
    return histograms


def full_grid_pair_histograms(
    predictions_a: NDArray[np.floating],
    predictions_b: NDArray[np.floating],
    particle_weights: FloatArray,
    low: float,
    spacing: float,
    n_points: int,
    periodic: bool,
) -> FloatArray:
    """``(C, M, Q, Q)`` full-grid stencil histograms of every pair (module docstring).

    Args:
        predictions_a: ``(C, N)`` float32 (or float64) noise-free observations of one side.
        predictions_b: ``(M, N)`` observations of the other side, of the same dtype.
        particle_weights: ``(N,)`` float64 normalised particle weights.
        low: Lower bound of the observation domain.
        spacing: Node spacing.
        n_points: ``Q``.
        periodic: Whether the observation wraps.

    Raises:
        TypeError, ValueError: An array of another dtype or shape (the message names it).
    """
    dtype = getattr(predictions_a, "dtype", None)
    dtype = np.float64 if dtype == np.float64 else np.float32
    predictions_a = require(predictions_a, "predictions_a", dtype, (None, None))
    n = predictions_a.shape[1]
    predictions_b = require(predictions_b, "predictions_b", dtype, (None, n))
    particle_weights = require(particle_weights, "particle_weights", np.float64, (n,))
    scale = 1.0 / spacing
    nearest_a, weights_a = _assign(predictions_a, float(low), scale, n_points, bool(periodic))
    nearest_b, weights_b = _assign(predictions_b, float(low), scale, n_points, bool(periodic))
    return _full_grid(  # type: ignore[no-any-return]
        nearest_a, weights_a, nearest_b, weights_b, particle_weights, n_points, bool(periodic)
    )


@kernel
def _windowed(
    targets_a: NDArray[np.int32],
    weights_a: NDArray[np.float32],
    rows_a: NDArray[np.int64],
    targets_b: NDArray[np.int32],
    weights_b: NDArray[np.float32],
    rows_b: NDArray[np.int64],
    particle_weights: FloatArray,
    width_a: int,
    width_b: int,
) -> tuple[NDArray[np.float32], bool]:
    """The window histograms and whether every window node lay inside its window (an entry
    outside is skipped, never written)."""
    n_a, n_b, n = rows_a.shape[0], rows_b.shape[0], particle_weights.shape[0]
    histograms = np.empty((n_a, n_b, width_a, width_b), dtype=np.float32)
    counts = np.empty((width_a, width_b))
    inside = True
    for a in range(n_a):
        row_a = rows_a[a]
        for b in range(n_b):
            row_b = rows_b[b]
            counts[:] = 0.0
            for i in range(n):
                for u in range(3):
                    scaled = np.float64(weights_a[row_a, i, u]) * particle_weights[i]
                    node_a = targets_a[row_a, i, u]
                    for v in range(3):
                        node_b = targets_b[row_b, i, v]
                        if node_a < 0 or node_a >= width_a or node_b < 0 or node_b >= width_b:
                            inside = False
                            continue
                        counts[node_a, node_b] += scaled * np.float64(weights_b[row_b, i, v])
            for u in range(width_a):
                for v in range(width_b):
                    histograms[a, b, u, v] = np.float32(counts[u, v])
    return histograms, inside


def windowed_scatter_histograms(
    targets_a: NDArray[np.int32],
    weights_a: NDArray[np.float32],
    targets_b: NDArray[np.int32],
    weights_b: NDArray[np.float32],
    particle_weights: FloatArray,
    width_a: int,
    width_b: int,
    rows_a: NDArray[np.integer] | None = None,
    rows_b: NDArray[np.integer] | None = None,
) -> NDArray[np.float32]:
    """``(C, M, W_a, W_b)`` float32 window histograms of every pair (module docstring).

    Args:
        targets_a: ``(P_a, N, 3)`` int32 window nodes of each stencil entry of one side, in
            ``[0, W_a)``.
        weights_a: ``(P_a, N, 3)`` float32 stencil weights.
        targets_b: ``(P_b, N, 3)`` int32 window nodes of the other side, in ``[0, W_b)``.
        weights_b: ``(P_b, N, 3)`` float32 stencil weights.
        particle_weights: ``(N,)`` float64 normalised particle weights.
        width_a, width_b: Window sizes ``W_a``, ``W_b``.
        rows_a, rows_b: The ``C`` and ``M`` poses of the two sides, rows of the arrays above
            (``None``: all rows).

    Raises:
        TypeError, ValueError: An array of another dtype or shape, or a target outside its
            window (the message names it).
    """
    targets_a = require(targets_a, "targets_a", np.int32, (None, None, 3))
    n = targets_a.shape[1]
    weights_a = require(weights_a, "weights_a", np.float32, targets_a.shape)
    targets_b = require(targets_b, "targets_b", np.int32, (None, n, 3))
    weights_b = require(weights_b, "weights_b", np.float32, targets_b.shape)
    particle_weights = require(particle_weights, "particle_weights", np.float64, (n,))
    selected_a = require_rows(rows_a, "rows_a", targets_a.shape[0])
    selected_b = require_rows(rows_b, "rows_b", targets_b.shape[0])
    histograms, inside = _windowed(
        targets_a,
        weights_a,
        selected_a,
        targets_b,
        weights_b,
        selected_b,
        particle_weights,
        int(width_a),
        int(width_b),
    )
    if not inside:
        raise ValueError(f"targets_a must lie in [0, {width_a}) and targets_b in [0, {width_b})")
    return histograms  # type: ignore[no-any-return]
