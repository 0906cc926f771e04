r"""The single-precision arctangent ``atan2(y, x)`` in IEEE arithmetic only (compiled).

The planners predict bearings in float32 (:mod:`infoseek.planners.information.stencil_cache`).
NumPy's float32 ``arctan2`` calls the C library's ``atan2f`` in the pinned numerical
environment (:mod:`infoseek.experiments.numerics`), and the C library's ``atan2f`` is not the
same on every machine: glibc 2.36, the C library of the machine that wrote the stored results,
computes it with Sun's ``fdlibm`` algorithm (error up to 2 units in the last place), glibc's
newer float functions (from the CORE-MATH project) return the correctly rounded value, and the
two differ in about one value in six. A planner's decision depends on
the last bits of its utilities, so stored trials written under one C library did not reproduce
under the other (``docs/development.md``).

:func:`arctan2_float32` therefore computes the ``fdlibm`` algorithm itself, in float32
arithmetic compiled without contraction or reassociation (:mod:`infoseek.envs.compiled`): glibc
2.36's values bit for bit, on every x86-64 machine and whatever its C library. The common case
is written with selects instead of branches, so its loop vectorises (about ten times faster
than the C library's ``atan2f``); zeros, infinities, NaN and extreme ratios go through the
scalar code.

:func:`arctan2_float32`, which the bearing sensor's float32 predictions call, uses it wherever
NumPy would call the C library (NumPy's baseline loop: the pinned environment, and machines
without AVX-512), and NumPy's own SIMD loop where NumPy runs one (AVX-512 machines outside the
pin, whose numbers are machine-dependent anyway; it is faster still).

The algorithm (Sun Microsystems, 1993; float version by Ian Lance Taylor):

* ``atan(x)`` for ``x >= 0``: an argument reduction to ``|t| <= 7/16`` around the nodes
  ``0, 1/2, 1, 3/2, inf``, ``atan(x) = atan(c) + atan(t)`` with
  ``t = (x - c) / (1 + c x)`` (``t = -1/x`` for the last), the node's arctangent kept as a
  high and a low float, and ``atan(t) = t - t (s_1 + s_2)`` with the odd series split into two
  Horner polynomials in ``t^4``; ``atan(x) = pi / 2`` (as ``hi + lo``) for ``x >= 2^25`` (glibc's
  bound; Sun's is ``2^34``) and ``atan(x) = x`` below ``2^-29``.
* ``atan2(y, x)``: the special values of IEEE 754 (signed zeros, infinities, NaN),
  ``atan(|y / x|)`` with its sign and the quadrant's ``pi`` (as ``pi_hi`` and ``pi_lo``), and
  ``pi / 2`` or ``0`` when the exponents are more than 60 apart.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

__all__ = ["arctan2_float32", "fdlibm_arctan2_float32", "numpy_arctan2_is_simd"]

Float32Array = NDArray[np.float32]

_F = np.float32
# Constants as the C compiler rounds the decimal literals of fdlibm to float.
_ATAN_HI = np.array([4.6364760399e-01, 7.8539812565e-01, 9.8279368877e-01, 1.5707962513e00], _F)
_ATAN_LO = np.array([5.0121582440e-09, 3.7748947079e-08, 3.4473217170e-08, 7.5497894159e-08], _F)
_SERIES = np.array(
    [
        3.3333334327e-01,
        -2.0000000298e-01,
        1.4285714924e-01,
        -1.1111110449e-01,
        9.0908870101e-02,
        -7.6918758452e-02,
        6.6610731184e-02,
        -5.8335702866e-02,
        4.9768779427e-02,
        -3.6531571299e-02,
        1.6285819933e-02,
    ],
    _F,
)
_ONE, _TWO, _HALF, _THREE_HALVES, _THREE = _F(1.0), _F(2.0), _F(0.5), _F(1.5), _F(3.0)
_ZERO = _F(0.0)
_PI_OVER_4 = _F(7.8539818525e-01)
_PI_OVER_2 = _F(1.5707963705e00)
_PI = _F(3.1415927410e00)
_PI_LO = _F(-8.7422776573e-08)
_TWO_POW_25 = _F(2.0**25)
_TWO_POW_M29 = _F(2.0**-29)
_NODE_EDGES = np.array([0.4375, 0.6875, 1.1875, 2.4375], _F)
_ATAN_AT_INFINITY = _F(_ATAN_HI[3] + _ATAN_LO[3])


@kernel
def _atan_non_negative(a: np.float32) -> np.float32:
    """``fdlibm``'s float ``atan(a)`` for ``a >= 0`` (not NaN), written with selects instead of
    branches (every node's reduction is formed, the division done once, then the node's values
    picked) so that loops calling it vectorise: the same float32 operations on the selected
    values as ``fdlibm``'s branches, hence the same bits."""
    n0 = (a >= _NODE_EDGES[0]) & (a < _NODE_EDGES[1])
    n1 = (a >= _NODE_EDGES[1]) & (a < _NODE_EDGES[2])
    n2 = (a >= _NODE_EDGES[2]) & (a < _NODE_EDGES[3])
    n3 = a >= _NODE_EDGES[3]
    num, den, hi, lo = a, _ONE, _ATAN_HI[3], _ATAN_LO[3]
    num = (_TWO * a - _ONE) if n0 else num
    num = (a - _ONE) if n1 else num
    num = (a - _THREE_HALVES) if n2 else num
    num = -_ONE if n3 else num
    den = (_TWO + a) if n0 else den
    den = (a + _ONE) if n1 else den
    den = (_ONE + _THREE_HALVES * a) if n2 else den
    den = a if n3 else den
    hi = _ATAN_HI[2] if n2 else hi
    hi = _ATAN_HI[1] if n1 else hi
    hi = _ATAN_HI[0] if n0 else hi
    lo = _ATAN_LO[2] if n2 else lo
    lo = _ATAN_LO[1] if n1 else lo
    lo = _ATAN_LO[0] if n0 else lo
    t = num / den
    z = t * t
    w = z * z
    c = _SERIES
    s1 = z * (c[0] + w * (c[2] + w * (c[4] + w * (c[6] + w * (c[8] + w * c[10])))))
    s2 = w * (c[1] + w * (c[3] + w * (c[5] + w * (c[7] + w * c[9]))))
    r = (t - t * (s1 + s2)) if a < _NODE_EDGES[0] else hi - ((t * (s1 + s2) - lo) - t)
    r = a if a < _TWO_POW_M29 else r
    return _ATAN_AT_INFINITY if a >= _TWO_POW_25 else r


@kernel
def _atan(x: np.float32) -> np.float32:
    """``fdlibm``'s float ``atan(x)``: NaN, ``x`` itself below ``2^-29`` (signed zeros kept),
    else :func:`_atan_non_negative` of ``|x|`` with the sign of ``x`` (the odd series of
    ``-|x|`` is the negated series of ``|x|`` in round-to-nearest)."""
    if x != x:
        return x + x
    ax = abs(x)
    if ax < _TWO_POW_M29:
        return x
    r = _atan_non_negative(ax)
    return -r if x < _ZERO else r


@kernel
def _atan2(y: np.float32, x: np.float32, y_bits: np.int32, x_bits: np.int32) -> np.float32:
    """``fdlibm``'s float ``atan2(y, x)``; ``*_bits`` are the IEEE words of ``y`` and ``x``."""
    ix, iy = x_bits & 0x7FFFFFFF, y_bits & 0x7FFFFFFF
    if ix > 0x7F800000 or iy > 0x7F800000:
        return x + y
    if x_bits == 0x3F800000:
        return _atan(y)
    quadrant = (1 if y_bits < 0 else 0) | (2 if x_bits < 0 else 0)
    if iy == 0:
        return y if quadrant < 2 else (_PI if quadrant == 2 else -_PI)
    if ix == 0 or (iy == 0x7F800000 and ix != 0x7F800000):
        return -_PI_OVER_2 if y_bits < 0 else _PI_OVER_2
    if ix == 0x7F800000:
        if iy == 0x7F800000:
            corner = _PI_OVER_4 if quadrant < 2 else _THREE * _PI_OVER_4
            return -corner if quadrant & 1 else corner
        far = _ZERO if quadrant < 2 else _PI
        return -far if quadrant & 1 else far
    k = (iy - ix) >> 23
    if k > 60:
        z = _PI_OVER_2 + _HALF * _PI_LO
    elif x_bits < 0 and k < -60:
        z = _ZERO
    else:
        z = _atan(abs(y / x))
    if quadrant == 0:
        return z
    if quadrant == 1:
        return -z
    if quadrant == 2:
        return _PI - (z - _PI_LO)
    return (z - _PI_LO) - _PI


@kernel
def _is_special(y_bits: np.int32, x_bits: np.int32) -> bool:
    """Whether the branch-free loop of :func:`_arctan2_into` does not apply to ``atan2(y, x)``
    (a zero, an infinity or a NaN, exponents more than 60 apart, ``x = 1``); branch-free, so
    loops vectorise."""
    ix, iy = x_bits & 0x7FFFFFFF, y_bits & 0x7FFFFFFF
    k = (iy - ix) >> 23
    edge = (ix == 0) | (iy == 0) | (ix >= 0x7F800000) | (iy >= 0x7F800000)
    return edge | (k > 60) | (k < -60) | (x_bits == 0x3F800000)


@kernel
def _arctan2_into(
    y: Float32Array,
    x: Float32Array,
    y_bits: NDArray[np.int32],
    x_bits: NDArray[np.int32],
    out: Float32Array,
) -> None:
    """:func:`_atan2` of every element into ``out``, in three loops: a branch-free one (the
    quadrant by selects, :func:`_atan_non_negative`) for finite non-zero ``y`` and ``x`` whose
    exponents are at most 60 apart, which vectorises; a branch-free count of the other elements
    (:func:`_is_special`); and, where there are any, the scalar :func:`_atan2` for those."""
    for i in range(out.size):
        r = _atan_non_negative(abs(y[i] / x[i]))
        negative_y = y_bits[i] < 0
        right = -r if negative_y else r
        left = ((r - _PI_LO) - _PI) if negative_y else (_PI - (r - _PI_LO))
        out[i] = left if x_bits[i] < 0 else right
    count = 0
    for i in range(out.size):
        count += _is_special(y_bits[i], x_bits[i])
    if count:
        for i in range(out.size):
            if _is_special(y_bits[i], x_bits[i]):
                out[i] = _atan2(y[i], x[i], y_bits[i], x_bits[i])


def fdlibm_arctan2_float32(y: Float32Array, x: Float32Array) -> Float32Array:
    """Elementwise ``atan2(y, x)`` of two float32 arrays of the same shape, in ``[-pi, pi]``:
    ``fdlibm``'s values (glibc 2.36's), computed here, the same on every machine.

    Args:
        y: Ordinates, float32.
        x: Abscissas, float32, the shape of ``y``.

    Returns:
        A new float32 array of the shape of ``y``.

    Raises:
        TypeError: If ``y`` or ``x`` is not a float32 array.
        ValueError: If their shapes differ.
    """
    _check(y, x, "fdlibm_arctan2_float32")
    y_flat, x_flat = np.ascontiguousarray(y).ravel(), np.ascontiguousarray(x).ravel()
    out = np.empty(y_flat.shape, dtype=np.float32)
    y_bits, x_bits = y_flat.view(np.int32), x_flat.view(np.int32)
    _arctan2_into(y_flat, x_flat, y_bits, x_bits, out)
    return out.reshape(y.shape)


def arctan2_float32(y: Float32Array, x: Float32Array) -> Float32Array:
    """Elementwise float32 ``atan2(y, x)`` as the planners compute it: NumPy's ``arctan2``
    where NumPy runs its own SIMD loop for it (AVX-512 machines outside the pinned numerical
    environment, whose results are machine-dependent anyway), otherwise
    :func:`fdlibm_arctan2_float32` (in the pinned environment, where NumPy would call the
    C library's ``atan2f``: the same values on every machine, and faster). Arguments, result
    and errors as :func:`fdlibm_arctan2_float32`'s.
    """
    if numpy_arctan2_is_simd():
        _check(y, x, "arctan2_float32")
        return np.arctan2(y, x)
    return fdlibm_arctan2_float32(y, x)


@functools.cache
def numpy_arctan2_is_simd() -> bool:
    """Whether NumPy's float32 ``arctan2`` runs one of NumPy's own SIMD loops in this process
    (not the baseline loop, which calls the C library's ``atan2f``)."""
    try:
        from numpy.lib.introspect import opt_func_info
    except ImportError:  # pragma: no cover - NumPy < 2.0
        return False
    info = opt_func_info(func_name="arctan2", signature="float32").get("arctan2", {})
    current = str(next(iter(info.values()), {}).get("current", "baseline"))
    return not current.startswith("baseline")


def _check(y: object, x: object, owner: str) -> None:
    for name, value in (("y", y), ("x", x)):
        if not isinstance(value, np.ndarray) or value.dtype != np.float32:
            raise TypeError(f"{owner}: {name} must be a float32 array, got {_kind(value)}")
    assert isinstance(y, np.ndarray) and isinstance(x, np.ndarray)
    if y.shape != x.shape:
        raise ValueError(f"{owner}: y and x must have one shape, got {y.shape} and {x.shape}")


def _kind(value: object) -> str:
    dtype = getattr(value, "dtype", None)
    return f"dtype {dtype}" if dtype is not None else type(value).__name__
