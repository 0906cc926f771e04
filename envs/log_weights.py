r"""Log-weight arithmetic of ``K`` particle beliefs: normaliser, Bayes step, ESS.

For each row ``k`` of ``(K, N)`` log-weights :math:`\ell_{k,n}`:

* the log normaliser :math:`\log Z_k = m_k + \log \sum_n e^{\ell_{k,n} - m_k}` with
  :math:`m_k = \max_n \ell_{k,n}` (``-inf`` for a row of ``-inf``);
* the normalised weights :math:`w_{k,n} = e^{\ell_{k,n}} / \sum_j e^{\ell_{k,j}}`;
* the effective sample size :math:`\mathrm{ESS}_k = 1 / \sum_n w_{k,n}^2`, and from
  log-weights :math:`\log \mathrm{ESS} = 2 \log Z(\ell) - \log Z(2 \ell)`;
* the Bayes step (eq. 4, eq. 14) :math:`\ell' = \ell + \log p(z \mid \theta)`, kept when its
  log evidence :math:`\log Z(\ell')` is finite, at least ``DEGENERATE_LOG_EVIDENCE`` and, with
  progressive correction, leaves :math:`\log \mathrm{ESS}(\ell') \ge \log \tau +
  \log \mathrm{ESS}(\ell)` (``tau`` the tempering floor); other rows are left to the caller.

Every row is computed alone (equal rows give equal results, so the log ESS of uniform rows is
computed once): row ``k`` does not depend on the other rows. The ``exp`` passes over the
``(K, N)`` arrays stay NumPy ufuncs (SIMD loops, faster than a compiled call of the C library's
``exp`` per element); the sums, logarithms, maxima, ESS and uniformity tests around them are
compiled (the Bayes step is two compiled passes around one ``exp`` call). The log ESS of a row
of equal log-weights needs no ``exp``: every term is ``exp(0) = 1``. The numbers are those of
the earlier NumPy form bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "DEGENERATE_LOG_EVIDENCE",
    "bayes_step",
    "ess_rows",
    "is_uniform",
    "log_ess_rows",
    "log_normaliser",
    "logsumexp_rows",
    "normalised",
]

#: Log evidence below which an update counts as degenerate (exp underflows in float64).
DEGENERATE_LOG_EVIDENCE = -700.0


@kernel
def log_normaliser(peak: float, total: float) -> float:
    """``log Z`` of a row from its maximum and the sum of ``exp(value - peak)``:
    ``peak + log(total)`` where ``peak`` is finite, ``peak`` itself otherwise (the C library's
    ``log``, as ``math.log`` calls it)."""
    return peak + math.log(total) if math.isfinite(peak) else peak


@kernel
def _log_normalisers(peak: FloatArray, sums: FloatArray) -> FloatArray:
    """:func:`log_normaliser` of every row."""
    out = np.empty(peak.shape[0])
    for k in range(peak.shape[0]):
        out[k] = log_normaliser(peak[k], sums[k])
    return out


def logsumexp_rows(values: FloatArray) -> FloatArray:
    """``(K,)`` ``log sum_n exp(values[k, n])`` of ``(K, N)`` values (module docstring).

    Args:
        values: ``(K, N)`` float64 values (``-inf`` allowed).

    Returns:
        ``(K,)`` log normalisers; ``-inf`` for a row of ``-inf``, ``+inf`` if the row holds one.
    """
    values = _rows_of(values, "values")
    peak = values.max(axis=1)
    shift = np.where(np.isfinite(peak), peak, 0.0)
    with np.errstate(invalid="ignore"):
        sums = np.exp(values - shift[:, None]).sum(axis=1)
    return _log_normalisers(peak, sums)  # type: ignore[no-any-return]


def normalised(log_weights: FloatArray) -> FloatArray:
    """``(K, N)`` weights ``exp(l) / sum exp(l)`` of ``(K, N)`` normalised log-weights."""
    weights = np.exp(_rows_of(log_weights, "log_weights"))
    weights /= weights.sum(axis=1, keepdims=True)
    return weights


@kernel
def _ess_rows(weights: FloatArray) -> FloatArray:
    out = np.empty(weights.shape[0])
    for k in range(weights.shape[0]):
        row = weights[k]
        out[k] = 1.0 / np.dot(row, row)
    return out


def ess_rows(weights: FloatArray) -> FloatArray:
    """``(K,)`` effective sample sizes ``1 / sum w^2`` of ``(K, N)`` normalised weights."""
    return _ess_rows(_rows_of(weights, "weights"))  # type: ignore[no-any-return]


@kernel
def is_uniform(values: FloatArray) -> bool:
    """Whether every value equals the first (the log-weights of a resampled belief)."""
    for i in range(1, values.shape[0]):
        if values[i] != values[0]:
            return False
    return True


@kernel
def _uniform_log_ess(log_weights: FloatArray) -> tuple[FloatArray, BoolArray]:
    """``log ESS`` of the rows whose log-weights are all equal, and which rows those are.

    For a row of ``N`` equal values ``c`` this is :func:`logsumexp_rows`'s arithmetic with
    every ``exp(c - c) = exp(0) = 1`` (exact in any ``exp``) and the pairwise sum of ``N``
    ones (exactly ``N``): ``2 (c + log N) - (2 c + log N)``, so the same bits without an
    ``exp`` pass.
    """
    k_rows, n = log_weights.shape
    out = np.zeros(k_rows)
    uniform = np.empty(k_rows, dtype=np.bool_)
    for k in range(k_rows):
        uniform[k] = is_uniform(log_weights[k])
        if uniform[k]:
            c = log_weights[k, 0]
            once = log_normaliser(c, float(n))
            out[k] = 2.0 * once - log_normaliser(2.0 * c, float(n))
    return out, uniform


def log_ess_rows(log_weights: FloatArray) -> FloatArray:
    """``(K,)`` ``log ESS = 2 log Z(l) - log Z(2 l)`` of ``(K, N)`` log-weights (rows of equal
    log-weights in closed form, :func:`_uniform_log_ess`; the same numbers)."""
    log_weights = _rows_of(log_weights, "log_weights")
    out, uniform = _uniform_log_ess(log_weights)
    rest = np.flatnonzero(~uniform)
    if rest.size:
        some = log_weights[rest]
        with np.errstate(invalid="ignore"):
            out[rest] = 2.0 * logsumexp_rows(some) - logsumexp_rows(2.0 * some)
    return out  # type: ignore[no-any-return]


@kernel
def _shifted(
    log_weights: FloatArray, log_likelihood: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``full = l + log p``, its row maxima, and the ``(2K, N)`` exponents of
    :func:`logsumexp_rows` of ``full`` (rows ``k``) and of ``2 full`` (rows ``K + k``), whose
    maxima are exactly twice those of ``full``."""
    k_rows, n = log_weights.shape
    full = np.empty((k_rows, n))
    shifted = np.empty((2 * k_rows, n))
    peak = np.empty(k_rows)
    for k in range(k_rows):
        top = -math.inf
        for i in range(n):
            value = log_weights[k, i] + log_likelihood[k, i]
            full[k, i] = value
            top = max(top, value)
        peak[k] = top
        shift = top if math.isfinite(top) else 0.0
        shift_twice = 2.0 * top if math.isfinite(2.0 * top) else 0.0
        for i in range(n):
            shifted[k, i] = full[k, i] - shift
            shifted[k_rows + k, i] = 2.0 * full[k, i] - shift_twice
    return full, peak, shifted


@kernel
def _accepted_rows(
    full: FloatArray,
    peak: FloatArray,
    exponentials: FloatArray,
    live: BoolArray,
    log_floor: FloatArray,
    tempering: bool,
) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Log evidence of every row, the acceptance of each, and ``full - log Z`` of the accepted
    rows in row order (module docstring)."""
    k_rows, n = full.shape
    log_z = np.empty(k_rows)
    accepted = np.zeros(k_rows, dtype=np.bool_)
    count = 0
    for k in range(k_rows):
        top = peak[k]
        log_z[k] = log_normaliser(top, pairwise_sum(exponentials[k]))
        ok = live[k] and math.isfinite(log_z[k]) and log_z[k] >= DEGENERATE_LOG_EVIDENCE
        if ok and tempering:
            log_z_twice = log_normaliser(2.0 * top, pairwise_sum(exponentials[k_rows + k]))
            ok = 2.0 * log_z[k] - log_z_twice >= log_floor[k]
        accepted[k] = ok
        count += ok
    updated = np.empty((count, n))
    row = 0
    for k in range(k_rows):
        if accepted[k]:
            for i in range(n):
                updated[row, i] = full[k, i] - log_z[k]
            row += 1
    return log_z, accepted, updated


def bayes_step(
    log_weights: FloatArray,
    log_likelihood: FloatArray,
    live: BoolArray,
    tempering_ess: float | None,
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """The Bayes step of every row (module docstring).

    Two compiled passes around one NumPy ``exp`` of the ``(2K, N)`` exponents of ``log Z(l')``
    and ``log Z(2 l')`` (and one of the accepted log-weights), with the arithmetic of
    :func:`logsumexp_rows` and :func:`log_ess_rows`: the numbers of computing them one by one.

    Args:
        log_weights: ``(K, N)`` normalised log-weights before the step.
        log_likelihood: ``(K, N)`` summed log-likelihood of each row's observations (no NaN,
            no ``+inf``).
        live: ``(K,)`` rows that received observations (the others are never accepted).
        tempering_ess: Progressive-correction floor ``tau`` of the acceptance test, or
            ``None`` to accept every live row of admissible evidence.

    Returns:
        ``(log_weights, weights, log_evidence, accepted)``: ``(A, N)`` normalised log-weights
        and weights of the ``A`` accepted rows (in row order), ``(K,)`` log evidence of every
        row, ``(K,)`` which rows were accepted.
    """
    log_weights = _rows_of(log_weights, "log_weights")
    log_likelihood = _rows_of(log_likelihood, "log_likelihood")
    if log_likelihood.shape != log_weights.shape:
        raise ValueError(
            f"log_likelihood must have the shape of log_weights {log_weights.shape}, "
            f"got {log_likelihood.shape}"
        )
    live = np.ascontiguousarray(live, dtype=np.bool_)
    if live.shape != log_weights.shape[:1]:
        raise ValueError(f"live must have shape {log_weights.shape[:1]}, got {live.shape}")
    full, peak, exponentials = _shifted(log_weights, log_likelihood)
    tempering = tempering_ess is not None
    used = exponentials if tempering else exponentials[: full.shape[0]]
    np.exp(used, out=used)
    log_floor = np.empty(0)  # read only when tempering
    if tempering_ess is not None:
        log_floor = math.log(tempering_ess) + log_ess_rows(log_weights)
    log_z, accepted, updated = _accepted_rows(full, peak, exponentials, live, log_floor, tempering)
    return updated, normalised(updated), log_z, accepted


def _rows_of(values: object, name: str) -> FloatArray:
    """``values`` as a C-contiguous ``(K, N)`` float64 array, or a ``ValueError``/``TypeError``
    naming ``name``."""
    array = np.asarray(values)
    if array.dtype != np.float64:
        raise TypeError(f"{name} must be a float64 array, got dtype {array.dtype}")
    if array.ndim != 2:
        raise ValueError(f"{name} must have shape (K, N), got {array.shape}")
    return np.ascontiguousarray(array)
