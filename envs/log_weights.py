r"""Log-weight arithmetic of ``K`` particle beliefs, compiled: normaliser, Bayes step, ESS.

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

Every row is computed alone (equal rows give equal results, so the log ESS of a uniform prior
row is computed once and reused), as the NumPy expressions these kernels replace computed it
(``exp`` and ``log`` of the C library, sums in NumPy's pairwise order, ``1 / dot(w, w)``
through BLAS): row ``k`` does not depend on the other rows, and the numbers are those of the
NumPy code bit for bit in the pinned numerical environment (:mod:`infoseek.envs.compiled`).
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
    "logsumexp_rows",
    "normalised",
]

#: Log evidence below which an update counts as degenerate (exp underflows in float64).
DEGENERATE_LOG_EVIDENCE = -700.0


@kernel
def _logsumexp(values: FloatArray, scratch: FloatArray, scale: float) -> float:
    """``log sum exp(scale * values)`` of one row (``scratch`` holds the shifted exponentials)."""
    n = values.shape[0]
    peak = -math.inf
    for i in range(n):
        v = scale * values[i]
        if v > peak or math.isnan(v):
            peak = v
    if not math.isfinite(peak):
        return peak
    for i in range(n):
        scratch[i] = math.exp(scale * values[i] - peak)
    return peak + math.log(pairwise_sum(scratch))


@kernel
def _logsumexp_rows(values: FloatArray) -> FloatArray:
    k_rows, n = values.shape
    out = np.empty(k_rows)
    scratch = np.empty(n)
    for k in range(k_rows):
        out[k] = _logsumexp(values[k], scratch, 1.0)
    return out


def logsumexp_rows(values: FloatArray) -> FloatArray:
    """``(K,)`` ``log sum_n exp(values[k, n])`` of ``(K, N)`` values (module docstring).

    Args:
        values: ``(K, N)`` float64 values (``-inf`` allowed).

    Returns:
        ``(K,)`` log normalisers; ``-inf`` for a row of ``-inf``, ``+inf`` if the row holds one.
    """
    return _logsumexp_rows(_rows_of(values, "values"))


@kernel
def _normalise_into(log_weights: FloatArray, weights: FloatArray) -> None:
    """``weights = exp(log_weights) / sum(exp(log_weights))`` of one row."""
    for i in range(log_weights.shape[0]):
        weights[i] = math.exp(log_weights[i])
    total = pairwise_sum(weights)
    for i in range(weights.shape[0]):
        weights[i] = weights[i] / total


@kernel
def _normalised(log_weights: FloatArray) -> FloatArray:
    weights = np.empty_like(log_weights)
    for k in range(log_weights.shape[0]):
        _normalise_into(log_weights[k], weights[k])
    return weights


def normalised(log_weights: FloatArray) -> FloatArray:
    """``(K, N)`` weights ``exp(l) / sum exp(l)`` of ``(K, N)`` normalised log-weights."""
    return _normalised(_rows_of(log_weights, "log_weights"))


@kernel
def _ess_rows(weights: FloatArray) -> FloatArray:
    out = np.empty(weights.shape[0])
    for k in range(weights.shape[0]):
        row = weights[k]
        out[k] = 1.0 / np.dot(row, row)
    return out


def ess_rows(weights: FloatArray) -> FloatArray:
    """``(K,)`` effective sample sizes ``1 / sum w^2`` of ``(K, N)`` normalised weights."""
    return _ess_rows(_rows_of(weights, "weights"))


@kernel
def is_uniform(values: FloatArray) -> bool:
    """Whether every value equals the first (the log-weights of a resampled belief)."""
    for i in range(1, values.shape[0]):
        if values[i] != values[0]:
            return False
    return True


@kernel
def _bayes_step(
    log_weights: FloatArray,
    log_likelihood: FloatArray,
    live: BoolArray,
    log_tempering_ess: float,
    tempering: bool,
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    k_rows, n = log_weights.shape
    updated = np.empty_like(log_weights)
    weights = np.empty_like(log_weights)
    log_evidence = np.empty(k_rows)
    accepted = np.zeros(k_rows, dtype=np.bool_)
    scratch = np.empty(n)
    cached_value, cached_log_ess = math.nan, 0.0  # log ESS of the last uniform prior row
    for k in range(k_rows):
        row = updated[k]
        for i in range(n):
            row[i] = log_weights[k, i] + log_likelihood[k, i]
        log_z = _logsumexp(row, scratch, 1.0)
        log_evidence[k] = log_z
        keep = live[k] and math.isfinite(log_z) and log_z >= DEGENERATE_LOG_EVIDENCE
        if keep and tempering:
            prior = log_weights[k]
            uniform = is_uniform(prior)
            if uniform and prior[0] == cached_value:
                prior_log_ess = cached_log_ess
            else:
                prior_log_ess = 2.0 * _logsumexp(prior, scratch, 1.0) - _logsumexp(
                    prior, scratch, 2.0
                )
                if uniform:
                    cached_value, cached_log_ess = prior[0], prior_log_ess
            log_floor = log_tempering_ess + prior_log_ess
            keep = 2.0 * log_z - _logsumexp(row, scratch, 2.0) >= log_floor
        accepted[k] = keep
        if keep:
            for i in range(n):
                row[i] = row[i] - log_z
            _normalise_into(row, weights[k])
    return updated, weights, log_evidence, accepted


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
        ``(log_weights, weights, log_evidence, accepted)``: ``(K, N)`` normalised log-weights
        and weights of the accepted rows (other rows hold unspecified values), ``(K,)`` log
        evidence of every row, ``(K,)`` which rows were accepted.
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
    tempering = tempering_ess is not None
    log_tau = math.log(tempering_ess) if tempering_ess is not None else 0.0
    return _bayes_step(log_weights, log_likelihood, live, log_tau, tempering)  # type: ignore[no-any-return]


def _rows_of(values: object, name: str) -> FloatArray:
    """``values`` as a C-contiguous ``(K, N)`` float64 array, or a ``ValueError``/``TypeError``
    naming ``name``."""
    array = np.asarray(values)
    if array.dtype != np.float64:
        raise TypeError(f"{name} must be a float64 array, got dtype {array.dtype}")
    if array.ndim != 2:
        raise ValueError(f"{name} must have shape (K, N), got {array.shape}")
    return np.ascontiguousarray(array)
