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
``exp`` per element); the per-row logarithms, ESS and uniformity tests are compiled. The
numbers are those of the earlier NumPy form bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "DEGENERATE_LOG_EVIDENCE",
    "bayes_step",
    "ess_rows",
    "is_uniform",
    "log_ess_rows",
    "logsumexp_rows",
    "normalised",
]

#: Log evidence below which an update counts as degenerate (exp underflows in float64).
DEGENERATE_LOG_EVIDENCE = -700.0


@kernel
def _log_normalisers(peak: FloatArray, sums: FloatArray) -> FloatArray:
    """``peak + log(sums)`` where ``peak`` is finite, ``peak`` elsewhere (the C library's
    ``log``, as ``math.log`` calls it)."""
    out = peak.copy()
    for k in range(peak.shape[0]):
        if math.isfinite(peak[k]):
            out[k] = peak[k] + math.log(sums[k])
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
def _uniform_rows(values: FloatArray) -> BoolArray:
    """``(K,)`` whether every value of a row equals its first (a resampled belief)."""
    out = np.empty(values.shape[0], dtype=np.bool_)
    for k in range(values.shape[0]):
        out[k] = is_uniform(values[k])
    return out


@kernel
def is_uniform(values: FloatArray) -> bool:
    """Whether every value equals the first (the log-weights of a resampled belief)."""
    for i in range(1, values.shape[0]):
        if values[i] != values[0]:
            return False
    return True


def log_ess_rows(log_weights: FloatArray) -> FloatArray:
    """``(K,)`` ``log ESS = 2 log Z(l) - log Z(2 l)`` of ``(K, N)`` log-weights, computed once
    for all rows of equal log-weights (equal rows give equal results)."""
    log_weights = _rows_of(log_weights, "log_weights")
    out = np.empty(log_weights.shape[0])
    uniform = _uniform_rows(log_weights)
    first = log_weights[:, 0]
    for value in np.unique(first[uniform]):
        rows = np.flatnonzero(uniform & (first == value))
        one = log_weights[rows[:1]]
        out[rows] = 2.0 * logsumexp_rows(one)[0] - logsumexp_rows(2.0 * one)[0]
    rest = np.flatnonzero(~uniform)
    if rest.size:
        some = log_weights[rest]
        out[rest] = 2.0 * logsumexp_rows(some) - logsumexp_rows(2.0 * some)
    return out


def bayes_step(
    log_weights: FloatArray,
    log_likelihood: FloatArray,
    live: BoolArray,
    tempering_ess: float | None,
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """The Bayes step of every row (module docstring).

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
    live = np.asarray(live, dtype=np.bool_)
    if live.shape != log_weights.shape[:1]:
        raise ValueError(f"live must have shape {log_weights.shape[:1]}, got {live.shape}")
    full = log_weights + log_likelihood
    log_z = logsumexp_rows(full)
    with np.errstate(invalid="ignore"):
        accepted = live & np.isfinite(log_z) & (log_z >= DEGENERATE_LOG_EVIDENCE)
        if tempering_ess is not None and accepted.any():
            rows = np.flatnonzero(accepted)
            log_floor = math.log(tempering_ess) + log_ess_rows(log_weights[rows])
            posterior = 2.0 * log_z[rows] - logsumexp_rows(2.0 * full[rows])
            accepted[rows] = posterior >= log_floor
    rows = np.flatnonzero(accepted)
    updated = full[rows] - log_z[rows, None]
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
