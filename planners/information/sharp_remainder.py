r"""The exact MI of shift kernels sharper than the Fourier table: a grid part and a Monte Carlo
remainder with its standard error.

The :mod:`~infoseek.planners.information.fourier` table resolves kernel shapes up to ``s_max``;
the exact beacon receiver's SNR ``rho`` is unbounded (``~10^3`` a few units from the beacon, so
peaks ``~10^-3`` rad wide). For a pose set, split the particles into the *resolved* set ``S``
(shape ``<= s_max`` at every pose) and the *sharp* set ``B``, with weights ``W_S + W_B = 1``, and
the mixture (eq. 15) into ``p = p_S + p_B``, ``p_X = sum_{n in X} w_n f_n`` (``f_n`` the joint
likelihood of particle ``n`` at the ``k`` poses). Then exactly

.. math::

    I = \underbrace{-\int p_S \log p_S - \sum_{n \in S} w_n h_n}_{\text{grid}}
        \; - \underbrace{\int p_S \log\Bigl(1 + \frac{p_B}{p_S}\Bigr)}_{T_S}
        \; + \underbrace{\sum_{n \in B} w_n \,\mathbb E_{f_n}\bigl[\log f_n(z) - \log p(z)\bigr]}
        _{T_B},

(:math:`-\int p \log p = -\int p_S \log p - \int p_B \log p` and
:math:`I = H(z) - \sum_n w_n h_n`), where ``h_n = -int f_n log f_n``. The grid part involves
resolved kernels only: it is the ``fourier`` estimator's sum with the sharp particles' weights set
to zero (the subnormalised mixture's nodal density, ``-sum P log P + W_S k log(cell)``). The two
remainders are expectations over mixture components, estimated by stratified Monte Carlo from
the caller's generator: ``T_S = W_S E[log1p(p_B / p_S)]`` with ``z ~ p_S / W_S`` and
``T_B = W_B E[log f_n(z) - log p(z)]`` with ``n ~ w | B``, ``z ~ f_n`` (``sensor.sample``; the
densities from ``sensor.log_likelihood`` of every particle). Both integrands are tame:
``0 <= T_S <= W_B`` (``log1p x <= x``) and it vanishes as the sharp peaks narrow; for a sharp
particle whose peak no other particle's overlaps, ``log f_n - log p = -log w_n`` up to the small
smooth background, whatever its width. A pilot of ``n_samples // 8`` draws per stratum sets the
Neyman allocation of the rest (draws ``proportional to W sd``); the standard error is
``sqrt(sum W^2 var / m)``.

The conditional entropy reported beside the value uses the table's ``h`` for resolved shapes
and, for sharp ones, the closed form of the beacon kernel's sharp limit: for ``rho -> inf`` the
kernel is the law of ``delta = arcsin S``, ``S ~ N(0, 1 / rho^2)`` (up to ``exp(-rho^2 / 2)``
terms), so ``h = h(S) - E[log cos delta] = log(sqrt(2 pi e) / rho) + 1 / (2 rho^2) +
3 / (4 rho^4) + 5 / (2 rho^6) + ...``, within ``1e-12`` nats of the table at ``rho = 64``.

Cost per pose set with sharp particles: the grid part as in ``fourier``, plus ``n_samples``
draws each evaluating ``k N`` likelihoods (``O(n_samples k N)``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.fft
from numpy.typing import NDArray
from scipy.special import logsumexp

from infoseek.planners.information.base import BeliefMI, FloatArray
from infoseek.planners.information.channels import BATCH_BUDGET, entropy, joint_entropies

if TYPE_CHECKING:
    from infoseek.planners.information.fourier import ShiftKernelEstimator

__all__ = ["sharp_kernel_entropy", "sharp_mi"]

#: ``log sqrt(2 pi e)``.
_HALF_LOG_2PIE = 0.5 * math.log(2.0 * math.pi * math.e)


def sharp_kernel_entropy(shapes: FloatArray) -> FloatArray:
    """Entropy (nats) of the beacon kernel ``f_rho`` for ``rho >= 64`` (module docstring)."""
    s2 = 1.0 / np.square(shapes)
    return _HALF_LOG_2PIE - np.log(shapes) + s2 * (0.5 + s2 * (0.75 + 2.5 * s2))


def sharp_mi(
    estimator: ShiftKernelEstimator,
    belief: BeliefMI,
    poses: FloatArray,
    rng: np.random.Generator,
    n_samples: int,
) -> tuple[float, float, float]:
    """``(I, stderr, H(z | theta))`` of one ``(k, pose_dim)`` pose set (module docstring).

    Args:
        estimator: The ``fourier`` estimator (its table, grid and caches).
        belief: The bound belief.
        poses: ``(k, pose_dim)`` poses.
        rng: The caller's generator.
        n_samples: Monte Carlo draws in all (both strata).
    """
    _, shapes = estimator.sensor.kernel_parameters(poses, belief.particles)  # type: ignore[attr-defined]
    shapes = np.asarray(shapes, dtype=np.float64)  # (k, N)
    weights = belief.weights
    sharp = (shapes > estimator.table.max_shape).any(axis=0) & (weights > 0)
    kept = np.where(sharp, 0.0, weights)
    grid = _grid_part(estimator, belief, poses, kept, shapes)
    strata = [(False, float(kept.sum())), (True, float(weights[sharp].sum()))]
    strata = [(is_sharp, mass) for is_sharp, mass in strata if mass > 0.0]
    pilot = max(2, n_samples // 8)
    draws = [_draw(estimator, belief, poses, sharp, s, pilot, rng) for s, _ in strata]
    spreads = [mass * float(np.std(d, ddof=1)) for (_, mass), d in zip(strata, draws, strict=True)]
    rest = max(0, n_samples - pilot * len(strata))
    total = sum(spreads)
    for i, (is_sharp, _) in enumerate(strata):
        extra = int(rest * spreads[i] / total) if total > 0 else rest // len(strata)
        if extra > 0:
            more = _draw(estimator, belief, poses, sharp, is_sharp, extra, rng)
            draws[i] = np.concatenate([draws[i], more])
    value, variance = grid, 0.0
    for (is_sharp, mass), d in zip(strata, draws, strict=True):
        value += (mass if is_sharp else -mass) * float(d.mean())
        variance += mass**2 * float(d.var(ddof=1)) / d.size
    entropies = np.where(
        shapes > estimator.table.max_shape,
        sharp_kernel_entropy(np.maximum(shapes, 1.0)),
        estimator.table.entropy_at(shapes),
    )
    return value, math.sqrt(variance), float(entropies.sum(axis=0) @ weights)


def _grid_part(
    estimator: ShiftKernelEstimator,
    belief: BeliefMI,
    poses: FloatArray,
    kept: FloatArray,
    shapes: FloatArray,
) -> float:
    """``-int p_S log p_S - sum_S w_n h_n`` on the estimator's grid (``kept``: the weights with
    the sharp particles' set to zero)."""
    mass = float(kept.sum())
    if mass == 0.0:
        return 0.0
    k = poses.shape[0]
    conditional = float(estimator.table.entropy_at(shapes).sum(axis=0) @ kept)
    if k == 1:
        spectra, _ = estimator.spectra(belief, poses)
        mixture = (spectra[0] @ kept.astype(np.complex64)).astype(np.complex128)
        nodal = scipy.fft.irfft(mixture, n=estimator.n_points)
        discrete = float(entropy(nodal, (0,)))
    else:
        channels = [
            np.swapaxes(estimator.channels(belief, poses[j : j + 1])[0], 1, 2).astype(np.float64)
            for j in range(k)
        ]
        discrete = float(joint_entropies(channels, kept)[0][0])
    return discrete + mass * k * estimator.log_spacing - conditional


def _draw(
    estimator: ShiftKernelEstimator,
    belief: BeliefMI,
    poses: FloatArray,
    sharp: NDArray[np.bool_],
    from_sharp: bool,
    size: int,
    rng: np.random.Generator,
) -> FloatArray:
    """``size`` Monte Carlo terms of one stratum: ``log f_n(z) - log p(z)`` with ``n ~ w | B``,
    ``z ~ f_n`` (``from_sharp``), else ``log1p(p_B(z) / p_S(z))`` with ``z ~ p_S / W_S``."""
    sensor, particles = estimator.sensor, belief.particles
    n, k = particles.shape[0], poses.shape[0]
    members = np.flatnonzero(sharp if from_sharp else ~sharp)
    chance = belief.weights[members] / belief.weights[members].sum()
    log_w = np.log(belief.weights, where=belief.weights > 0, out=np.full(n, -np.inf))
    chunk = max(1, BATCH_BUDGET // (2 * k * n))
    terms = []
    for start in range(0, size, chunk):
        m = min(chunk, size - start)
        index = members[rng.choice(members.size, size=m, p=chance)]
        z = np.asarray(sensor.sample(poses[None], particles[index][:, None, :], rng))
        log_lik = np.asarray(
            sensor.log_likelihood(z, poses[None], particles), dtype=np.float64
        ).sum(axis=1)  # (m, N)
        joint = log_lik + log_w
        log_b = logsumexp(joint[:, sharp], axis=1)
        if from_sharp:
            terms.append(log_lik[np.arange(m), index] - np.logaddexp(log_b, _log_s(joint, sharp)))
        else:
            terms.append(np.logaddexp(0.0, log_b - _log_s(joint, sharp)))
    values = np.concatenate(terms)
    if not np.all(np.isfinite(values)):
        raise ValueError(
            "sharp-kernel Monte Carlo produced non-finite terms (likelihood underflow)"
        )
    return values


def _log_s(joint: FloatArray, sharp: NDArray[np.bool_]) -> FloatArray:
    """``log p_S(z)`` of each draw from the ``(m, N)`` ``log w_n f_n(z)``."""
    if sharp.all():
        return np.full(joint.shape[0], -np.inf)
    return np.asarray(logsumexp(joint[:, ~sharp], axis=1))
