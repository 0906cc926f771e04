r"""Compiled synthesis of the ``fourier`` estimator's kernel spectra (one pass per pose).

For pose ``p`` and particle ``n`` with kernel centre ``c`` and shape ``s``
(:mod:`~infoseek.planners.information.fourier`), the spectrum on harmonics ``k = 0..K`` is

.. math::  X[k] = F(k; s)\, e^{-i w_1 k (c - low)},

where ``F(k; s)`` is interpolated linearly in ``u = log(1 + s) / spacing`` between the shape
nodes ``g = min(floor(u), G - 2)`` and ``g + 1`` (float32: ``F_g + float32(u - g) dF_g``), and the
phase factors are powers of ``e_1 = float32(cos(w_1 (c - low))) - i float32(sin(w_1 (c - low)))``
(``e_k = e_{k - 1} e_1``, complex64). The kernel entropy ``h = h_g + (u - g)(h_{g + 1} - h_g)``
comes with it (float64).

NumPy's ``log1p`` computes ``u`` (its SIMD loop outside the pinned environment is much faster
than the C library's); the kernel does everything else in one pass: the phase ``cos`` and
``sin`` (the C library's, which NumPy's float64 ``cos`` and ``sin`` call too), and NumPy's
complex64 products (:mod:`~infoseek.planners.information.fused`) in the order of the array code
it replaces (the powers first, then each times its coefficient), so the spectra are the same bit
for bit, without the ``(P, N, 2, K + 1)`` gathered coefficient table.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.fused import complex_multiply
from infoseek.planners.information.kernel_arrays import require

__all__ = ["kernel_spectra"]


@kernel
def _spectra(
    u: FloatArray,
    centre: FloatArray,
    low: float,
    frequency: float,
    table: NDArray[np.float32],
    entropies: FloatArray,
    harmonics: int,
    n_rows: int,
) -> tuple[NDArray[np.complex64], FloatArray]:
    n_poses, n = u.shape
    last_node = table.shape[0] - 2
    spectra = np.zeros((n_poses, n_rows, n), dtype=np.complex64)
    entropy = np.empty((n_poses, n))
    coefficient = np.empty((harmonics + 1, n), dtype=np.float32)
    power_real = np.empty(n, dtype=np.float32)
    power_imag = np.empty(n, dtype=np.float32)
    step_real = np.empty(n, dtype=np.float32)
    step_imag = np.empty(n, dtype=np.float32)
    zero = np.float32(0.0)
    for p in range(n_poses):
        for i in range(n):  # per particle: interpolated coefficients, entropy, phase step
            g = min(int(u[p, i]), last_node)
            t = u[p, i] - g
            fraction = np.float32(t)
            for k in range(harmonics + 1):
                coefficient[k, i] = table[g, 1, k] * fraction + table[g, 0, k]
            entropy[p, i] = entropies[g] + t * (entropies[g + 1] - entropies[g])
            # cos - 1j sin in complex128 (1j sin = (0 sin - 1 0, sin)), then complex64
            angle = (centre[p, i] - low) * frequency
            cosine, sine = math.cos(angle), math.sin(angle)
            real_part = (0.0 * sine) + -(1.0 * 0.0)
            step_real[i] = np.float32(cosine - real_part)
            step_imag[i] = np.float32(0.0 - sine)
            power_real[i], power_imag[i] = np.float32(1.0), zero
        out = spectra[p]
        for k in range(harmonics + 1):  # per harmonic: the next power, times its coefficient
            for i in range(n):
                if k == 1:
                    power_real[i], power_imag[i] = step_real[i], step_imag[i]
                elif k > 1:
                    power_real[i], power_imag[i] = complex_multiply(
                        power_real[i], power_imag[i], step_real[i], step_imag[i]
                    )
                real, imag = complex_multiply(power_real[i], power_imag[i], coefficient[k, i], zero)
                out[k, i] = complex(real, imag)
    return spectra, entropy


def kernel_spectra(
    u: FloatArray,
    centre: FloatArray,
    low: float,
    frequency: float,
    table: NDArray[np.float32],
    entropies: FloatArray,
    harmonics: int,
    n_rows: int,
) -> tuple[NDArray[np.complex64], FloatArray]:
    """Spectra and kernel entropies of ``P`` poses (module docstring).

    Args:
        u: ``(P, N)`` shape coordinates ``log1p(clip(s, 0, s_max)) / spacing`` (float64).
        centre: ``(P, N)`` kernel centres ``c`` (float64).
        low: The domain's lower bound.
        frequency: ``w_1 = 2 pi / L``.
        table: ``(G, 2, K' + 1)`` float32 coefficient values and slopes to the next node
            (``G >= 2``, ``K' >= K``).
        entropies: ``(G,)`` kernel entropies at the nodes.
        harmonics: ``K``.
        n_rows: Rows of the spectra, ``Q // 2 + 1 > K`` (those above ``K`` are zero).

    Returns:
        ``(spectra (P, n_rows, N) complex64, entropies (P, N) float64)``.

    Raises:
        TypeError, ValueError: An array of another dtype or shape, or a table too small.
    """
    u = require(u, "u", np.float64, (None, None))
    centre = require(centre, "centre", np.float64, u.shape)
    table = require(table, "table", np.float32, (None, 2, None))
    entropies = require(entropies, "entropies", np.float64, (table.shape[0],))
    if table.shape[0] < 2 or table.shape[2] <= harmonics or n_rows <= harmonics:
        raise ValueError(
            f"table {table.shape} must have >= 2 nodes and more than K = {harmonics} harmonics, "
            f"and n_rows = {n_rows} more than K rows"
        )
    if u.size and not ((u >= 0.0).all() and np.isfinite(u).all()):
        raise ValueError("u must be finite and >= 0")
    return _spectra(  # type: ignore[no-any-return]
        u, centre, float(low), float(frequency), table, entropies, int(harmonics), int(n_rows)
    )
