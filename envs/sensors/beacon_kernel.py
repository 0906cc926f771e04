r"""The beacon log-likelihood of many readings, summed per belief and particle (compiled).

For readings :math:`z_{gm}` taken at receivers :math:`p_{gm}` (``G`` groups of ``M``) and
``K`` beliefs of ``N`` beacon hypotheses :math:`\theta_{kn}` (belief ``k`` in group
``k // (K / G)``), :func:`summed_beacon_log_likelihood` returns
:math:`\sum_m [\text{received}_{km}] \log p(z_{gm} \mid p_{gm}, \theta_{kn})` with the folded
projected-normal density of :class:`~infoseek.envs.sensors.beacon.BeaconSensor` (its module
docstring), capped at ``max_snr`` as the sensor caps it. It serves the filter's Bayes update
(groups = environments, ``M`` = agents) and its Metropolis moves, which evaluate a belief's
whole kept history (one group of ``M`` = all its readings) at every proposal.

The arithmetic is the sensor's, operation by operation and in the same order: the field
``(H_r, H_psi)`` rotated into the world frame, scaled by ``1 / noise_std``, shrunk to
``max_snr``, projected along and across ``z``; ``log erf`` switching to ``log1p(-erfc)`` at
0.5; the two terms combined as NumPy's ``logaddexp`` combines them; the readings summed in
order (a reading not received adds ``0.0``), as NumPy sums a leading axis. ``erf`` and ``erfc``
are SciPy's (which differ from the C library's in the last bits), called from the compiled pass
through SciPy's Cython interface (``scipy.special.cython_special``: the functions its ufuncs
call, registered with LLVM under a name of our own so that the kernels can be cached);
everything else runs with the C library's transcendentals.
In the pinned numerical environment (:mod:`infoseek.envs.compiled`) the result therefore
equals the masked sum of ``BeaconSensor.log_likelihood`` bit for bit
(``tests/test_filter_kernels.py``). The C library's ``pow(r, 3)`` and the other
transcendentals, which both versions call once per reading and particle, dominate the cost.
"""

from __future__ import annotations

import math
from typing import Any

import llvmlite.binding as llvm
import numpy as np
from numba import types
from numba.extending import get_cython_function_address
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

FloatArray = NDArray[np.float64]

__all__ = ["summed_beacon_log_likelihood"]

_LOG_PI = math.log(math.pi)
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_LOG_2 = 0.693147180559945309417232121458176568  # NumPy's NPY_LOGE2
_MIN_ALONG = 1e-150
_SQRT_HALF = math.sqrt(0.5)
_MIN_DISTANCE = 1e-3


def _scipy_special(name: str) -> Any:
    """SciPy's real ``name`` (``erf``, ``erfc``) as a function the kernels (only) call by a
    symbol of our own (``double f(double x, int skip_dispatch)``, Cython's signature)."""
    symbol = f"infoseek_scipy_special_{name}"
    address = get_cython_function_address("scipy.special.cython_special", f"__pyx_fuse_1{name}")
    llvm.add_symbol(symbol, address)
    return types.ExternalFunction(symbol, types.float64(types.float64, types.intc))


_erf = _scipy_special("erf")
_erfc = _scipy_special("erfc")


@kernel
def _projections(
    z: FloatArray,
    poses: FloatArray,
    particles: FloatArray,
    moment: float,
    noise_std: float,
    max_snr: float,
    along: FloatArray,
    across: FloatArray,
) -> None:
    """Per belief ``k``, reading ``m`` of its group and particle ``n``: ``|a|`` and ``b``, the
    components of the scaled field ``mu`` along and across ``z[g, m]``, into ``along[k, m, n]``
    and ``across[k, m, n]``."""
    inv = 1.0 / noise_std
    capped = max_snr != math.inf
    per = particles.shape[0] // z.shape[0]
    for k in range(particles.shape[0]):
        g = k // per
        cos_psi, sin_psi = np.cos(particles[k, :, 2]), np.sin(particles[k, :, 2])
        for m in range(z.shape[1]):
            cos_z, sin_z = math.cos(z[g, m]), math.sin(z[g, m])
            for n in range(particles.shape[1]):
                dx = poses[g, m, 0] - particles[k, n, 0]
                dy = poses[g, m, 1] - particles[k, n, 1]
                distance = math.hypot(dx, dy)
                at_antenna = distance == 0.0
                nonzero = 1.0 if at_antenna else distance
                cos_phi = 1.0 if at_antenna else dx / nonzero
                sin_phi = dy / nonzero
                scale = moment / math.pow(max(distance, _MIN_DISTANCE), 3.0)
                cos_a, sin_a = cos_psi[n], sin_psi[n]
                h_r = (2.0 * scale) * (cos_phi * cos_a + sin_phi * sin_a)
                h_psi = scale * (sin_phi * cos_a - cos_phi * sin_a)
                mu_x = (h_r * cos_phi - h_psi * sin_phi) * inv
                mu_y = (h_r * sin_phi + h_psi * cos_phi) * inv
                if capped:
                    norm = max(math.hypot(mu_x, mu_y), 1e-300)
                    shrink = min(1.0, max_snr / norm)
                    mu_x, mu_y = mu_x * shrink, mu_y * shrink
                along[k, m, n] = abs(mu_x * cos_z + mu_y * sin_z)
                across[k, m, n] = mu_x * sin_z - mu_y * cos_z


@kernel
def _log_add_exp(x: float, y: float) -> float:
    """NumPy's ``logaddexp`` of two floats (same branches, same operations)."""
    if x == y:
        return x + _LOG_2
    difference = x - y
    if difference > 0:
        return x + math.log1p(math.exp(-difference))
    if difference <= 0:
        return y + math.log1p(math.exp(difference))
    return difference


@kernel
def _erf_part(along: float) -> float:
    """``erf(x)`` where ``x = max(|a|, 1e-150) / sqrt 2 < 0.5``, else ``erfc(x)`` (NaN stays
    NaN, as in NumPy's ``maximum``), SciPy's values."""
    x = (along if along != along or along > _MIN_ALONG else _MIN_ALONG) * _SQRT_HALF
    return _erf(x, 0) if x < 0.5 else _erfc(x, 0)


@kernel
def _summed_log_density(
    along: FloatArray,
    across: FloatArray,
    received: NDArray[np.bool_],
    total: FloatArray,
) -> bool:
    """``total[k, n] = sum_m log p`` over the readings belief ``k`` received (a reading it
    did not receive adds ``0.0``, as in NumPy's masked sum), from the projections;
    ``False`` if some total is NaN or ``+inf``."""
    ok = True
    for k in range(along.shape[0]):
        for m in range(along.shape[1]):
            for n in range(along.shape[2]):
                value = 0.0
                if received[k, m]:
                    a, b = along[k, m, n], across[k, m, n]
                    uniform_part = -0.5 * (a * a + b * b) - _LOG_PI
                    erf_part = _erf_part(a)
                    a = max(a, _MIN_ALONG)
                    if a * _SQRT_HALF < 0.5:
                        log_erf = math.log(erf_part)
                    else:
                        log_erf = math.log1p(-erf_part)
                    peak_part = -0.5 * b * b - _LOG_SQRT_2PI + math.log(a) + log_erf
                    value = _log_add_exp(uniform_part, peak_part)
                total[k, n] = value if m == 0 else total[k, n] + value
        for n in range(along.shape[2]):
            if math.isnan(total[k, n]) or total[k, n] == math.inf:
                ok = False
    return ok


def summed_beacon_log_likelihood(
    z: FloatArray,
    poses: FloatArray,
    particles: FloatArray,
    received: NDArray[np.bool_],
    sensor: tuple[float, float, float],
) -> tuple[FloatArray, bool]:
    """Per belief and particle, ``sum_m log p(z_gm | poses_gm, particles_kn)`` over the
    readings the belief received, and whether every sum is free of NaN and ``+inf``.

    Args:
        z: ``(G, M)`` float64 readings of ``G`` groups (any real; the density has period
            ``pi``), ``M >= 1``.
        poses: ``(G, M, 2)`` float64 receiver positions.
        particles: ``(K, N, 3)`` float64 beacon hypotheses ``(x_a, y_a, psi_a)`` of ``K``
            beliefs; belief ``k`` belongs to group ``k // (K / G)``.
        received: ``(K, M)`` bool, which of its group's readings each belief received.
        sensor: The sensor's ``(moment, noise_std, max_snr)`` (``max_snr`` ``inf``: no cap).

    Returns:
        ``(total, ok)``: the ``(K, N)`` sums, and ``False`` if one of them is NaN or ``+inf``.

    Raises:
        TypeError: If an array has the wrong dtype.
        ValueError: If the shapes do not match.
    """
    _check(z, poses, particles, received)
    shape = (particles.shape[0], z.shape[1], particles.shape[1])
    along, across = np.empty(shape), np.empty(shape)
    z, poses, particles = (np.ascontiguousarray(a) for a in (z, poses, particles))
    moment, noise_std, max_snr = (float(value) for value in sensor)
    _projections(z, poses, particles, moment, noise_std, max_snr, along, across)
    total = np.empty(shape[::2])
    ok = _summed_log_density(along, across, np.ascontiguousarray(received), total)
    return total, bool(ok)


def _check(
    z: FloatArray, poses: FloatArray, particles: FloatArray, received: NDArray[np.bool_]
) -> None:
    """The dtypes and shapes :func:`summed_beacon_log_likelihood` needs (its Raises)."""
    owner = "summed_beacon_log_likelihood"
    for name, array in (("z", z), ("poses", poses), ("particles", particles)):
        if not isinstance(array, np.ndarray) or array.dtype != np.float64:
            raise TypeError(f"{owner}: {name} must be a float64 array")
    if not isinstance(received, np.ndarray) or received.dtype != np.bool_:
        raise TypeError(f"{owner}: received must be a bool array")
    if z.ndim != 2 or z.shape[1] < 1 or poses.shape != z.shape + (2,):
        raise ValueError(
            f"{owner}: expected z (G, M) with M >= 1 and poses (G, M, 2), got z {z.shape} "
            f"and poses {poses.shape}"
        )
    if particles.ndim != 3 or particles.shape[2] != 3 or particles.shape[0] % z.shape[0]:
        raise ValueError(
            f"{owner}: particles must be (K, N, 3) with K a multiple of G = {z.shape[0]}, got "
            f"{particles.shape}"
        )
    if received.shape != (particles.shape[0], z.shape[1]):
        raise ValueError(
            f"{owner}: received must be (K, M) = {(particles.shape[0], z.shape[1])}, got "
            f"{received.shape}"
        )
