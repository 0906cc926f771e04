r"""Progressive correction's arithmetic: the tempering exponent and the moves' acceptance.

A belief of normalised log-weights :math:`\ell` that receives observations of summed
log-likelihood :math:`L` is updated in stages (:mod:`infoseek.envs.belief`). Each stage takes
the largest exponent :math:`\lambda \in (0, r]` of the remainder :math:`r` that keeps

.. math:: \log \mathrm{ESS}(\ell + \lambda L) = 2 \log Z(\ell + \lambda L)
          - \log Z(2 (\ell + \lambda L)) \ \ge\ \log \phi,

with :math:`\log Z(v) = m + \log \sum_n e^{v_n - m}`, :math:`m = \max_n v_n`, and
:math:`\log \phi` the stage's floor. :func:`tempering_exponent` bisects on :math:`\log \lambda`
over :math:`[\log r - 60, \log r]` in ``steps`` halvings, keeping the largest exponent it has
seen pass. From equal weights (those resampling leaves) the ESS falls as the exponent grows:
:math:`\frac{d}{d\lambda} \log \sum_n p_n^2 = 2 (E_{2 \lambda}[L] - E_\lambda[L]) \ge 0` for
:math:`p \propto e^{\lambda L}`, the mean of :math:`L` under :math:`p \propto e^{\lambda L}`
growing with :math:`\lambda`; so there the passing exponents form an interval and the
bisection finds its end. When even :math:`\lambda = r e^{-60}` fails (a belief whose particles
all have zero likelihood, say) that smallest exponent is returned.

After resampling, each stage moves the particles by Metropolis sweeps whose target is the
stage's exact posterior: a proposal :math:`\theta'` of particle :math:`\theta` is accepted when

.. math:: \log u < \lambda_{\mathrm{so\,far}} (L(\theta') - L(\theta)) + (H(\theta') - H(\theta)),

with :math:`H` the log-likelihood of the belief's earlier observations and :math:`u` uniform on
``[0, 1)`` (:func:`metropolis_accept`); an impossible particle and proposal (``-inf - -inf``)
are rejected.

Each log normaliser evaluation is two compiled passes around one NumPy ``exp`` of the
``(2, N)`` exponents, with the arithmetic of the NumPy form (the same operations in the same
order, NumPy's pairwise sums; :mod:`infoseek.envs.log_weights`), so the exponents found are
those of evaluating :math:`\log \mathrm{ESS}` with NumPy calls, bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum
from infoseek.envs.log_weights import log_normaliser

FloatArray = NDArray[np.float64]

__all__ = ["LOG_MIN_EXPONENT", "TemperedLogEss", "metropolis_accept", "tempering_exponent"]

#: Smallest tempering exponent tried, in nats below the remainder (``r exp(-60)``).
LOG_MIN_EXPONENT = -60.0


@kernel
def _tempered_exponents(
    log_weights: FloatArray, log_likelihood: FloatArray, scale: float, out: FloatArray
) -> float:
    """Fill ``(2, N)`` ``out`` with the exponents of ``log Z(v)`` (row 0) and ``log Z(2 v)``
    (row 1) for ``v = log_weights + scale * log_likelihood``; return ``max v`` (NaN if ``v``
    holds one)."""
    n = log_weights.shape[0]
    top = -math.inf
    nan = False
    for i in range(n):
        value = log_weights[i] + scale * log_likelihood[i]
        out[0, i] = value
        if value > top:
            top = value
        elif value != value:
            nan = True
    if nan:
        top = math.nan
    shift = top if math.isfinite(top) else 0.0
    shift_twice = 2.0 * top if math.isfinite(2.0 * top) else 0.0
    for i in range(n):
        value = out[0, i]
        out[0, i] = value - shift
        out[1, i] = 2.0 * value - shift_twice
    return top


@kernel
def _log_ess(top: float, exponentials: FloatArray) -> float:
    """``2 log Z(v) - log Z(2 v)`` from ``max v`` and the ``exp`` of
    :func:`_tempered_exponents`' rows (``log Z`` is ``max`` itself where that is not finite)."""
    once = log_normaliser(top, pairwise_sum(exponentials[0]))
    return 2.0 * once - log_normaliser(2.0 * top, pairwise_sum(exponentials[1]))


class TemperedLogEss:
    """``log ESS(log_weights + lambda * log_likelihood)`` as a function of ``lambda`` (the
    numbers of evaluating it with NumPy calls), with the ``(2, N)`` exponent buffer it reuses.

    Args:
        log_weights: ``(N,)`` C-contiguous float64 log-weights.
        log_likelihood: ``(N,)`` C-contiguous float64 log-likelihoods (``-inf`` allowed).
    """

    def __init__(self, log_weights: FloatArray, log_likelihood: FloatArray) -> None:
        self._log_weights = log_weights
        self._log_likelihood = log_likelihood
        self._buffer = np.empty((2, log_weights.shape[0]))

    def __call__(self, exponent: float) -> float:
        top = _tempered_exponents(self._log_weights, self._log_likelihood, exponent, self._buffer)
        np.exp(self._buffer, out=self._buffer)
        return float(_log_ess(top, self._buffer))


def tempering_exponent(
    log_weights: FloatArray,
    log_likelihood: FloatArray,
    remaining: float,
    log_floor: float,
    steps: int,
) -> float:
    """Largest ``lambda`` in ``(0, remaining]`` with ``log ESS(log_weights + lambda *
    log_likelihood) >= log_floor``, by bisection on ``log lambda`` (module docstring).

    Args:
        log_weights: ``(N,)`` log-weights of the belief before the stage.
        log_likelihood: ``(N,)`` summed log-likelihood of the stage's observations (``-inf``
            allowed, no NaN).
        remaining: The exponent not yet applied, in ``(0, 1]``.
        log_floor: The stage's floor on the log ESS.
        steps: Number of halvings of the search interval.

    Returns:
        The exponent: ``exp`` of the bisection's last passing ``log lambda``, or
        ``remaining * exp(LOG_MIN_EXPONENT)`` when even that fails.
    """
    log_weights = np.ascontiguousarray(log_weights, dtype=np.float64)
    log_likelihood = np.ascontiguousarray(log_likelihood, dtype=np.float64)
    if log_likelihood.shape != log_weights.shape or log_weights.ndim != 1:
        raise ValueError(
            f"log_weights and log_likelihood must have one shape (N,), got "
            f"{log_weights.shape} and {log_likelihood.shape}"
        )
    log_ess = TemperedLogEss(log_weights, log_likelihood)
    hi = math.log(remaining)
    lo = hi + LOG_MIN_EXPONENT
    if log_ess(math.exp(lo)) < log_floor:
        return math.exp(lo)
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if log_ess(math.exp(mid)) >= log_floor:
            lo = mid
        else:
            hi = mid
    return math.exp(lo)


@kernel
def metropolis_accept(
    particles: FloatArray,
    log_likelihood: FloatArray,
    past_log_likelihood: FloatArray,
    proposal: FloatArray,
    proposal_log_likelihood: FloatArray,
    proposal_past: FloatArray,
    log_uniforms: FloatArray,
    exponent: float,
) -> None:
    """One Metropolis sweep's acceptance, in place (module docstring): where ``log_uniforms``
    is below the log ratio, the particle (``(N, d)``), its ``log_likelihood`` and its
    ``past_log_likelihood`` (``(N,)`` each) take the proposal's."""
    for i in range(particles.shape[0]):
        ratio = exponent * (proposal_log_likelihood[i] - log_likelihood[i]) + (
            proposal_past[i] - past_log_likelihood[i]
        )
        if log_uniforms[i] < ratio:
            for j in range(particles.shape[1]):
                particles[i, j] = proposal[i, j]
            log_likelihood[i] = proposal_log_likelihood[i]
            past_log_likelihood[i] = proposal_past[i]
