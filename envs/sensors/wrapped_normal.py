r"""Compiled wrapped-normal log densities of bearing residuals (the image sum of
:mod:`infoseek.envs.sensors.bearing`).

For a residual :math:`x` (any real), :math:`r = |\operatorname{wrap}(x)|` with
:math:`\operatorname{wrap}` into :math:`[-\pi, \pi)` and the image terms
:math:`(a_t, s_t)` of the sensor (distances :math:`a_t + s_t |r|`),

.. math::

    \log p = \log\Bigl(1 + \sum_t e^{\max(c_{1,t} r - c_{2,t},\, -700)}\Bigr)
        - \frac{r^2}{2\sigma^2} + \log\frac{1}{\sigma\sqrt{2\pi}},
    \qquad c_{1,t} = -2 s_t a_t / (2\sigma^2),\ c_{2,t} = a_t^2 / (2\sigma^2).

The clip at ``-700`` keeps ``exp`` out of the subnormals; a clipped term is the constant
``exp(-700)``, and a sum of clipped terms has a constant ``log1p``, so most residuals (those
within about ``pi - 1.1`` of zero for ``sigma = 0.1``) need no ``exp`` or ``log1p`` call at
all, with the same result as evaluating them: a vectorisable pass computes every density as if
all its terms were clipped, and a second pass re-evaluates the few that are not.

:func:`summed_log_likelihood` adds, for every belief, the log densities of the observations it
received, in observation order (a missing observation adds ``0.0``), from bearings computed by
the caller; it is the likelihood pass of the filter (:meth:`~infoseek.envs.belief_batch.
BeliefBatch.log_likelihoods`). Every operation is the one the NumPy form performed, in the same
order, so the numbers are the same bit for bit in the pinned numerical environment.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "ImageSum",
    "bearings_of_groups",
    "summed_log_likelihood",
    "wrapped_log_density",
]

_CLIP = -700.0
_CLIPPED_TERM = math.exp(_CLIP)
_LOW = -math.pi
_PERIOD = 2.0 * math.pi
_INV_PERIOD = 1.0 / _PERIOD


class ImageSum:
    """The constants of a wrapped normal's image sum.

    Args:
        sigma: Noise standard deviation (radians).
        image_terms: ``(a, sign)`` of every image term kept (distance ``a + sign |r|``).
        log_norm: ``-log(sigma sqrt(2 pi))``.
    """

    def __init__(
        self, sigma: float, image_terms: list[tuple[float, float]], log_norm: float
    ) -> None:
        inv_2s2 = 0.5 / sigma**2
        self.inv_2s2 = inv_2s2
        self.slopes = np.array([-sign * 2.0 * a * inv_2s2 for a, sign in image_terms])
        self.offsets = np.array([a * a * inv_2s2 for a, _ in image_terms])
        self.log_norm = log_norm
        clipped = 0.0
        for t in range(len(image_terms)):  # the image sum with every term at the clip
            clipped = _CLIPPED_TERM if t == 0 else clipped + _CLIPPED_TERM
        #: ``(log1p(clipped sum), 1 / (2 sigma^2), log_norm)`` for the kernels.
        self.constants = (math.log1p(clipped), inv_2s2, log_norm)


@kernel
def _wrapped_distance(residual: float) -> float:
    """``|wrap(residual)|`` with ``wrap`` into ``[-pi, pi)`` (branch-free: vectorisable)."""
    shifted = residual - _LOW
    wrapped = shifted - _PERIOD * math.floor(shifted * _INV_PERIOD)
    wrapped = wrapped - _PERIOD if wrapped >= _PERIOD else wrapped
    wrapped = wrapped + _PERIOD if wrapped < 0.0 else wrapped
    return abs(wrapped + _LOW)


@kernel
def _exact_log_density(
    r: float, slopes: FloatArray, offsets: FloatArray, inv_2s2: float, log_norm: float
) -> float:
    """The log density at wrapped distance ``r``, every image term evaluated."""
    total = 0.0
    for t in range(slopes.shape[0]):
        arg = r * slopes[t] - offsets[t]
        term = _CLIPPED_TERM if arg <= _CLIP else math.exp(arg)
        total = term if t == 0 else total + term
    return (math.log1p(total) - (r * r) * inv_2s2) + log_norm


@kernel
def _log_densities(
    residual: FloatArray,
    out: FloatArray,
    distance: FloatArray,
    slopes: FloatArray,
    offsets: FloatArray,
    constants: tuple[float, float, float],
) -> None:
    """Log densities of ``residual`` into ``out`` (``distance`` is scratch of the same length).

    A first, vectorisable pass assumes every image term clipped (``log1p`` of the clipped sum
    is the constant ``constants[0]``); a second pass re-evaluates the few residuals with an
    image term above the clip.
    """
    clipped_log1p, inv_2s2, log_norm = constants
    for i in range(residual.shape[0]):
        r = _wrapped_distance(residual[i])
        distance[i] = r
        out[i] = (clipped_log1p - (r * r) * inv_2s2) + log_norm
    for i in range(residual.shape[0]):
        r = distance[i]
        for t in range(slopes.shape[0]):
            if r * slopes[t] - offsets[t] > _CLIP:
                out[i] = _exact_log_density(r, slopes, offsets, inv_2s2, log_norm)
                break


@kernel
def _wrapped_log_density(
    residual: FloatArray,
    slopes: FloatArray,
    offsets: FloatArray,
    constants: tuple[float, float, float],
) -> FloatArray:
    out = np.empty(residual.shape[0])
    _log_densities(residual, out, np.empty(residual.shape[0]), slopes, offsets, constants)
    return out


def wrapped_log_density(residual: FloatArray, image_sum: ImageSum) -> FloatArray:
    """Log density (module docstring) of every residual.

    Args:
        residual: Residuals ``z - mu`` of any shape (float64).
        image_sum: The sensor's image-sum constants.

    Returns:
        Log densities, the shape of ``residual``.
    """
    residual = np.ascontiguousarray(residual, dtype=np.float64)
    s = image_sum
    flat = _wrapped_log_density(residual.reshape(-1), s.slopes, s.offsets, s.constants)
    return flat.reshape(residual.shape)  # type: ignore[no-any-return]


@kernel
def _summed(
    bearings: FloatArray,
    z: FloatArray,
    received: BoolArray,
    slopes: FloatArray,
    offsets: FloatArray,
    constants: tuple[float, float, float],
) -> FloatArray:
    groups, m, width = bearings.shape
    k_rows = received.shape[0]
    per = k_rows // groups
    n = width // per
    total = np.empty((k_rows, n))
    density = np.empty((m, width))
    residual = np.empty(width)
    distance = np.empty(width)
    for g in range(groups):
        for j in range(m):
            for i in range(width):
                residual[i] = z[g, j] - bearings[g, j, i]
            _log_densities(residual, density[j], distance, slopes, offsets, constants)
        for q in range(per):
            k = g * per + q
            row = total[k]
            for i in range(n):  # observation order; a missing observation adds 0.0
                row[i] = density[0, q * n + i] if received[k, 0] else 0.0
            for j in range(1, m):
                if received[k, j]:
                    for i in range(n):
                        row[i] = row[i] + density[j, q * n + i]
                else:
                    for i in range(n):
                        row[i] = row[i] + 0.0
    return total


@kernel
def _offsets(
    particles: FloatArray, poses: FloatArray, groups: int
) -> tuple[FloatArray, FloatArray]:
    """``(G, M, P)`` offsets ``particle - pose`` along x and y of every group's particles."""
    k_rows, n, _ = particles.shape
    per = k_rows // groups
    m = poses.shape[1]
    dx = np.empty((groups, m, per * n))
    dy = np.empty((groups, m, per * n))
    for g in range(groups):
        for j in range(m):
            px, py = poses[g, j, 0], poses[g, j, 1]
            for q in range(per):
                source = particles[g * per + q]
                for i in range(n):
                    dx[g, j, q * n + i] = source[i, 0] - px
                    dy[g, j, q * n + i] = source[i, 1] - py
    return dx, dy


def bearings_of_groups(particles: FloatArray, poses: FloatArray) -> FloatArray:
    """``(G, M, P)`` unwrapped bearings ``atan2`` from each of group ``g``'s ``M`` poses to
    its ``P = (K / G) N`` particles (the arctangent is NumPy's ufunc: its SIMD loop where
    allowed, the C library's in the pinned environment).

    Args:
        particles: ``(K, N, >= 2)`` particles of ``K`` beliefs, belief ``k`` of group
            ``k // (K / G)``.
        poses: ``(G, M, 2)`` sensor positions.
    """
    particles = np.ascontiguousarray(particles, dtype=np.float64)
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    if particles.shape[0] % poses.shape[0]:
        raise ValueError(f"{particles.shape[0]} beliefs do not split into {poses.shape[0]} groups")
    dx, dy = _offsets(particles, poses, poses.shape[0])
    return np.arctan2(dy, dx, out=dy)


def summed_log_likelihood(
    bearings: FloatArray, z: FloatArray, received: BoolArray, image_sum: ImageSum
) -> FloatArray:
    """``(K, N)`` summed log-likelihood of the bearings each belief received.

    Args:
        bearings: ``(G, M, P)`` noise-free bearings (unwrapped ``atan2``) of the ``P = (K / G)
            * N`` particles of group ``g`` (its beliefs' particles one after the other) seen
            from the ``M`` poses of that group.
        z: ``(G, M)`` observed bearings.
        received: ``(K, M)`` which of its group's observations each belief received.
        image_sum: The sensor's image-sum constants.
    """
    bearings = np.ascontiguousarray(bearings, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    received = np.ascontiguousarray(received, dtype=np.bool_)
    groups, m, width = bearings.shape
    k_rows = received.shape[0]
    if (
        z.shape != (groups, m)
        or received.shape[1] != m
        or k_rows % groups
        or width % (k_rows // groups)
    ):
        raise ValueError(
            f"bearings (G, M, P) = {bearings.shape}, z {z.shape} and received {received.shape} "
            "do not describe G groups of K / G beliefs and M observations"
        )
    s = image_sum
    return _summed(bearings, z, received, s.slopes, s.offsets, s.constants)  # type: ignore[no-any-return]
