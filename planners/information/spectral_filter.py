r"""Compiled multiplication of two-dimensional grid spectra by a separable noise spectrum.

The ``fft`` estimator convolves each ``Q x Q`` pair histogram with the noise density along both
axes by multiplying its ``rfft2`` spectrum ``S[b, u, v]`` by the full-length noise spectrum
``K_full[u]`` along the first grid axis, then by the half spectrum ``K_half[v]`` along the
second (:meth:`~infoseek.planners.information.noise_kernel.NoiseKernel.smoothed_entropy`). NumPy
does that in two in-place passes of complex128 products, which it rounds with fused
multiply-adds (:mod:`~infoseek.planners.information.fused`); :func:`filter_spectra` does both
products in one pass, in the same order and with the same roundings, so the spectra are the same
bit for bit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel
from infoseek.planners.information.fused import complex_multiply
from infoseek.planners.information.kernel_arrays import require

__all__ = ["filter_spectra"]


@kernel
def _filter(
    spectra: NDArray[np.complex128], full: NDArray[np.complex128], half: NDArray[np.complex128]
) -> None:
    for b in range(spectra.shape[0]):
        for u in range(spectra.shape[1]):
            first = full[u]
            for v in range(spectra.shape[2]):
                value = spectra[b, u, v]
                real, imag = complex_multiply(value.real, value.imag, first.real, first.imag)
                real, imag = complex_multiply(real, imag, half[v].real, half[v].imag)
                spectra[b, u, v] = complex(real, imag)


def filter_spectra(
    spectra: NDArray[np.complex128], full: NDArray[np.complex128], half: NDArray[np.complex128]
) -> None:
    """``spectra[b, u, v] *= full[u]``, then ``*= half[v]``, in place (module docstring).

    Args:
        spectra: ``(B, L, R)`` complex128 spectra (C-contiguous; modified).
        full: ``(L,)`` complex128 spectrum along the first grid axis.
        half: ``(R,)`` complex128 spectrum along the second grid axis.

    Raises:
        TypeError, ValueError: Arrays of another dtype or shape, or ``spectra`` not contiguous.
    """
    if not (isinstance(spectra, np.ndarray) and spectra.flags.c_contiguous):
        raise ValueError("spectra must be a C-contiguous numpy array (it is filtered in place)")
    spectra = require(spectra, "spectra", np.complex128, (None, None, None))
    full = require(full, "full", np.complex128, (spectra.shape[1],))
    half = require(half, "half", np.complex128, (spectra.shape[2],))
    _filter(spectra, full, half)
