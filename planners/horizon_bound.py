r"""The horizon bound's log-sum-exp over particle pairs, with its sums and shifts compiled.

For a candidate's summed pair terms :math:`L = S_0 + S_1 + \dots + S_K` (its own sequence's
sums :math:`S_0`, then the ``K`` partner plans' in order, added in that order), weights
:math:`w` and :math:`M_n = \max_m (L(n, m) + \log w_m)`, the bound of
:mod:`~infoseek.planners.horizon_information` is

.. math::  \hat I_B = -\sum_n w_n r_n, \qquad
           r_n = \log \sum_m e^{L(n, m) + \log w_m - M_n} + M_n .

:func:`bound_rows` computes the rows :math:`r` of ``C`` candidates as the NumPy expression
``log(exp(shifted - top).sum(-1)) + top`` did, chunk by chunk of candidates so that the
exponents stay in the cache:

1. one compiled pass (:func:`_exponents`) forms the sums ``L``, adds ``log w``, takes the row
   maximum and the shift, and counts the exponents that underflow (:math:`x < -746`:
   :math:`e^x < 2^{-1076}` rounds to zero in every ``exp``);
2. without underflows (the usual case once the belief has narrowed), NumPy's ``exp`` of the
   exponents in place; otherwise the exponents that do not underflow are packed into one
   array (:func:`_pack`), NumPy takes their ``exp``, and a compiled pass (:func:`_unpack`)
   puts them back in place with ``0.0`` for the others;
3. NumPy's sums over ``m`` (its pairwise order), its ``log`` of the sums, plus ``M``.

The exponential and the logarithm stay NumPy calls: in the pinned numerical environment they
are the C library's functions, as a kernel's would be, and elsewhere NumPy's SIMD loops are
several times faster than the C library, so the bound keeps the bits of the NumPy code in
both. Leaving out the underflowing exponents matters at a wide belief (the first step), where
a fifth of the pairs are more than ``exp(-746)`` apart and ``exp`` takes its slow path on them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]

__all__ = ["bound_rows"]

#: Candidates per chunk: 8 x 128 x 128 float64 exponents (1 MiB) at the default 128 particles.
CHUNK_CANDIDATES = 8
#: Exponents below this have ``exp(x) == 0.0`` (the smallest subnormal is ``exp(-744.44)``;
#: ``exp(x)`` for ``x < -745.14`` rounds to zero).
EXP_UNDERFLOW = -746.0


@kernel
def _exponents(
    own: FloatArray,
    partners: FloatArray,
    log_weights: FloatArray,
    start: int,
    out: FloatArray,
    tops: FloatArray,
) -> int:
    """``out[c - start, n, m] = L(n, m) + log w_m - M_n`` and ``tops[c, n] = M_n`` for the
    candidates ``c = start .. start + len(out) - 1``. Returns how many exponents underflow.

    Row ``n`` of every candidate of the chunk in turn: the partners' rows ``n`` stay in the
    first-level cache while the candidates' rows stream past.
    """
    n = own.shape[2]
    underflows = 0
    for i in range(own.shape[1]):
        for c in range(start, start + out.shape[0]):
            row = out[c - start, i]
            for m in range(n):
                row[m] = own[c, i, m]
            for k in range(partners.shape[0]):
                partner = partners[k, i]
                for m in range(n):
                    row[m] += partner[m]
            top = -np.inf
            for m in range(n):
                shifted = row[m] + log_weights[m]
                row[m] = shifted
                top = shifted if shifted > top else top
            for m in range(n):
                row[m] -= top
                underflows += row[m] < EXP_UNDERFLOW
            tops[c, i] = top
    return underflows


@kernel
def _pack(exponents: FloatArray, packed: FloatArray) -> int:
    """Copy the exponents ``>= EXP_UNDERFLOW`` (and NaN) in order to the front of ``packed``;
    returns how many."""
    flat = exponents.reshape(-1)
    count = 0
    for j in range(flat.shape[0]):  # without branches: always write, advance when kept
        packed[count] = flat[j]
        count += not flat[j] < EXP_UNDERFLOW
    return count


@kernel
def _unpack(exponents: FloatArray, packed: FloatArray) -> None:
    """Replace every exponent by its exponential: the next value of ``packed`` where the
    exponent does not underflow, ``0.0`` where it does (``packed`` has one slot of slack)."""
    flat = exponents.reshape(-1)
    count = 0
    for j in range(flat.shape[0]):  # without branches
        kept = not flat[j] < EXP_UNDERFLOW
        flat[j] = packed[count] if kept else 0.0
        count += kept


def bound_rows(own: FloatArray, partners: FloatArray, log_weights: FloatArray) -> FloatArray:
    """``(C, N)`` rows ``r`` of the bound of ``L = own[c] + partners[0] + partners[1] + ...``.

    Args:
        own: ``(C, N, N)`` float64 pair sums, one per candidate.
        partners: ``(K, N, N)`` float64 pair sums added to every candidate's, in order
            (``K = 0`` for none).
        log_weights: ``(N,)`` float64 ``log w``.

    Returns:
        ``(C, N)`` ``log sum_m exp(L[c, n, m] + log w_m - M_n) + M_n`` (module docstring); the
        bound of candidate ``c`` is ``-(rows[c] @ w)``. A NaN in the inputs gives NaN rows.

    Raises:
        TypeError: An argument is not float64.
        ValueError: Shapes that do not match.
    """
    own, partners, log_weights = (
        _float64(own, "own"),
        _float64(partners, "partners"),
        _float64(log_weights, "log_weights"),
    )
    n = log_weights.shape[0] if log_weights.ndim == 1 else -1
    if own.ndim != 3 or own.shape[1:] != (n, n):
        raise ValueError(f"own must be (C, N, N) with N = log_weights.size, got {own.shape}")
    if partners.ndim != 3 or partners.shape[1:] != (n, n):
        raise ValueError(f"partners must be (K, N, N) with N = {n}, got {partners.shape}")
    n_candidates = own.shape[0]
    tops = np.empty((n_candidates, n))
    sums = np.empty((n_candidates, n))
    exponents = np.empty((min(CHUNK_CANDIDATES, n_candidates), n, n))
    packed = np.empty(0)
    for start in range(0, n_candidates, CHUNK_CANDIDATES):
        stop = min(n_candidates, start + CHUNK_CANDIDATES)
        chunk = exponents[: stop - start]
        if _exponents(own, partners, log_weights, start, chunk, tops) == 0:
            np.exp(chunk, out=chunk)
            np.sum(chunk, axis=-1, out=sums[start:stop])
            continue
        if packed.size == 0:
            packed = np.empty(exponents.size + 1)  # + 1: _unpack may read one past the last
        kept = packed[: _pack(chunk, packed)]
        np.exp(kept, out=kept)
        _unpack(chunk, packed)
        np.sum(chunk, axis=-1, out=sums[start:stop])
    return np.log(sums) + tops


def _float64(values: FloatArray, name: str) -> FloatArray:
    """``values`` as a C-contiguous ndarray after checking that it is float64."""
    array = np.asarray(values)
    if array.dtype != np.float64:
        raise TypeError(f"{name} must be a float64 array, got {array.dtype}")
    return np.ascontiguousarray(array)
