r"""Sorting and selection for the adaptive entropy grid, compiled.

* :func:`stable_argsort`: the permutation that sorts float64 values ascending with ties in
  their original order, which is unique (it is what ``numpy.argsort(kind="stable")`` returns
  for values without NaN). It is computed by a least-significant-digit radix sort of the
  values' IEEE bit patterns, mapped to unsigned integers in the order of the values (negative
  values: all bits flipped; others: the sign bit set), eleven bits per pass. A radix sort is
  stable by construction and costs ``O(N)`` per pass; passes in which every key has the same
  digit are skipped. ``-0.0`` is keyed as ``+0.0`` (they compare equal).
* :func:`order_statistic_pair`: the ``i``-th and ``j``-th smallest values (0-based), by one
  scan keeping the few smallest and largest values when both ranks are near an end of the
  sample (as the weighted ``0.1 %`` and ``99.9 %`` quantiles of equally weighted particles
  are), by selection otherwise. Order statistics are values, so any algorithm gives the same
  result.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["order_statistic_pair", "stable_argsort"]

_DIGIT_BITS = 11
_BUCKETS = 1 << _DIGIT_BITS
_PASSES = 6  # ceil(64 / 11)
#: Ranks this close to an end of the sample are found by one scan with a small buffer.
_SCAN_RANKS = 32


@kernel
def _sort_keys(values: FloatArray) -> NDArray[np.uint64]:
    bits = values.view(np.uint64)
    keys = np.empty(values.shape[0], dtype=np.uint64)
    sign = np.uint64(1) << np.uint64(63)
    for i in range(values.shape[0]):
        b = bits[i]
        if b == sign:  # -0.0 ties with +0.0, as in NumPy's comparison
            b = np.uint64(0)
        keys[i] = ~b if b & sign else b | sign
    return keys


@kernel
def stable_argsort(values: FloatArray) -> IntArray:
    """Indices that sort ``values`` (1-D, contiguous, no NaN) ascending, ties in index order."""
    n = values.shape[0]
    keys = _sort_keys(values)
    order = np.arange(n)
    spare = np.empty(n, dtype=np.int64)
    counts = np.empty(_BUCKETS, dtype=np.int64)
    mask = np.uint64(_BUCKETS - 1)
    for p in range(_PASSES):
        shift = np.uint64(p * _DIGIT_BITS)
        counts[:] = 0
        for i in range(n):
            counts[(keys[i] >> shift) & mask] += 1
        if n == 0 or counts[(keys[0] >> shift) & mask] == n:
            continue  # every key has this digit: the pass would not move anything
        start = 0
        for b in range(_BUCKETS):
            c = counts[b]
            counts[b] = start
            start += c
        for i in range(n):
            index = order[i]
            digit = (keys[index] >> shift) & mask
            spare[counts[digit]] = index
            counts[digit] += 1
        order, spare = spare, order
    return order


@kernel
def _insert_low(buffer: FloatArray, size: int, value: float) -> None:
    """Keep ``buffer[:size]`` the ``size`` smallest values seen, ascending."""
    if value >= buffer[size - 1]:
        return
    i = size - 1
    while i > 0 and buffer[i - 1] > value:
        buffer[i] = buffer[i - 1]
        i -= 1
    buffer[i] = value


@kernel
def _select(values: FloatArray, rank: int) -> float:
    """The ``rank``-th smallest of ``values`` (0-based; ``values`` is reordered): Hoare's
    selection with the median of three as pivot."""
    left, right = 0, values.shape[0] - 1
    while right > left:
        middle = (left + right) // 2
        a, b, c = values[left], values[middle], values[right]
        pivot = max(min(a, b), min(max(a, b), c))
        i, j = left, right
        while i <= j:
            while values[i] < pivot:
                i += 1
            while values[j] > pivot:
                j -= 1
            if i <= j:
                values[i], values[j] = values[j], values[i]
                i += 1
                j -= 1
        if rank <= j:
            right = j
        elif rank >= i:
            left = i
        else:
            break
    return values[rank]


@kernel
def order_statistic_pair(values: FloatArray, low: int, high: int) -> tuple[float, float]:
    """The ``low``-th and ``high``-th smallest of ``values`` (0-based, ``low <= high``)."""
    n = values.shape[0]
    top = n - 1 - high  # rank of the high one counted from the largest
    if low >= _SCAN_RANKS or top >= _SCAN_RANKS or n < 2 * _SCAN_RANKS:
        return _select(values.copy(), low), _select(values.copy(), high)
    smallest = np.full(low + 1, np.inf)
    largest = np.full(top + 1, np.inf)  # negated: the smallest of -values
    for i in range(n):
        _insert_low(smallest, low + 1, values[i])
        _insert_low(largest, top + 1, -values[i])
    return smallest[low], -largest[top]
