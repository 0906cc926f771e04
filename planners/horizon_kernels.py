r"""Compiled kernels of the horizon information bound: affinity lookups and the bound's rows.

:class:`~infoseek.planners.horizon_information.HorizonInformation` evaluates, for the noise-free
predictions :math:`h_{k,n}` of particle :math:`n` at pose :math:`k`, the pair terms

.. math::  \ell_k(n, m) = \log \rho(\operatorname{wrap}(h_{k,n} - h_{k,m}))

by linear interpolation in a table of :math:`\log \rho` on the grid
:math:`\delta_j = \delta_0 + j s` (``j = 0 .. J-1``): with
:math:`q = \min(\max((\delta - \delta_0) / s, 0), J - 1 - 10^{-9})`,
:math:`j = \lfloor q \rfloor` and :math:`f = q - j`,
:math:`\log \rho(\delta) \approx T_j + f (T_{j+1} - T_j)`. On a periodic observation of period
:math:`P` the difference is first wrapped to :math:`[-P/2, P/2)`:
:math:`\operatorname{wrap}(\delta) = ((\delta + P/2) \bmod P) - P/2` with NumPy's floored
``mod`` (the result has the sign of :math:`P`, ``+0.0`` for a zero remainder).

The kernels here are the NumPy expressions of that module, fused:

* :func:`log_affinity` is the lookup of any array of differences;
* :func:`pair_term_sums` gives :math:`S_g(n, m) = \sum_{t} \ell_{g,t}(n, m)` of ``G`` groups
  of ``H`` poses (a control sequence's ``H`` poses), summed over ``t`` in order
  (``((l_0 + l_1) + l_2) + ...``, as NumPy's sum over a leading axis), without the
  ``(G, H, N, N)`` temporaries; groups whose first pose's predictions equal the previous
  group's share that pose's lookups (equal inputs, equal bits);
* :func:`bound_rows` gives, for pair sums :math:`L = S_0 + S_1 + \dots + S_K` (summed in that
  order) and weights :math:`w`, the rows
  :math:`r_n = \log \sum_m e^{L(n, m) + \log w_m - M_n} + M_n` with
  :math:`M_n = \max_m (L(n, m) + \log w_m)`, the inner log-sum-exp of the bound
  :math:`\hat I_B = -\sum_n w_n r_n`.

Every value is computed as the NumPy code computed it: the same operations in the same order
(``mod`` as NumPy's ``npy_divmod``: C ``fmod`` then the sign fix-up, with the exact shortcuts
``x``, ``x - P`` and ``x + P`` on the range that predictions inside the domain produce),
``exp`` and ``log`` of the C library, the sum over ``m`` in NumPy's pairwise order
(:func:`~infoseek.envs.compiled.pairwise_sum`). In the pinned numerical environment
(:mod:`infoseek.envs.compiled`) the results are those of the NumPy expressions bit for bit.
An exponent below ``-746`` is taken as ``0.0`` without calling ``exp`` (its value rounds to 0).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum

FloatArray = NDArray[np.float64]

__all__ = ["AffinityTable", "bound_rows", "log_affinity", "pair_term_sums"]

#: Exponents below this give ``exp(x) == 0.0`` in float64 (the smallest subnormal is
#: ``exp(-744.44)``; values under ``exp(-745.13)`` round to zero).
EXP_UNDERFLOW = -746.0


class AffinityTable:
    """The interpolation table of ``log rho`` and its grid, as the kernels take it.

    Args:
        table: ``(J,)`` float64 values of ``log rho`` on the grid, ``J >= 2``.
        delta0: First grid point ``delta_0``.
        step: Grid spacing ``s > 0``.
        period: Observation period ``P`` (periodic observations), or ``None``.
    """

    def __init__(self, table: FloatArray, delta0: float, step: float, period: float | None):
        table = np.ascontiguousarray(table)
        if table.dtype != np.float64 or table.ndim != 1 or table.size < 2:
            raise ValueError(
                f"table must be a (J >= 2,) float64 array, got {table.dtype} {table.shape}"
            )
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f"step must be finite and > 0, got {step}")
        if period is not None and not (math.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0, got {period}")
        self.table = table
        self.delta0 = float(delta0)
        self.step = float(step)
        self.periodic = period is not None
        self.period = float(period) if period is not None else 0.0
        self.half = 0.5 * self.period
        #: Largest table position, ``J - 1 - 1e-9`` (the clip of the NumPy code).
        self.upper = (table.size - 1) - 1e-9


@kernel
def _floored_mod(x: float, period: float) -> float:
    """NumPy's ``np.mod(x, period)`` for ``period > 0`` (``npy_divmod``'s remainder)."""
    if 0.0 <= x < period:
        return x + 0.0  # fmod(x, P) = x; a zero remainder is +0.0
    if period <= x < 2.0 * period:
        return x - period  # exact (Sterbenz), as fmod
    if -period < x < 0.0:
        return x + period  # fmod(x, P) = x, then the sign fix-up adds P
    mod = np.fmod(x, period)  # exact (IEEE remainder of truncated division)
    if mod != 0.0:
        if mod < 0.0:
            mod += period
    else:
        mod = 0.0
    return mod


@kernel
def _lookup(
    delta: float,
    table: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    periodic: bool,
    upper: float,
) -> float:
    """``log rho(delta)`` of one difference (module docstring)."""
    if periodic:
        delta = _floored_mod(delta + half, period) - half
    position = (delta - delta0) / step
    if not position > 0.0:  # np.clip(position, 0, upper): max first (-0.0 -> +0.0), then min
        position = 0.0
    if not position < upper:
        position = upper
    index = int(position)
    position -= index
    low = table[index]
    return low + position * (table[index + 1] - low)


@kernel
def _log_affinity(
    delta: FloatArray,
    table: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    periodic: bool,
    upper: float,
) -> FloatArray:
    out = np.empty_like(delta)
    for i in range(delta.shape[0]):
        out[i] = _lookup(delta[i], table, delta0, step, half, period, periodic, upper)
    return out


def log_affinity(delta: FloatArray, affinity: AffinityTable) -> FloatArray:
    """``log rho`` of every difference in ``delta`` (any shape, float64, finite).

    Raises:
        TypeError: ``delta`` is not float64.
        ValueError: ``delta`` holds NaN or infinite values.
    """
    values = _checked_float64(delta, "delta")
    flat = np.ascontiguousarray(values).reshape(-1)
    out = _log_affinity(flat, *_table_arguments(affinity))
    return out.reshape(values.shape)


@kernel
def _pair_lookups(
    row: FloatArray,
    anchor: float,
    predictions: FloatArray,
    accumulate: bool,
    table: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    periodic: bool,
    upper: float,
) -> None:
    """``row[m] (+)= log rho(anchor - predictions[m])`` for every ``m``."""
    if accumulate:
        for m in range(row.shape[0]):
            d = anchor - predictions[m]
            row[m] += _lookup(d, table, delta0, step, half, period, periodic, upper)
    else:
        for m in range(row.shape[0]):
            d = anchor - predictions[m]
            row[m] = _lookup(d, table, delta0, step, half, period, periodic, upper)


@kernel
def _pair_term_sums(
    predictions: FloatArray,
    table: FloatArray,
    delta0: float,
    step: float,
    half: float,
    period: float,
    periodic: bool,
    upper: float,
) -> FloatArray:
    n_groups, horizon, n = predictions.shape
    out = np.empty((n_groups, n, n))
    first = np.empty((n, n))
    cached = -1
    for g in range(n_groups):
        head = predictions[g, 0]
        if cached < 0 or not np.all(head == predictions[cached, 0]):
            for i in range(n):
                _pair_lookups(
                    first[i], head[i], head, False, table, delta0, step, half, period,
                    periodic, upper,
                )  # fmt: skip
            cached = g
        for i in range(n):
            row = out[g, i]
            row[:] = first[i]
            for t in range(1, horizon):
                pose = predictions[g, t]
                _pair_lookups(
                    row, pose[i], pose, True, table, delta0, step, half, period, periodic, upper
                )
    return out


def pair_term_sums(predictions: FloatArray, affinity: AffinityTable) -> FloatArray:
    """``(G, N, N)`` sums over ``t`` of ``log rho(h[g, t, n] - h[g, t, m])`` (module docstring).

    Args:
        predictions: ``(G, H, N)`` float64 noise-free predictions, finite, ``H >= 1``.
        affinity: The table.

    Raises:
        TypeError: ``predictions`` is not float64.
        ValueError: Wrong shape or non-finite values.
    """
    values = _checked_float64(predictions, "predictions")
    if values.ndim != 3 or values.shape[1] < 1:
        raise ValueError(f"predictions must be (G, H >= 1, N), got {values.shape}")
    return _pair_term_sums(np.ascontiguousarray(values), *_table_arguments(affinity))


@kernel
def _bound_rows(own: FloatArray, partners: FloatArray, log_weights: FloatArray) -> FloatArray:
    n_candidates, n = own.shape[0], own.shape[2]
    out = np.empty((n_candidates, own.shape[1]))
    row = np.empty(n)
    exponentials = np.empty(n)
    for c in range(n_candidates):
        for i in range(own.shape[1]):
            for m in range(n):
                row[m] = own[c, i, m]
            for k in range(partners.shape[0]):
                for m in range(n):
                    row[m] += partners[k, i, m]
            top = -math.inf
            for m in range(n):
                shifted = row[m] + log_weights[m]
                row[m] = shifted
                if shifted > top or math.isnan(shifted):
                    top = shifted
            for m in range(n):
                exponent = row[m] - top
                exponentials[m] = math.exp(exponent) if not exponent < EXP_UNDERFLOW else 0.0
            out[c, i] = math.log(pairwise_sum(exponentials)) + top
    return out


def bound_rows(own: FloatArray, partners: FloatArray, log_weights: FloatArray) -> FloatArray:
    """``(C, N)`` rows ``r`` of the bound of ``L = own[c] + partners[0] + partners[1] + ...``.

    Args:
        own: ``(C, N, N)`` float64 pair sums, one per candidate.
        partners: ``(K, N, N)`` float64 pair sums added to every candidate's, in order
            (``K = 0`` for none).
        log_weights: ``(N,)`` float64 ``log w``.

    Returns:
        ``(C, N)`` ``log sum_m exp(L[c, n, m] + log w_m - M) + M`` (module docstring); the
        bound of candidate ``c`` is ``-(rows[c] @ w)``.

    Raises:
        TypeError: An argument is not float64.
        ValueError: Shapes that do not match.
    """
    own = _checked_float64(own, "own", finite=False)
    partners = _checked_float64(partners, "partners", finite=False)
    log_weights = _checked_float64(log_weights, "log_weights", finite=False)
    n = log_weights.shape[0] if log_weights.ndim == 1 else -1
    if own.ndim != 3 or own.shape[1:] != (n, n):
        raise ValueError(f"own must be (C, N, N) with N = log_weights.size, got {own.shape}")
    if partners.ndim != 3 or partners.shape[1:] != (n, n):
        raise ValueError(f"partners must be (K, N, N) with N = {n}, got {partners.shape}")
    return _bound_rows(
        np.ascontiguousarray(own),
        np.ascontiguousarray(partners),
        np.ascontiguousarray(log_weights),
    )


def _checked_float64(values: FloatArray, name: str, *, finite: bool = True) -> FloatArray:
    """``values`` as an ndarray after checking its dtype (and finiteness)."""
    array = np.asarray(values)
    if array.dtype != np.float64:
        raise TypeError(f"{name} must be a float64 array, got {array.dtype}")
    if finite and not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite")
    return array


def _table_arguments(
    affinity: AffinityTable,
) -> tuple[FloatArray, float, float, float, float, bool, float]:
    """The table's fields in the kernels' argument order."""
    if not isinstance(affinity, AffinityTable):
        raise TypeError(f"affinity must be an AffinityTable, got {type(affinity).__name__}")
    return (
        affinity.table,
        affinity.delta0,
        affinity.step,
        affinity.half,
        affinity.period,
        affinity.periodic,
        affinity.upper,
    )
