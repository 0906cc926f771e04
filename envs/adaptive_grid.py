r"""The adaptive-grid histogram entropy of ``K`` beliefs, compiled (the estimator is documented in
:mod:`infoseek.envs.entropy`).

One call handles every row; per row and coordinate the kernel

1. scales the particles to ``[0, 1)`` by the domain widths and unrolls a periodic coordinate at
   the largest gap between its sorted values;
2. finds the weighted ``TAIL`` and ``1 - TAIL`` quantiles: for equal weights the order
   statistics at the ranks where the running sum of the weights reaches those fractions
   (a selection, no sort), otherwise the values at which the running sum of the weights in
   ascending (stable) order reaches them;
3. cuts the box into ``ESS / PARTICLES_PER_CELL`` near-cubic cells, accumulates the weights
   per cell in particle order, and returns the plug-in entropy with the cell volume and the
   Miller-Madow term added.

The arithmetic is that of the NumPy form it replaced (running sums in order, NumPy's pairwise
sum, ``ESS = 1 / dot(w, w)`` and the plug-in ``dot(P, log P)`` through BLAS, the C library's
``log`` and ``pow``), so the entropies are the same bit for bit in the pinned numerical
environment.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum
from infoseek.envs.log_weights import is_uniform
from infoseek.envs.order_statistics import order_statistic_pair, stable_argsort

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

__all__ = ["adaptive_entropies", "plug_in_entropy"]


@kernel
def plug_in_entropy(mass: FloatArray) -> tuple[float, int]:
    """``-sum P_c log P_c`` of the non-empty cells of ``mass`` renormalised to ``P``, and the
    number of non-empty cells."""
    occupied = 0
    for value in mass:
        if value > 0:
            occupied += 1
    cells = np.empty(occupied)
    c = 0
    for value in mass:
        if value > 0:
            cells[c] = value
            c += 1
    total = pairwise_sum(cells)
    logs = np.empty(occupied)
    for c in range(occupied):
        cells[c] = cells[c] / total
        logs[c] = math.log(cells[c])
    return -np.dot(cells, logs), occupied


@kernel
def _first_reaching(cumulative: FloatArray, fraction: float) -> int:
    """Index of the first running sum ``>= fraction * total`` (0 if none), at most ``n - 1``."""
    n = cumulative.shape[0]
    threshold = fraction * cumulative[n - 1]
    for i in range(n):
        if cumulative[i] >= threshold:
            return min(i, n - 1)
    return 0


@kernel
def _equal_weight_ranks(n: int, weight: float, tail: float) -> tuple[int, int]:
    cumulative = np.empty(n)
    running = 0.0
    for i in range(n):
        running += weight
        cumulative[i] = running
    return _first_reaching(cumulative, tail), _first_reaching(cumulative, 1.0 - tail)


@kernel
def _unroll(column: FloatArray) -> None:
    """Shift angles in ``[0, 1)`` so that the largest gap between them is at the wrap."""
    n = column.shape[0]
    order = stable_argsort(column)
    ordered = np.empty(n)
    for i in range(n):
        ordered[i] = column[order[i]]
    best, first = -math.inf, 0
    for i in range(n):
        gap = (ordered[i + 1] if i + 1 < n else ordered[0] + 1.0) - ordered[i]
        if gap > best:
            best, first = gap, (i + 1) % n
    start = ordered[first]
    for i in range(n):
        column[i] = (column[i] - start) % 1.0


@kernel
def _box(
    column: FloatArray, weights: FloatArray, ranks: tuple[int, int], tail: float
) -> tuple[float, float]:
    """Weighted ``tail`` and ``1 - tail`` quantiles of one scaled coordinate (``ranks``: those
    of equal weights, ``(-1, -1)`` for unequal ones)."""
    if ranks[0] >= 0:
        return order_statistic_pair(column, ranks[0], ranks[1])
    order = stable_argsort(column)
    cumulative = np.empty(column.shape[0])
    running = 0.0
    for i in range(order.shape[0]):
        running += weights[order[i]]
        cumulative[i] = running
    low_k = _first_reaching(cumulative, tail)
    high_k = _first_reaching(cumulative, 1.0 - tail)
    return column[order[low_k]], column[order[high_k]]


@kernel
def _row_entropy(
    scaled: FloatArray,
    weights: FloatArray,
    log_width: FloatArray,
    ranks: tuple[int, int],
    settings: tuple[float, float, float],
) -> float:
    """Entropy of one belief from its ``(d, N)`` scaled coordinates (module docstring);
    ``ranks`` are the quantile ranks of equal weights, ``(-1, -1)`` for unequal weights."""
    tail, box_floor, per_cell = settings
    d, n = scaled.shape
    box_low, side = np.empty(d), np.empty(d)
    for j in range(d):
        low, high = _box(scaled[j], weights, ranks, tail)
        box_low[j], side[j] = low, max(high - low, box_floor)
    ess = 1.0 / np.dot(weights, weights)
    volume = 1.0
    for j in range(d):
        volume *= side[j]
    cube = (volume / max(1.0, ess / per_cell)) ** (1.0 / d)
    bins = np.empty(d, dtype=np.int64)
    cells = 1
    for j in range(d):
        bins[j] = max(1, int(np.rint(side[j] / cube)))
        cells *= bins[j]
    per_side = np.empty(d)  # bins / side, divided once (the same quotient in every cell index)
    for j in range(d):
        per_side[j] = bins[j] / side[j]
    mass = np.zeros(cells)
    for i in range(n):
        flat = 0
        for j in range(d):
            cell = int(math.floor((scaled[j, i] - box_low[j]) * per_side[j]))
            flat = flat * bins[j] + min(max(cell, 0), bins[j] - 1)
        mass[flat] += weights[i]
    plug_in, occupied = plug_in_entropy(mass)
    log_cell_volume = 0.0
    for j in range(d):
        log_cell_volume += math.log(side[j] / bins[j]) + log_width[j]
    return plug_in + log_cell_volume + (occupied - 1) / (2.0 * ess)


@kernel
def _adaptive_entropies(
    particles: FloatArray,
    weights: FloatArray,
    low: FloatArray,
    width: FloatArray,
    periodic: BoolArray,
    settings: tuple[float, float, float],
) -> FloatArray:
    k_rows, n, d = particles.shape
    log_width = np.empty(d)
    for j in range(d):
        log_width[j] = math.log(width[j])
    out = np.empty(k_rows)
    scaled = np.empty((d, n))
    ranks_weight, ranks = math.nan, (0, 0)
    for k in range(k_rows):
        equal = is_uniform(weights[k])
        for j in range(d):
            for i in range(n):
                scaled[j, i] = (particles[k, i, j] - low[j]) / width[j]
            if periodic[j]:
                for i in range(n):
                    scaled[j, i] = scaled[j, i] % 1.0
                _unroll(scaled[j])
        if equal and weights[k, 0] != ranks_weight:  # these ranks depend on N and the weight
            ranks_weight = weights[k, 0]
            ranks = _equal_weight_ranks(n, ranks_weight, settings[0])
        row_ranks = ranks if equal else (-1, -1)
        out[k] = _row_entropy(scaled, weights[k], log_width, row_ranks, settings)
    return out


def adaptive_entropies(
    particles: FloatArray,
    weights: FloatArray,
    low: FloatArray,
    width: FloatArray,
    periodic: BoolArray,
    settings: tuple[float, float, float],
) -> FloatArray:
    """``(K,)`` adaptive-grid entropies of ``(K, N, d)`` particles with ``(K, N)`` normalised
    weights in the box ``[low, low + width]`` (``periodic`` coordinates wrap);
    ``settings = (TAIL, BOX_FLOOR, PARTICLES_PER_CELL)``."""
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    weights = np.ascontiguousarray(weights, dtype=np.float64)
    if particles.ndim != 3 or weights.shape != particles.shape[:2]:
        raise ValueError(
            f"particles must be (K, N, d) and weights (K, N), got {particles.shape} and "
            f"{weights.shape}"
        )
    return _adaptive_entropies(  # type: ignore[no-any-return]
        particles,
        weights,
        np.ascontiguousarray(low, dtype=np.float64),
        np.ascontiguousarray(width, dtype=np.float64),
        np.ascontiguousarray(periodic, dtype=np.bool_),
        settings,
    )
