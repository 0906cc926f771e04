"""Argument checks in front of the compiled MI kernels.

A numba kernel given an array of another dtype or number of axes either fails with a typing
error that names none of the caller's arguments or, worse, compiles a second specialisation
that computes in another precision. Every public wrapper of a kernel in
:mod:`infoseek.planners.information` therefore passes its arrays through :func:`require`
first: the wrong dtype is a ``TypeError`` and the wrong shape a ``ValueError``, both naming the
argument, and the array handed on is C-contiguous (the layout the kernels are compiled for).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

__all__ = ["require", "require_rows"]


def require(
    value: Any,
    name: str,
    dtype: DTypeLike,
    shape: tuple[int | None, ...],
) -> NDArray[Any]:
    """``value`` as a C-contiguous array of exactly ``dtype`` and ``shape``.

    Args:
        value: The argument.
        name: Its name in the caller's signature (used in the messages).
        dtype: The dtype the kernel is compiled for (no casting is done).
        shape: The expected shape; ``None`` entries accept any length on that axis.

    Raises:
        TypeError: ``value`` is not a NumPy array of ``dtype``.
        ValueError: ``value`` has another number of axes or a wrong length on an axis.
    """
    expected = np.dtype(dtype)
    if (
        type(value) is np.ndarray
        and value.dtype == expected
        and value.ndim == len(shape)
        and value.flags.c_contiguous
        and all(want is None or have == want for have, want in zip(value.shape, shape, strict=True))
    ):
        return value  # the common case, checked cheaply
    if not isinstance(value, np.ndarray):
        raise TypeError(
            f"{name} must be a numpy array of {expected.name}, got {type(value).__name__}"
        )
    if value.dtype != expected:
        raise TypeError(f"{name} must have dtype {expected.name}, got {value.dtype}")
    if value.ndim != len(shape) or any(
        want is not None and have != want for have, want in zip(value.shape, shape, strict=True)
    ):
        wanted = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {wanted}, got {value.shape}")
    return np.ascontiguousarray(value)


def require_rows(rows: Any, name: str, count: int) -> NDArray[np.int64]:
    """``rows`` (``None``: all ``count`` rows) as a contiguous int64 array of rows in
    ``[0, count)``.

    Raises:
        TypeError: ``rows`` is not an integer array.
        ValueError: ``rows`` is not one-dimensional or selects a row outside ``[0, count)``.
    """
    if rows is None:
        return np.arange(count, dtype=np.int64)
    if not isinstance(rows, np.ndarray) or rows.dtype.kind not in "iu":
        raise TypeError(f"{name} must be a numpy array of integers, got {rows!r}")
    if rows.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {rows.shape}")
    if rows.size and (rows.min() < 0 or rows.max() >= count):
        raise ValueError(f"{name} must select rows in [0, {count})")
    return np.ascontiguousarray(rows, dtype=np.int64)
