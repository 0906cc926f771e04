r"""Compiled stencil histograms of single observations (the ``fft`` estimator's ``k = 1`` grids).

For ``B`` poses with float32 noise-free predictions ``x_{b,n}`` and particle weights ``w_n``,
the grid position of a prediction is ``y = (x - low) / spacing`` in float32 (wrapped into
``[0, Q)`` on a periodic domain, clamped to ``[0, Q - 1]`` otherwise), its nearest node
``j = floor(y + 1/2)`` and its offset ``delta = y - j``. Three moment histograms

.. math::  h_m[b, j] = \sum_{n \to j} w_n \delta_{b,n}^m, \qquad m = 0, 1, 2

(``w_n = 1`` and a final factor ``1 / N`` for equal weights) give the three-point quadratic
stencil histogram (:mod:`~infoseek.planners.information.noise_kernel`)

.. math::  H[b, q] = (h_0 - h_2)[q] + \tfrac12 (h_2 + h_1)[q - 1] + \tfrac12 (h_2 - h_1)[q + 1].

Node ``Q`` (a prediction that rounds up to the seam, or past the last node) is folded onto node
``0`` (periodic) or ``Q - 1`` (clamped) before the stencil is formed; on a clamped grid the
stencil's overhang beyond either end stays on the end node.

The kernel makes one pass over the predictions of each pose and accumulates each moment in
particle order into a float64 histogram, exactly the sums the three ``numpy.bincount`` calls it
replaces formed (``bincount`` adds its weights sequentially in input order), with the same
float32 position arithmetic, so the histograms are the same bit for bit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.kernel_arrays import require, require_rows

__all__ = ["grid_positions", "single_stencil_histograms"]


@kernel
def grid_positions(
    predictions: NDArray[np.float32],
    low: np.float32,
    scale: np.float32,
    n_points: int,
    periodic: bool,
    out: NDArray[np.float32],
) -> None:
    """Fractional float32 node positions of one pose's predictions, into ``out``.

    ``(x - low) * scale``, then wrapped into ``[0, Q)`` (periodic; only values outside it
    change, as NumPy's remainder leaves the others alone) or clamped to ``[0, Q - 1]`` (values
    inside it are left as they are, as by ``numpy.clip``; ``-0.0`` keeps its sign, which no
    stencil weight or moment can see). The wrap or clamp is a second pass over the few rows
    that need it: a remainder in the main loop would be evaluated for every value.
    """
    q = np.float32(n_points)
    floor = np.float32(0.0)
    ceiling = q if periodic else q - np.float32(1.0)  # wrap at >= Q, clamp above Q - 1
    outside = False
    for i in range(predictions.shape[0]):
        position = (predictions[i] - low) * scale
        out[i] = position
        outside |= bool(position < floor) | bool(position > ceiling)
        outside |= periodic & bool(position == ceiling)
    if not outside:
        return
    if periodic:
        for i in range(out.shape[0]):
            if out[i] < floor or out[i] >= q:
                out[i] = out[i] % q
    else:  # numpy.clip: max(x, low) then min(x, high), the bound on ties
        for i in range(out.shape[0]):
            position = out[i] if out[i] > floor else floor
            out[i] = position if position < ceiling else ceiling


@kernel
def _add(row: FloatArray, position: np.float32, weight: float, uniform: bool) -> None:
    """Add one prediction at grid ``position`` to the moment histogram ``row``."""
    nearest = np.floor(position + np.float32(0.5))
    delta = position - nearest
    j = int(nearest)
    if uniform:
        row[j, 0] += 1.0
        row[j, 1] += np.float64(delta)
        row[j, 2] += np.float64(delta * delta)
    else:
        weighted = np.float64(delta) * weight
        row[j, 0] += weight
        row[j, 1] += weighted
        row[j, 2] += weighted * np.float64(delta)


@kernel
def _moments(
    predictions: NDArray[np.float32],
    rows: NDArray[np.int64],
    weights: FloatArray,
    uniform: bool,
    low: np.float32,
    scale: np.float32,
    n_points: int,
    periodic: bool,
) -> FloatArray:
    """``(B, Q + 1, 3)`` moment histograms of the predictions ``rows`` (node ``Q``: the seam or
    the overhang). Two poses are accumulated side by side (independent histograms, each in
    particle order), which keeps more additions in flight."""
    n_batch, n = rows.shape[0], predictions.shape[1]
    moments = np.zeros((n_batch, n_points + 1, 3))
    first = np.empty(n, dtype=np.float32)
    second = np.empty(n, dtype=np.float32)
    for b in range(0, n_batch, 2):
        grid_positions(predictions[rows[b]], low, scale, n_points, periodic, first)
        if b + 1 < n_batch:
            grid_positions(predictions[rows[b + 1]], low, scale, n_points, periodic, second)
            row_a, row_b = moments[b], moments[b + 1]
            for i in range(n):
                _add(row_a, first[i], weights[i], uniform)
                _add(row_b, second[i], weights[i], uniform)
        else:
            row_a = moments[b]
            for i in range(n):
                _add(row_a, first[i], weights[i], uniform)
    if uniform:
        inverse = 1.0 / n
        for b in range(n_batch):
            for j in range(n_points + 1):
                for m in range(3):
                    moments[b, j, m] = moments[b, j, m] * inverse
    return moments


@kernel
def _stencil_histograms(moments: FloatArray, periodic: bool) -> FloatArray:
    """Fold node ``Q`` back and spread the moments with the quadratic stencil."""
    n_batch, width = moments.shape[:2]
    q = width - 1
    fold = 0 if periodic else q - 1
    histogram = np.empty((n_batch, q))
    centre = np.empty(q)
    up = np.empty(q)
    down = np.empty(q)
    for b in range(n_batch):
        for m in range(3):
            moments[b, fold, m] += moments[b, q, m]
        for j in range(q):
            mass, first, second = moments[b, j, 0], moments[b, j, 1], moments[b, j, 2]
            centre[j] = mass - second
            up[j] = 0.5 * (second + first)  # to node j + 1
            down[j] = 0.5 * (second - first)  # to node j - 1
        if periodic:
            for j in range(q):
                histogram[b, j] = (centre[j] + up[(j - 1) % q]) + down[(j + 1) % q]
        else:
            for j in range(q):
                value = centre[j]
                if j >= 1:
                    value += up[j - 1]
                if j == q - 1:
                    value += up[q - 1]  # the overhang stays on the edge node
                if j < q - 1:
                    value += down[j + 1]
                if j == 0:
                    value += down[0]
                histogram[b, j] = value
    return histogram


def single_stencil_histograms(
    predictions: NDArray[np.float32],
    weights: FloatArray,
    uniform: bool,
    low: float,
    spacing: float,
    n_points: int,
    periodic: bool,
    rows: NDArray[np.integer] | None = None,
) -> FloatArray:
    """``(B, Q)`` stencil histograms of float32 predictions (module docstring).

    Args:
        predictions: ``(P, N)`` float32 noise-free observations.
        weights: ``(N,)`` float64 normalised particle weights.
        uniform: Whether all weights are equal (then ``1 / N`` replaces them).
        low: Lower bound of the observation domain.
        spacing: Node spacing.
        n_points: ``Q``.
        periodic: Whether the observation wraps.
        rows: ``(B,)`` rows of ``predictions`` to histogram (``None``: all, ``B = P``).

    Raises:
        TypeError, ValueError: An array of another dtype or shape (the message names it).
    """
    predictions = require(predictions, "predictions", np.float32, (None, None))
    selected = require_rows(rows, "rows", predictions.shape[0])
    weights = require(weights, "weights", np.float64, (predictions.shape[1],))
    if not (isinstance(n_points, int) and n_points >= 2):
        raise ValueError(f"n_points must be an integer >= 2, got {n_points!r}")
    scale = np.float32(1.0 / spacing)
    moments = _moments(
        predictions,
        selected,
        weights,
        bool(uniform),
        np.float32(low),
        scale,
        n_points,
        bool(periodic),
    )
    return _stencil_histograms(moments, bool(periodic))  # type: ignore[no-any-return]
