r"""Compiled window stencils of the ``fft`` estimator's windowed pair grids.

:mod:`~infoseek.planners.information.windows` gives each pose a window of ``W_p`` nodes starting
at integer node ``s_p`` and relabels every three-point stencil into it. Per pose ``p`` with
float32 grid positions ``y_n`` (wrapped into ``[0, Q)`` or clamped):

* periodic: ``d_n = y_n - y_1`` wrapped into ``[-Q/2, Q/2)`` (float32),
  ``s_p = floor(float64(min_n d_n) + y_1) - 1``, ``r_n = y_n - s_p`` wrapped into ``[0, Q)``,
  nearest window node ``j_n = floor(r_n + 1/2)``, offset ``delta_n = r_n - j_n``; a pose whose
  lowest stencil would reach node ``-1`` (some ``j_n = 0``) moves its window one node down;
* clamped: ``j_n = floor(y_n + 1/2)``, ``delta_n = y_n - j_n``, ``s_p = max(min_n j_n - 1, 0)``
  and the stencil nodes ``min(max(j_n + u, 0), Q - 1) - s_p``.

The stencil weights are the float32 quadratic weights of ``delta`` and ``W_p`` is one more than
the largest window node. :func:`stencil_matrices` spreads the stencils of a pose set into the
dense ``(P W, N)`` float32 matrices the pair histograms are matrix products of (row
``p W + x``: the weight of every particle at window node ``x`` of pose ``p``; where two stencil
entries of a particle share a node at a clamped edge the last one is kept, as the NumPy
assignment it replaces kept it). Every operation is the float32 (or float64) operation of the
NumPy code it replaces, in the same order, so the stencils are the same bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.planners.information.kernel_arrays import require, require_rows
from infoseek.planners.information.moment_histograms import grid_positions

__all__ = ["pose_windows", "stencil_matrices"]


@kernel
def _lowest_deviation(
    position: NDArray[np.float32], first: np.float32, half: np.float32, period: np.float32
) -> np.float32:
    """``min_n d_n`` of the deviations from the first position wrapped into ``[-Q/2, Q/2)``.

    Kept as eight running minima (a minimum is exact in any order, so this is the minimum
    NumPy's reduction found; only the sign of a zero could differ, which the sum it enters
    cannot see).
    """
    n = position.shape[0]
    lanes = np.full(8, np.inf, dtype=np.float32)
    i = 0
    while i + 8 <= n:
        for k in range(8):
            deviation = position[i + k] - first
            deviation = deviation + period if deviation < -half else deviation
            deviation = deviation - period if deviation >= half else deviation
            lanes[k] = deviation if deviation < lanes[k] else lanes[k]
        i += 8
    lowest = np.float32(np.inf)
    for k in range(8):
        lowest = lanes[k] if lanes[k] < lowest else lowest
    for j in range(i, n):
        deviation = position[j] - first
        deviation = deviation + period if deviation < -half else deviation
        deviation = deviation - period if deviation >= half else deviation
        lowest = deviation if deviation < lowest else lowest
    return lowest


@kernel
def _periodic_nodes(
    position: NDArray[np.float32],
    origin: np.float32,
    period: np.float32,
    nodes: NDArray[np.int32],
    deltas: NDArray[np.float32],
) -> int:
    """Nearest window nodes and offsets of positions relative to ``origin`` (wrapped into
    ``[0, Q)``); returns the lowest node."""
    half = np.float32(0.5)
    for i in range(position.shape[0]):
        relative = position[i] - origin
        relative = relative + period if relative < np.float32(0.0) else relative
        relative = relative - period if relative >= period else relative
        nearest = np.floor(relative + half)
        nodes[i] = np.int32(nearest)
        deltas[i] = relative - nearest
    lowest = int(nodes[0])
    for i in range(nodes.shape[0]):
        lowest = min(lowest, int(nodes[i]))
    return lowest


@kernel
def _fill(
    nodes: NDArray[np.int32],
    deltas: NDArray[np.float32],
    shift: int,
    low_edge: int,
    high_edge: int,
    targets: NDArray[np.int32],
    weights: NDArray[np.float32],
) -> int:
    """Targets ``min(max(j + u, low_edge), high_edge) + shift`` (``u = -1, 0, 1``) and the
    float32 quadratic weights of the offsets; returns the largest target."""
    half = np.float32(0.5)
    widest = 0
    for i in range(nodes.shape[0]):
        node = int(nodes[i])
        for u in range(3):
            target = min(max(node + u - 1, low_edge), high_edge) + shift
            targets[i, u] = target
            widest = max(widest, target)
        delta = deltas[i]
        half_sq = half * delta * delta
        weights[i, 0] = half_sq - half * delta
        weights[i, 1] = np.float32(1.0) - np.float32(2.0) * half_sq
        weights[i, 2] = half_sq + half * delta
    return widest


@kernel
def _windows(
    predictions: NDArray[np.float32],
    rows: NDArray[np.int64],
    low: np.float32,
    scale: np.float32,
    n_points: int,
    periodic: bool,
) -> tuple[NDArray[np.int64], NDArray[np.int32], NDArray[np.float32], NDArray[np.int64]]:
    n_poses, n = rows.shape[0], predictions.shape[1]
    start = np.empty(n_poses, dtype=np.int64)
    width = np.empty(n_poses, dtype=np.int64)
    targets = np.empty((n_poses, n, 3), dtype=np.int32)
    weights = np.empty((n_poses, n, 3), dtype=np.float32)
    position = np.empty(n, dtype=np.float32)
    nodes = np.empty(n, dtype=np.int32)
    deltas = np.empty(n, dtype=np.float32)
    period = np.float32(n_points)
    half = np.float32(0.5)
    unbounded = n_points + 3  # no clamping of periodic window nodes
    for p in range(n_poses):
        grid_positions(predictions[rows[p]], low, scale, n_points, periodic, position)
        if periodic:
            first = position[0]
            lowest = _lowest_deviation(position, first, half * period, period)
            origin = math.floor(np.float64(lowest) + np.float64(first)) - 1
            lowest_node = _periodic_nodes(position, np.float32(origin), period, nodes, deltas)
            # a stencil reaching node -1: move the window one node down
            shift = 1 if lowest_node == 0 else 0
            start[p] = origin - shift
            widest = _fill(nodes, deltas, shift, -unbounded, unbounded, targets[p], weights[p])
        else:
            lowest_node = n_points
            for i in range(n):
                nearest = np.floor(position[i] + half)
                nodes[i] = np.int32(nearest)
                deltas[i] = position[i] - nearest
                lowest_node = min(lowest_node, int(nodes[i]))
            start[p] = max(lowest_node - 1, 0)
            zero = np.int64(0)  # not a literal: one compiled signature of _fill
            widest = _fill(
                nodes,
                deltas,
                -start[p],
                zero,  # type: ignore[arg-type]
                n_points - 1,
                targets[p],
                weights[p],
            )
        width[p] = widest + 1
    return start, targets, weights, width


def pose_windows(
    predictions: NDArray[np.float32],
    low: float,
    spacing: float,
    n_points: int,
    periodic: bool,
    rows: NDArray[np.integer] | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.int32], NDArray[np.float32], NDArray[np.int64]]:
    """Window stencils of float32 predictions (module docstring).

    Args:
        predictions: ``(P, N)`` float32 noise-free observations.
        low: Lower bound of the observation domain.
        spacing: Node spacing.
        n_points: ``Q``.
        periodic: Whether the observation wraps.
        rows: ``(B,)`` rows of ``predictions`` (``None``: all, ``B = P``).

    Returns:
        ``(start (B,), targets (B, N, 3) int32, weights (B, N, 3) float32, width (B,))``.

    Raises:
        TypeError, ValueError: ``predictions`` or ``rows`` of another dtype or shape.
    """
    predictions = require(predictions, "predictions", np.float32, (None, None))
    if predictions.shape[1] == 0:
        raise ValueError("predictions must have at least one particle")
    selected = require_rows(rows, "rows", predictions.shape[0])
    return _windows(  # type: ignore[no-any-return]
        predictions,
        selected,
        np.float32(low),
        np.float32(1.0 / spacing),
        int(n_points),
        bool(periodic),
    )


@kernel
def _dense(
    targets: NDArray[np.int32], weights: NDArray[np.float32], rows: NDArray[np.int64], width: int
) -> tuple[NDArray[np.float32], bool]:
    """The dense matrices and whether every window node lay in ``[0, width)`` (a node outside
    is skipped, never written)."""
    n_poses, n = rows.shape[0], targets.shape[1]
    dense = np.zeros((n_poses * width, n), dtype=np.float32)
    inside = True
    for p in range(n_poses):
        row = rows[p]
        for i in range(n):
            for u in range(3):
                node = targets[row, i, u]
                if node < 0 or node >= width:
                    inside = False
                    continue
                dense[p * width + node, i] = weights[row, i, u]
    return dense, inside


def stencil_matrices(
    targets: NDArray[np.int32],
    weights: NDArray[np.float32],
    width: int,
    rows: NDArray[np.integer] | None = None,
) -> NDArray[np.float32]:
    """Dense ``(B W, N)`` float32 stencil matrices of a pose set (module docstring).

    Args:
        targets: ``(P, N, 3)`` int32 window nodes.
        weights: ``(P, N, 3)`` float32 stencil weights.
        width: Rows per pose ``W``.
        rows: ``(B,)`` poses of the set, rows of ``targets`` (``None``: all, ``B = P``); their
            window nodes must lie in ``[0, width)``.

    Raises:
        TypeError, ValueError: An array of another dtype or shape, or a node outside the window.
    """
    targets = require(targets, "targets", np.int32, (None, None, 3))
    weights = require(weights, "weights", np.float32, targets.shape)
    selected = require_rows(rows, "rows", targets.shape[0])
    dense, inside = _dense(targets, weights, selected, int(width))
    if not inside:
        raise ValueError(f"targets must lie in [0, {width})")
    return dense  # type: ignore[no-any-return]
