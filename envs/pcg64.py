r"""NumPy's default generator drawn inside compiled kernels, from the generator's own state.

Every belief draws from its own :class:`numpy.random.Generator` (``default_rng``: the PCG64
bit generator), and the filter's parity tests require the very numbers NumPy draws. numba
can take a ``Generator`` argument, but it calls the bit generator through a function pointer
for every number and unboxes each generator separately (about 5 us a call), so a kernel over
many beliefs had to be called once per belief. This module instead reads and advances the
128-bit PCG64 state in place, given its address, so one kernel call can draw for every row
from that row's generator.

**PCG64** (O'Neill's XSL-RR 128/64, as ``numpy.random.PCG64``): the state advances as

.. math::  s \leftarrow a s + c \pmod{2^{128}}, \qquad a = 2549297995355413924 \cdot 2^{64} +
           4865540595714422341,

with the stream's odd increment :math:`c`, and the output of the new state
:math:`s = 2^{64} h + l` is :math:`\operatorname{rotr}_{64}(h \oplus l,\ h \gg 58)`.
A double in :math:`[0, 1)` is :math:`\lfloor u / 2^{11} \rfloor \, 2^{-53}`.

**Standard normal** (``Generator.standard_normal``): NumPy's 256-layer ziggurat. From one
64-bit output :math:`u`: layer :math:`i = u \bmod 256`, sign bit :math:`(u \gg 8) \bmod 2`,
52-bit magnitude :math:`m = (u \gg 9) \bmod 2^{52}`, :math:`x = \pm m\,w_i`; accepted at once
when :math:`m < k_i` (about 99 % of draws). Otherwise the base layer samples the tail beyond
:math:`r = 3.6541528853610088` by Marsaglia's method (two doubles per attempt, ``log1p``) and
the other layers draw a double :math:`U` and accept :math:`x` when
:math:`(f_{i-1} - f_i) U + f_i < e^{-x^2/2}`; a rejection starts over. The
tables :math:`k_i, w_i, f_i` are NumPy's, as numba ships them for its own ``Generator``
support.

The arithmetic is NumPy's, in its order, and ``exp``/``log1p`` are the C library's (as NumPy's
C code calls them), so the numbers and the generator's state afterwards are NumPy's bit for
bit. :func:`state_addresses` hands out addresses only for exactly ``numpy.random.PCG64`` bit
generators and only after a check, on first use, that this NumPy stores the state as the
module assumes (a 128-bit little-endian integer, then the increment; NumPy builds without
128-bit integers store it otherwise); anywhere else it returns ``None`` and callers draw
through the ``Generator`` itself. The kernels do not take the bit generator's lock: a generator
must not be drawn from by another thread while a kernel draws from it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel

__all__ = ["next_double", "standard_normal", "state_addresses", "uniforms"]

_MULTIPLIER = (2549297995355413924 << 64) + 4865540595714422341

try:  # NumPy's ziggurat tables, as numba ships them for its Generator support
    from numba.np.random import _constants as _ziggurat

    _KI = np.asarray(_ziggurat.ki_double, dtype=np.uint64)
    _WI = np.asarray(_ziggurat.wi_double, dtype=np.float64)
    _FI = np.asarray(_ziggurat.fi_double, dtype=np.float64)
    _TAIL = float(_ziggurat.ziggurat_nor_r)
    _INVERSE_TAIL = float(_ziggurat.ziggurat_nor_inv_r)
    _TABLES = _KI.shape == _WI.shape == _FI.shape == (256,)
except (ImportError, AttributeError):  # pragma: no cover - another numba layout
    _KI, _WI, _FI = np.zeros(256, np.uint64), np.zeros(256), np.zeros(256)
    _TAIL = _INVERSE_TAIL = 0.0
    _TABLES = False


def _define_next_uint64() -> Any:
    """The compiled ``next_uint64(address)``: one PCG64 step of the state at ``address``."""
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def next_uint64(typingctx: Any, address: Any) -> Any:
        """PCG64's next output; ``address`` is the ``pcg64_state`` of a ``PCG64`` (whose first
        member points at the 128-bit state and increment)."""

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            u128, u64 = ir.IntType(128), ir.IntType(64)
            holder = builder.inttoptr(args[0], u128.as_pointer().as_pointer())
            state_ptr = builder.load(holder)
            increment = builder.load(builder.gep(state_ptr, [ir.Constant(ir.IntType(32), 1)]))
            state = builder.load(state_ptr)
            state = builder.add(builder.mul(state, ir.Constant(u128, _MULTIPLIER)), increment)
            builder.store(state, state_ptr)
            high = builder.trunc(builder.lshr(state, ir.Constant(u128, 64)), u64)
            folded = builder.xor(high, builder.trunc(state, u64))
            rotation = builder.lshr(high, ir.Constant(u64, 58))
            back = builder.and_(builder.neg(rotation), ir.Constant(u64, 63))
            return builder.or_(builder.lshr(folded, rotation), builder.shl(folded, back))

        return types.uint64(types.uint64), codegen

    return next_uint64


next_uint64 = _define_next_uint64()


@kernel
def next_double(address: np.uint64) -> float:
    """A double in ``[0, 1)``: ``Generator.random()``'s next number."""
    return float(next_uint64(address) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@kernel
def _rejected_layer(address: np.uint64, layer: np.uint64, magnitude: np.uint64, x: float) -> Any:
    """The rest of a ziggurat attempt whose fast test failed: ``(accepted, value)``."""
    if layer == 0:  # the tail beyond r, by Marsaglia's method
        while True:
            xx = -_INVERSE_TAIL * math.log1p(-next_double(address))
            yy = -math.log1p(-next_double(address))
            if yy + yy > xx * xx:
                if (magnitude >> np.uint64(8)) & np.uint64(1):
                    return True, -(_TAIL + xx)
                return True, _TAIL + xx
    below = _FI[layer - 1] - _FI[layer]
    if below * next_double(address) + _FI[layer] < math.exp(-0.5 * x * x):
        return True, x
    return False, 0.0


@kernel
def standard_normal(address: np.uint64) -> float:
    """``Generator.standard_normal()``'s next number (module docstring)."""
    while True:
        bits = next_uint64(address)
        layer = bits & np.uint64(0xFF)
        bits >>= np.uint64(8)
        sign = np.float64(bits & np.uint64(1))
        magnitude = (bits >> np.uint64(1)) & np.uint64(0x000FFFFFFFFFFFFF)
        x = magnitude * _WI[layer] * (1.0 - 2.0 * sign)  # times -1.0: an exact negation
        if magnitude < _KI[layer]:
            return x
        accepted, value = _rejected_layer(address, layer, magnitude, x)
        if accepted:
            return value


@kernel
def _uniforms(addresses: NDArray[np.uint64]) -> NDArray[np.float64]:
    out = np.empty(addresses.shape[0])
    for r in range(addresses.shape[0]):
        out[r] = next_double(addresses[r])
    return out


def uniforms(rngs: Sequence[np.random.Generator]) -> NDArray[np.float64]:
    """``(R,)``: ``rngs[r].random()`` for every ``r`` (one compiled call where possible)."""
    addresses = state_addresses(rngs)
    if addresses is None:
        return np.array([rng.random() for rng in rngs], dtype=np.float64)
    return _uniforms(addresses)  # type: ignore[no-any-return]


@kernel
def _normals(address: np.uint64, out: NDArray[np.float64]) -> None:
    for i in range(out.shape[0]):
        out[i] = standard_normal(address)


@functools.cache
def _layout_holds() -> bool:
    """Whether this NumPy's PCG64 state is laid out as the module assumes: compiled draws from
    a fresh generator equal NumPy's (uniforms and normals, the tail included) and leave the
    same state."""
    if not _TABLES:
        return False
    seed = 20061213
    ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
    address = _addresses([ours])
    normals = np.empty(4096)
    _normals(address[0], normals)
    uniform = _uniforms(np.repeat(address, 3))
    same = np.array_equal(normals, theirs.standard_normal(4096)) and np.array_equal(
        uniform, theirs.random(3)
    )
    return same and ours.bit_generator.state == theirs.bit_generator.state


def _addresses(rngs: Sequence[np.random.Generator]) -> NDArray[np.uint64]:
    return np.array([rng.bit_generator.ctypes.state_address for rng in rngs], dtype=np.uint64)


def state_addresses(rngs: Sequence[np.random.Generator]) -> NDArray[np.uint64] | None:
    """``(R,)`` state addresses of ``rngs`` for the compiled draws, or ``None`` when one of
    them is not exactly a ``PCG64`` generator or this NumPy's layout differs (module
    docstring). The addresses are valid while the generators live."""
    if not all(type(rng.bit_generator) is np.random.PCG64 for rng in rngs):
        return None
    if not _layout_holds():
        return None
    return _addresses(rngs)
