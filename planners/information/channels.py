r"""Discrete channels: the MI of a particle belief observed through row-stochastic matrices.

Several estimators reduce the observation of pose ``p`` to a *channel*: a ``(N, Q)`` matrix
``P_p`` whose row ``n`` is the probability of each of ``Q`` observation cells given particle
``n`` (likelihood values on quadrature nodes, exact bin probabilities, or a Fourier-synthesised
kernel). For ``k`` conditionally independent observations and weights ``w``

.. math::

    H(z) = H\Big(\sum_n w_n P_1[n] \otimes \dots \otimes P_k[n]\Big), \qquad
    H(z \mid \theta) = \sum_j \sum_n w_n H(P_j[n]),

discrete entropies whose difference is the exact MI of the discretised channel
(``0 <= I <= k log Q``). The joint of two channels is the matrix product
``P_a^T diag(w) P_b`` (eq. 15 on the grid), of three the same product over a ``Q^2 x Q`` grid.
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.planners.information.base import BeliefMI, FloatArray, JointEntropies, MIEstimator

__all__ = [
    "BATCH_BUDGET",
    "ChannelEstimator",
    "conditional_entropies",
    "entropy",
    "joint_entropies",
    "pair_joint_entropies",
]

#: Floats one chunk of a batched computation may hold at once (64 MB of float64).
BATCH_BUDGET = 1 << 23
_TINY64 = 1e-300
_TINY32 = 1e-38


def entropy(p: NDArray[Any], axes: tuple[int, ...]) -> NDArray[Any]:
    """Shannon entropy ``-sum p log p`` over ``axes`` (``0 log 0 = 0``; negatives count as 0)."""
    p = np.maximum(p, _TINY64 if p.dtype == np.float64 else _TINY32)
    return -np.sum(p * np.log(p), axis=axes)


def conditional_entropies(channels: FloatArray, weights: FloatArray) -> FloatArray:
    """``(P,)`` values of ``sum_n w_n H(P[p, n])`` for ``(P, N, Q)`` channels."""
    return np.einsum("pnq,n->p", -channels * np.log(np.maximum(channels, _TINY64)), weights)


def joint_entropies(
    channels: Sequence[FloatArray], weights: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Discrete ``(H(z), H(z | theta))``, each ``(B,)``, of ``k`` channels ``(B, N, Q)``."""
    k = len(channels)
    conditional = sum(conditional_entropies(channel, weights) for channel in channels)
    batch, n = channels[0].shape[:2]
    product = channels[0] * weights[:, None]
    for channel in channels[1:-1]:
        product = (product[..., :, None] * channel[..., None, :]).reshape(batch, n, -1)
    if k == 1:
        joint = product.sum(axis=1)
    else:
        joint = np.matmul(np.swapaxes(product, 1, 2), channels[-1])
    return entropy(joint.reshape(batch, -1), (1,)), np.asarray(conditional)


def pair_joint_entropies(
    channels_a: NDArray[Any], channels_b: NDArray[Any], weights: FloatArray
) -> FloatArray:
    """``(C, M)`` discrete joint entropies ``H(z_a, z_b)`` of every pair of channels.

    Args:
        channels_a: ``(C, N, Q)`` channels of one side.
        channels_b: ``(M, N, Q)`` channels of the other side (same dtype).
        weights: ``(N,)`` normalised particle weights.

    The joints ``P_a^T diag(w) P_b`` of all pairs are one matrix product per chunk of ``a``.
    """
    n_a, n_b = channels_a.shape[0], channels_b.shape[0]
    n, q = channels_a.shape[1:]
    result = np.empty((n_a, n_b))
    right = np.transpose(channels_b, (1, 0, 2)).reshape(n, n_b * q)
    scaled = weights.astype(channels_a.dtype)[:, None]
    chunk = max(1, BATCH_BUDGET // (n_b * q * q + n * q))
    for start in range(0, n_a, chunk):
        stop = min(start + chunk, n_a)
        left = np.transpose(channels_a[start:stop] * scaled, (0, 2, 1))
        joint = (left.reshape(-1, n) @ right).reshape(stop - start, q, n_b, q)
        joint = np.transpose(joint, (0, 2, 1, 3)).reshape(stop - start, n_b, q * q)
        result[start:stop] = entropy(joint, (2,))
    return result


class ChannelEstimator(MIEstimator):
    """An estimator that reduces each pose's observation to a discrete channel (module doc).

    Subclasses implement :meth:`cells` (grid size for ``k`` joint observations; the same for
    ``k = 1`` and ``k = 2``), :meth:`compute_channels` and, for grids of a continuous
    observation, :meth:`log_cell` (the log cell width that turns the discrete entropies into
    differential ones).
    """

    @abstractmethod
    def cells(self, k: int) -> int:
        """Number of observation cells per observation for ``k`` joint observations."""

    @abstractmethod
    def compute_channels(self, poses: FloatArray, particles: FloatArray, q: int) -> FloatArray:
        """``(P, N, q)`` row-stochastic channels of ``(P, pose_dim)`` poses."""

    def log_cell(self, q: int) -> float:
        """Log cell width of a ``q``-cell grid (0: report discrete entropies)."""
        return 0.0

    def channels(
        self, belief: BeliefMI, poses: FloatArray, k: int
    ) -> tuple[FloatArray, FloatArray]:
        """Channels ``(P, N, Q)`` and conditional entropies ``(P,)``, cached per pose."""
        q = self.cells(k)

        def compute(missing: FloatArray) -> list[tuple[FloatArray, float]]:
            fresh = self.compute_channels(missing, belief.particles, q)
            conditional = conditional_entropies(fresh, belief.weights)
            return [(fresh[p], float(conditional[p])) for p in range(missing.shape[0])]

        entries = belief.per_pose(f"channels/{q}", poses, compute)
        return np.stack([c for c, _ in entries]), np.array([h for _, h in entries])

    def joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        n_sets, k = pose_sets.shape[:2]
        q = self.cells(k)
        n = belief.n_particles
        per_set = 2 * k * n * q + n * q ** max(k - 1, 1) + q**k
        chunk = max(1, BATCH_BUDGET // per_set)
        entropy_z = np.empty(n_sets)
        conditional = np.zeros(n_sets)
        for start in range(0, n_sets, chunk):
            block = pose_sets[start : start + chunk]
            part = slice(start, start + block.shape[0])
            channels = []
            for j in range(k):
                channel, entropies = self.channels(belief, block[:, j], k)
                channels.append(channel)
                conditional[part] += entropies
            entropy_z[part] = joint_entropies(channels, belief.weights)[0]
        log_cell = k * self.log_cell(q)
        return JointEntropies.from_entropies(entropy_z + log_cell, conditional + log_cell)

    def pairs(self, belief: BeliefMI, poses_a: FloatArray, poses_b: FloatArray) -> FloatArray:
        channels_a, conditional_a = self.channels(belief, poses_a, 2)
        channels_b, conditional_b = self.channels(belief, poses_b, 2)
        joint = pair_joint_entropies(channels_a, channels_b, belief.weights)
        return joint - conditional_a[:, None] - conditional_b[None, :]
