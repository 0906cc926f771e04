"""Argument checking and small array maths shared by the sensor models.

Every sensor validates its inputs the same way (finite float arrays of the documented shapes,
errors naming the argument and the sensor), wraps angles the same way, and differences normal
CDFs accurately in the tails; those pieces live here so each sensor module holds one model.
Not part of the public API.
"""

from __future__ import annotations

import math
from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from infoseek.envs.compiled import kernel
from infoseek.envs.sensors.base import FloatArray, ObservationDomain

TWO_PI = 2.0 * math.pi
LOG_SQRT_2PI = 0.5 * math.log(TWO_PI)


def check_positive(value: object, name: str, owner: str) -> float:
    """Return ``value`` as a float, raising unless it is a finite real number ``> 0``."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise TypeError(f"{owner}: {name} must be a real number, got {type(value).__name__}")
    result = float(value)
    if not (math.isfinite(result) and result > 0.0):
        raise ValueError(f"{owner}: {name} must be finite and > 0, got {value!r}")
    return result


def float_dtype(*arrays: object) -> type[np.floating]:
    """``float32`` when every argument is already a float32 array, else ``float64``.

    Lets a caller that has cast its inputs to float32 (the planners' FFT fast path) keep the
    cheaper arithmetic, while everything else computes in float64.
    """
    if all(isinstance(a, np.ndarray) and a.dtype == np.float32 for a in arrays):
        return np.float32
    return np.float64


@kernel
def _all_finite(values: NDArray[Any]) -> bool:
    for value in values:
        if not math.isfinite(value):
            return False
    return True


def all_finite(array: NDArray[Any]) -> bool:
    """Whether every entry of a float array is finite (one compiled pass that stops at the first
    NaN or infinity; ``numpy.isfinite(array).all()`` without its boolean temporary)."""
    return bool(_all_finite(array.reshape(-1)))


@kernel
def _nan_or_plus_inf(values: NDArray[Any]) -> bool:
    for value in values:
        if math.isnan(value) or value == math.inf:
            return True
    return False


def has_nan_or_plus_inf(array: NDArray[Any]) -> bool:
    """Whether some entry of a float64 array is NaN or ``+inf`` (log-likelihoods may be
    ``-inf``, never these): one compiled pass, no temporaries."""
    return bool(_nan_or_plus_inf(np.ascontiguousarray(array, dtype=np.float64).reshape(-1)))


def as_points(
    array: object, name: str, last_dim: int, owner: str, dtype: type = np.float64
) -> FloatArray:
    """Convert to a finite float array (``dtype``) of shape ``(..., last_dim)``."""
    try:
        result: FloatArray = np.asarray(array, dtype=dtype)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{owner}: {name} must be a float array, got {type(array).__name__}") from (
            error
        )
    if result.ndim < 1 or result.shape[-1] != last_dim:
        raise ValueError(f"{owner}: {name} must have shape (..., {last_dim}), got {result.shape}")
    if not all_finite(result):
        raise ValueError(f"{owner}: {name} must be finite (got NaN or inf)")
    return result


def as_particles(
    particles: object,
    name: str,
    dim: int,
    owner: str,
    *,
    allow_wider: bool = False,
    dtype: type = np.float64,
) -> FloatArray:
    """Convert to a finite float array (``dtype``) of shape ``(N, dim)`` (``(N, >= dim)``)."""
    try:
        result: FloatArray = np.asarray(particles, dtype=dtype)
    except (TypeError, ValueError) as error:
        raise TypeError(
            f"{owner}: {name} must be a float array, got {type(particles).__name__}"
        ) from error
    width_ok = result.ndim == 2 and (
        result.shape[1] >= dim if allow_wider else result.shape[1] == dim
    )
    if not width_ok:
        expected = f"(N, >= {dim})" if allow_wider else f"(N, {dim})"
        raise ValueError(f"{owner}: {name} must have shape {expected}, got {result.shape}")
    if not all_finite(result):
        raise ValueError(f"{owner}: {name} must be finite (got NaN or inf)")
    return result


def check_rng(rng: object, owner: str) -> np.random.Generator:
    """Raise TypeError unless ``rng`` is a :class:`numpy.random.Generator`."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"{owner}: rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def as_edges(edges: object, domain: ObservationDomain, owner: str) -> FloatArray:
    """Validate bin edges: ``(Q+1,)``, finite, strictly increasing, ``Q >= 1``.

    For a periodic domain the edges must also lie in ``[low, high]`` (so that every bin is an
    ordinary sub-interval of one period).
    """
    result = np.asarray(edges, dtype=np.float64)
    if result.ndim != 1 or result.shape[0] < 2:
        raise ValueError(f"{owner}: edges must have shape (Q+1,) with Q >= 1, got {result.shape}")
    if not all_finite(result):
        raise ValueError(f"{owner}: edges must be finite")
    if not (np.diff(result) > 0.0).all():
        raise ValueError(f"{owner}: edges must be strictly increasing")
    if domain.periodic[0]:
        low, high = domain.low[0], domain.high[0]
        tol = 1e-9 * (high - low)
        if result[0] < low - tol or result[-1] > high + tol:
            raise ValueError(
                f"{owner}: edges must lie within the observation domain [{low}, {high}], got "
                f"[{result[0]}, {result[-1]}]"
            )
    return result


def wrap_into(x: FloatArray, low: float, period: float) -> FloatArray:
    """Wrap ``x`` into ``[low, low + period)`` (guarding the float rounding to ``low + period``)."""
    shifted = np.subtract(x, low)
    wrapped = shifted - period * np.floor(shifted * (1.0 / period))
    # Rounding can leave the result a hair outside [0, period); fold it back.
    wrapped[wrapped >= period] -= period
    wrapped[wrapped < 0.0] += period
    wrapped += low
    return wrapped


def normal_bin_masses(x: FloatArray) -> FloatArray:
    """Standard normal mass of the bins between consecutive points along the last axis.

    Args:
        x: ``(..., Q+1)`` standardised bin edges, increasing along the last axis.

    Returns:
        ``(..., Q)`` values ``Phi(x[q+1]) - Phi(x[q])``, differenced on the accurate side of zero
        (upper-tail probabilities when the bin lies above the mean), so tiny tail masses keep
        their relative accuracy.
    """
    cdf = ndtr(x)
    sf = ndtr(-x)
    upper = x[..., :-1] > 0.0
    return np.where(upper, sf[..., :-1] - sf[..., 1:], cdf[..., 1:] - cdf[..., :-1])


def check_broadcast(z: FloatArray, poses: FloatArray, owner: str) -> None:
    """Raise ValueError naming both arguments unless the batch shapes broadcast."""
    try:
        np.broadcast_shapes(z.shape[:-1], poses.shape[:-1])
    except ValueError as error:
        raise ValueError(
            f"{owner}: batch shapes of z {z.shape} and poses {poses.shape} do not broadcast"
        ) from error


def planar_offsets(poses: object, targets: object, owner: str) -> FloatArray:
    """``(..., 2)`` offsets ``target[:2] - pose`` of broadcast pose and target batches.

    Args:
        poses: ``(..., 2)`` sensor positions.
        targets: ``(..., >= 2)`` target states (the first two coordinates are the position).
        owner: Name used in error messages.

    Raises:
        ValueError: Wrong shapes, non-finite values or batch shapes that do not broadcast.
    """
    poses = as_points(poses, "poses", 2, owner)
    targets = np.asarray(targets, dtype=np.float64)
    if targets.ndim < 1 or targets.shape[-1] < 2:
        raise ValueError(f"{owner}: targets must have shape (..., 2), got {targets.shape}")
    targets = as_points(targets[..., :2], "targets", 2, owner)
    try:
        return targets - poses
    except ValueError as error:
        raise ValueError(
            f"{owner}: batch shapes of poses {poses.shape} and targets {targets.shape} "
            "do not broadcast"
        ) from error
