r"""Compiled lookups of the horizon bound's pair terms ``log rho`` (the affinity table).

:class:`~infoseek.planners.horizon_information.HorizonInformation` evaluates, for the noise-free
predictions :math:`h_{k,n}` of particle :math:`n` at pose :math:`k`, the pair terms

.. math::  \ell_k(n, m) = \log \rho(\operatorname{wrap}(h_{k,n} - h_{k,m}))

by linear interpolation in a table :math:`T` of :math:`\log \rho` on the grid
:math:`\delta_j = \delta_0 + j s` (``j = 0 .. J-1``): with the table position
:math:`q = \min(\max((\delta - \delta_0) / s, 0), J - 1 - 10^{-9})`,
:math:`j = \lfloor q \rfloor` and :math:`f = q - j`,
:math:`\log \rho(\delta) \approx T_j + f (T_{j+1} - T_j)`. On a periodic observation of period
:math:`P` the difference is first wrapped to :math:`[-P/2, P/2)`:
:math:`\operatorname{wrap}(\delta) = ((\delta + P/2) \bmod P) - P/2` with NumPy's floored
``mod`` (the result has the sign of :math:`P`, ``+0.0`` for a zero remainder).

* :func:`log_affinity` looks up any array of differences;
* :func:`pair_term_sums` gives :math:`S_g(n, m) = \sum_{t} \ell_{g,t}(n, m)` of ``G`` groups
  of ``H`` poses (a control sequence's ``H`` poses), summed over ``t`` in order
  (``((l_0 + l_1) + l_2) + ...``, as NumPy's sum over a leading axis), without the
  ``(G, H, N, N)`` temporaries. One row :math:`n` at a time: the table positions of the ``N``
  differences split into ``j`` and ``f`` (a loop the compiler vectorises), then the ``N``
  interpolations added to the row, from a table of pairs :math:`(T_j, T_{j+1} - T_j)` (the
  slope is the difference the NumPy code took at every lookup, taken once). A group whose
  first pose's predictions equal those of the last first pose looked up reuses its terms
  (equal inputs, equal bits): the receding-horizon sequences that start with the same control.

Every value is the one of the NumPy expressions these kernels replace, bit for bit (there are no
transcendental functions here, so in any numerical environment): the same operations in the
same order, the ``mod`` as NumPy's ``npy_divmod`` (C ``fmod``, then ``+P`` for a negative
remainder, ``+0.0`` for a zero one). When the predictions of a pose span at most ``P`` (always
for predictions inside the observation domain), every ``x = delta + P/2`` lies in
``[-P/2, 3P/2]`` and the remainder is ``x + P`` (``x < 0``), ``x + 0.0`` or ``x - P``
(``x >= P``, exact by Sterbenz's lemma as ``fmod``); otherwise ``fmod`` is called.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.int32]

__all__ = ["AffinityTable", "log_affinity", "pair_term_sums"]

#: How :func:`_positions` wraps the differences: not at all, by the exact shift (predictions
#: spanning at most one period), through ``fmod``.
_NO_WRAP, _SHIFT_WRAP, _FMOD_WRAP = 0, 1, 2


class AffinityTable:
    """The interpolation table of ``log rho`` and its grid, as the kernels take it.

    Args:
        table: ``(J,)`` float64 values of ``log rho`` on the grid, ``J >= 2``.
        delta0: First grid point ``delta_0``.
        step: Grid spacing ``s > 0``.
        period: Observation period ``P`` (periodic observations), or ``None``.

    Raises:
        ValueError: A table that is not ``(J >= 2,)`` float64 and finite, or a non-positive
            ``step`` / ``period``.
    """

    def __init__(self, table: FloatArray, delta0: float, step: float, period: float | None) -> None:
        table = np.ascontiguousarray(table)
        if table.dtype != np.float64 or table.ndim != 1 or table.size < 2:
            raise ValueError(f"table must be (J >= 2,) float64, got {table.dtype} {table.shape}")
        if not np.all(np.isfinite(table)):
            raise ValueError("table must be finite")
        if table.size > np.iinfo(np.int32).max:
            raise ValueError(f"table has {table.size} points, more than int32 positions")
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f"step must be finite and > 0, got {step}")
        if period is not None and not (math.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0, got {period}")
        self.table = table
        #: ``(J, 2)`` ``(T_j, T_{j+1} - T_j)`` (the last slope, never used, 0).
        self.pairs = np.ascontiguousarray(np.stack([table, np.append(np.diff(table), 0.0)], 1))
        self.delta0 = float(delta0)
        self.step = float(step)
        self.periodic = period is not None
        self.period = float(period) if period is not None else 0.0
        #: ``P / 2``, added before and subtracted after the ``mod``.
        self.half = 0.5 * self.period
        #: Largest table position, ``J - 1 - 1e-9`` (the clip of the NumPy code).
        self.upper = (table.size - 1) - 1e-9

    def arguments(self) -> tuple[FloatArray, float, float, float, float, float]:
        """``(pairs, delta0, step, half, period, upper)`` in the kernels' argument order."""
        return self.pairs, self.delta0, self.step, self.half, self.period, self.upper


@kernel
def _floored_mod(x: float, period: float) -> float:
    """NumPy's ``np.mod(x, period)`` for ``period > 0`` (the remainder of ``npy_divmod``)."""
    mod = np.fmod(x, period)  # exact: the remainder of the truncated division
    if mod != 0.0:
        if mod < 0.0:
            mod += period
    else:
        mod = 0.0
    return mod


@kernel
def _store_position(
    index: IndexArray, fraction: FloatArray, m: int, position: float, upper: float
) -> None:
    """``index[m], fraction[m] = j, f`` of the position clipped as ``np.clip(position, 0,
    upper)`` (NumPy's maximum with 0 first: ``-0.0`` becomes ``+0.0``)."""
    position = position if position > 0.0 else 0.0
    position = position if position < upper else upper
    j = np.int32(position)  # truncation, as astype(intp) of a non-negative position
    index[m] = j
    fraction[m] = position - j


@kernel
def _positions(
    index: IndexArray,
    fraction: FloatArray,
    anchor: float,
    predictions: FloatArray,
    wrap: int,
    delta0: float,
    step: float,
    half: float,
    period: float,
    upper: float,
) -> None:
    """The table position ``j + f`` of ``anchor - predictions[m]`` for every ``m`` (module
    docstring), as ``index[m] = j`` and ``fraction[m] = f``."""
    if wrap == _SHIFT_WRAP:
        for m in range(index.shape[0]):
            x = (anchor - predictions[m]) + half
            shift = period if x < 0.0 else (-period if x >= period else 0.0)
            _store_position(index, fraction, m, (((x + shift) - half) - delta0) / step, upper)
    elif wrap == _FMOD_WRAP:
        for m in range(index.shape[0]):
            delta = _floored_mod((anchor - predictions[m]) + half, period) - half
            _store_position(index, fraction, m, (delta - delta0) / step, upper)
    else:
        for m in range(index.shape[0]):
            _store_position(index, fraction, m, ((anchor - predictions[m]) - delta0) / step, upper)


@kernel
def _interpolate(
    row: FloatArray, index: IndexArray, fraction: FloatArray, pairs: FloatArray, add: bool
) -> None:
    """``row[m] (+)= T_j + f (T_{j+1} - T_j)`` at ``j, f = index[m], fraction[m]``, with
    ``pairs[j] = (T_j, T_{j+1} - T_j)``."""
    for m in range(row.shape[0]):
        j = index[m]
        value = pairs[j, 0] + fraction[m] * pairs[j, 1]
        row[m] = row[m] + value if add else value


@kernel
def _wrap_mode(predictions: FloatArray, periodic: bool, period: float) -> int:
    """How to wrap the differences of one pose's predictions (see :func:`_positions`)."""
    if not periodic or predictions.shape[0] == 0:
        return _NO_WRAP
    low = high = predictions[0]
    for m in range(1, predictions.shape[0]):
        low = min(low, predictions[m])
        high = max(high, predictions[m])
    return _SHIFT_WRAP if high - low <= period else _FMOD_WRAP


@kernel
def _equal(a: FloatArray, b: FloatArray) -> bool:
    """Whether two equally long rows compare equal element by element."""
    for m in range(a.shape[0]):
        if a[m] != b[m]:
            return False
    return True


@kernel
def _pair_term_sums(
    predictions: FloatArray,
    periodic: bool,
    pairs: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    upper: float,
) -> FloatArray:
    n_groups, horizon, n = predictions.shape
    out = np.empty((n_groups, n, n))
    first = np.empty((n, n))  # the first pose's terms of the latest group that computed them
    index = np.empty(n, dtype=np.int32)
    fraction = np.empty(n)
    cached = -1
    for g in range(n_groups):
        head = predictions[g, 0]
        if cached < 0 or not _equal(head, predictions[cached, 0]):
            wrap = _wrap_mode(head, periodic, period)
            for i in range(n):
                _positions(index, fraction, head[i], head, wrap, delta0, step, half, period, upper)
                _interpolate(first[i], index, fraction, pairs, False)
            cached = g
        for i in range(n):
            for m in range(n):
                out[g, i, m] = first[i, m]
        for t in range(1, horizon):
            pose = predictions[g, t]
            wrap = _wrap_mode(pose, periodic, period)
            for i in range(n):
                _positions(index, fraction, pose[i], pose, wrap, delta0, step, half, period, upper)
                _interpolate(out[g, i], index, fraction, pairs, True)
    return out


def pair_term_sums(predictions: FloatArray, affinity: AffinityTable) -> FloatArray:
    """``(G, N, N)`` sums over ``t`` of ``log rho(h[g, t, n] - h[g, t, m])`` (module docstring).

    Args:
        predictions: ``(G, H, N)`` float64 noise-free predictions, finite, ``H >= 1``.
        affinity: The table.

    Raises:
        TypeError: ``predictions`` is not float64, ``affinity`` not an :class:`AffinityTable`.
        ValueError: Wrong shape or non-finite values.
    """
    values = _finite_float64(predictions, "predictions")
    if values.ndim != 3 or values.shape[1] < 1:
        raise ValueError(f"predictions must be (G, H >= 1, N), got {values.shape}")
    checked = _checked_table(affinity)
    return _pair_term_sums(np.ascontiguousarray(values), checked.periodic, *checked.arguments())


@kernel
def _log_affinity(
    delta: FloatArray,
    periodic: bool,
    pairs: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    upper: float,
) -> FloatArray:
    out = np.empty_like(delta)
    index = np.empty(delta.shape[0], dtype=np.int32)
    fraction = np.empty_like(delta)
    for k in range(delta.shape[0]):
        value = delta[k]
        if periodic:
            value = _floored_mod(value + half, period) - half
        _store_position(index, fraction, k, (value - delta0) / step, upper)
    _interpolate(out, index, fraction, pairs, False)
    return out


def log_affinity(delta: FloatArray, affinity: AffinityTable) -> FloatArray:
    """``log rho`` of every difference in ``delta`` (any shape, float64, finite).

    Raises:
        TypeError: ``delta`` is not float64, ``affinity`` not an :class:`AffinityTable`.
        ValueError: ``delta`` holds NaN or infinite values.
    """
    values = _finite_float64(delta, "delta")
    checked = _checked_table(affinity)
    flat = np.ascontiguousarray(values).reshape(-1)
    return _log_affinity(flat, checked.periodic, *checked.arguments()).reshape(values.shape)


def _finite_float64(values: FloatArray, name: str) -> FloatArray:
    """``values`` as an ndarray after checking that it is float64 and finite."""
    array = np.asarray(values)
    if array.dtype != np.float64:
        raise TypeError(f"{name} must be a float64 array, got {array.dtype}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite")
    return array


def _checked_table(affinity: AffinityTable) -> AffinityTable:
    if not isinstance(affinity, AffinityTable):
        raise TypeError(f"affinity must be an AffinityTable, got {type(affinity).__name__}")
    return affinity
