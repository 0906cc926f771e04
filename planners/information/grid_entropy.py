r"""Compiled normalisation and entropy sums of the smoothed observation grids.

The ``fft`` estimator turns every convolved grid row ``x`` (one observation density per pose or
pair, ``L`` cells) into a discrete entropy

.. math::  p_i = \frac{c(x_i)}{\sum_j c(x_j)}, \qquad H = -\sum_i p_i \log p_i,

with ``c`` a clamp of the FFT's (or the float32 product's) rounding: float64 grids clamp at
``0`` and divide by ``max(sum, 1e-30)``, then clamp ``p`` at ``1e-300``; float32 window grids
clamp at ``1e-38`` and divide by the float64 sum rounded to float32. The logarithm is left to
NumPy's ufunc between the two kernels here (its SIMD loops are much faster than the C library's
``log`` outside the pinned environment, and they are NumPy's bits inside it); the kernels do the
passes around it. Sums are NumPy's: the pairwise summation of :func:`~infoseek.envs.compiled.
pairwise_sum` over a float64 row, and for float32 rows summed as float64 the same over blocks of
8192 values (NumPy's casting buffer) added in order. So the entropies are the NumPy ones bit for
bit.

The float32 floor ``1e-38`` is subnormal (below ``2^-126``), and so is its quotient by a row's
sum: typically a tenth of a window grid's cells. Arithmetic with a subnormal operand (a
division, a product, NumPy's SIMD logarithm of a vector holding one) costs a microcode assist
on many x86-64 CPUs, about a hundred cycles. :func:`float32_grid_entropies` therefore divides,
takes the logarithm and multiplies for the floor once per row and leaves the vectorised passes
only normal operands: the same IEEE operations on the same operands, fewer of them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum
from infoseek.planners.information.base import FloatArray
from infoseek.planners.information.kernel_arrays import require

__all__ = ["entropy_sums", "float32_grid_entropies", "normalise_rows", "pair_grids"]

#: Values NumPy casts per buffer in a reduction with a ``dtype`` (its default buffer size).
CAST_BLOCK = 8192
#: The clamp of float32 grids (a subnormal number: below :data:`SMALLEST_NORMAL32`).
FLOOR32 = np.float32(1e-38)
#: The smallest positive normal float32 (``2^-126``).
SMALLEST_NORMAL32 = np.finfo(np.float32).smallest_normal


@kernel
def _buffered_sum(values: FloatArray) -> float:
    """NumPy's sum of a row converted to float64 in buffers of :data:`CAST_BLOCK` values."""
    total = 0.0
    for start in range(0, values.shape[0], CAST_BLOCK):
        total += pairwise_sum(values[start : min(start + CAST_BLOCK, values.shape[0])])
    return total


@kernel
def _normalise64(rows: FloatArray) -> None:
    buffer = np.empty(rows.shape[1])
    for r in range(rows.shape[0]):
        for i in range(rows.shape[1]):
            value = rows[r, i]
            buffer[i] = value if value >= 0.0 else 0.0
        total = pairwise_sum(buffer)
        total = total if total >= 1e-30 else 1e-30
        for i in range(rows.shape[1]):
            value = buffer[i] / total
            rows[r, i] = value if value >= 1e-300 else 1e-300


@kernel
def _normalise32(rows: NDArray[np.float32]) -> NDArray[np.float32]:
    """Normalise in place (module docstring); returns each row's quotient of the floor."""
    buffer = np.empty(rows.shape[1])
    floor_quotients = np.empty(rows.shape[0], dtype=np.float32)
    for r in range(rows.shape[0]):
        row = rows[r]
        others = 0  # subnormal values other than the floor (rare)
        for i in range(row.shape[0]):
            value = row[i]
            value = value if value >= FLOOR32 else FLOOR32
            row[i] = value
            buffer[i] = np.float64(value)
            others += (value != FLOOR32) & (value < SMALLEST_NORMAL32)
        total = np.float32(_buffered_sum(buffer))
        # the floor's quotient once; the normal values' in one vectorised pass with no
        # subnormal operand; any other subnormal value alone
        quotient = FLOOR32 / total
        floor_quotients[r] = quotient
        for i in range(row.shape[0]):
            value = row[i]
            normal = value if value >= SMALLEST_NORMAL32 else np.float32(1.0)
            row[i] = quotient if value == FLOOR32 else normal / total
        if others:
            for i in range(row.shape[0]):
                value = np.float32(buffer[i])
                if value != FLOOR32 and value < SMALLEST_NORMAL32:
                    row[i] = value / total
    return floor_quotients


def normalise_rows(rows: NDArray[np.floating]) -> None:
    """Clamp and normalise every row of a float64 or float32 ``(R, L)`` grid in place (module
    docstring).

    Raises:
        TypeError, ValueError: ``rows`` is not a two-dimensional float64 or float32 array.
    """
    if not isinstance(rows, np.ndarray) or rows.dtype not in (np.float64, np.float32):
        raise TypeError(f"rows must be a float64 or float32 numpy array, got {rows!r:.60}")
    if rows.ndim != 2 or not rows.flags.c_contiguous:
        raise ValueError(f"rows must be a C-contiguous (R, L) array, got shape {rows.shape}")
    if rows.dtype == np.float64:
        _normalise64(rows)  # type: ignore[arg-type]
    else:
        _normalise32(rows)


@kernel
def _without_floor_quotients(
    rows: NDArray[np.float32], floor_quotients: NDArray[np.float32]
) -> NDArray[np.float32]:
    """``rows`` with each row's floor quotient replaced by 1 (the input of the big log)."""
    work = np.empty_like(rows)
    for r in range(rows.shape[0]):
        quotient = floor_quotients[r]
        for i in range(rows.shape[1]):
            value = rows[r, i]
            work[r, i] = np.float32(1.0) if value == quotient else value
    return work


@kernel
def _float32_entropy_sums(
    rows: NDArray[np.float32],
    logs: NDArray[np.float32],
    floor_quotients: NDArray[np.float32],
    floor_logs: NDArray[np.float32],
) -> FloatArray:
    """:func:`entropy_sums` of normalised float32 rows whose floor cells' logarithms are
    ``floor_logs`` (the others' are ``logs``): each row's floor product once, the normal values'
    products in one vectorised pass with no subnormal operand, any other subnormal one alone."""
    result = np.empty(rows.shape[0])
    buffer = np.empty(rows.shape[1])
    for r in range(rows.shape[0]):
        row, log_row = rows[r], logs[r]
        quotient = floor_quotients[r]
        product = quotient * floor_logs[r]
        others = 0
        for i in range(row.shape[0]):
            value = row[i]
            normal = value if value >= SMALLEST_NORMAL32 else np.float32(0.0)
            buffer[i] = np.float64(product if value == quotient else normal * log_row[i])
            others += (value != quotient) & (value < SMALLEST_NORMAL32)
        if others:
            for i in range(row.shape[0]):
                value = row[i]
                if value != quotient and value < SMALLEST_NORMAL32:
                    buffer[i] = np.float64(value * log_row[i])
        result[r] = -_buffered_sum(buffer)
    return result


def float32_grid_entropies(rows: NDArray[np.float32]) -> FloatArray:
    """``(R,)`` entropies of float32 grid rows, normalised in place: ``normalise_rows(rows)``
    then ``entropy_sums(rows, numpy.log(rows))``, bit for bit, without slow arithmetic on the
    subnormal floor cells (module docstring). Their logarithm is NumPy's of each row's floor
    quotient taken apart, which is the same number: NumPy's loop computes every element from
    that element alone (``tests/test_information_kernels.py`` checks it for every subnormal).

    Raises:
        TypeError, ValueError: ``rows`` is not a C-contiguous ``(R, L)`` float32 array.
    """
    rows = require(rows, "rows", np.float32, (None, None))
    floor_quotients = _normalise32(rows)
    logs = np.log(_without_floor_quotients(rows, floor_quotients))
    floor_logs = np.log(floor_quotients)
    return _float32_entropy_sums(rows, logs, floor_quotients, floor_logs)  # type: ignore[no-any-return]


@kernel
def _entropy_sums(rows: NDArray[np.floating], logs: NDArray[np.floating], cast: bool) -> FloatArray:
    result = np.empty(rows.shape[0])
    buffer = np.empty(rows.shape[1])
    for r in range(rows.shape[0]):
        for i in range(rows.shape[1]):
            buffer[i] = np.float64(rows[r, i] * logs[r, i])  # the product in the rows' precision
        result[r] = -(_buffered_sum(buffer) if cast else pairwise_sum(buffer))
    return result


def entropy_sums(rows: NDArray[np.floating], logs: NDArray[np.floating]) -> FloatArray:
    """``(R,)`` values ``-sum_i p_i log p_i`` of normalised rows and their logarithms.

    Args:
        rows: ``(R, L)`` float64 or float32 probabilities (:func:`normalise_rows`).
        logs: ``numpy.log(rows)``.

    Raises:
        TypeError, ValueError: Arrays of another dtype or shape.
    """
    dtype = getattr(rows, "dtype", None)
    dtype = np.float32 if dtype == np.float32 else np.float64
    rows = require(rows, "rows", dtype, (None, None))
    logs = require(logs, "logs", dtype, rows.shape)
    return _entropy_sums(rows, logs, dtype == np.float32)  # type: ignore[no-any-return]


@kernel
def _pair_grids(joint: NDArray[np.float32], n_a: int, n_b: int, q: int) -> FloatArray:
    grids = np.empty((n_a * n_b, q * q))
    for a in range(n_a):
        for u in range(q):
            source = joint[a * q + u]
            for b in range(n_b):
                target = grids[a * n_b + b]
                for v in range(q):
                    value = np.float64(source[b * q + v])
                    target[u * q + v] = value if value >= 1e-300 else 1e-300
    return grids


def pair_grids(joint: NDArray[np.float32], n_a: int, n_b: int, q: int) -> FloatArray:
    """``(A B, Q^2)`` float64 pair grids, clamped at ``1e-300``, of the float32 product
    ``(A Q, B Q)`` of two sets of ``Q``-cell channels (row ``a B + b``: the ``Q x Q`` joint of
    pair ``(a, b)``, the transpose NumPy's ``reshape(A, Q, B, Q).transpose(0, 2, 1, 3)``
    forms).

    Raises:
        TypeError, ValueError: ``joint`` of another dtype or shape.
    """
    joint = require(joint, "joint", np.float32, (n_a * q, n_b * q))
    return _pair_grids(joint, int(n_a), int(n_b), int(q))  # type: ignore[no-any-return]
