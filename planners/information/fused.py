r"""The fused multiply-add of NumPy's complex multiplication, for compiled kernels.

NumPy multiplies complex arrays with its SIMD loops, which on every x86-64 target with FMA
(the pinned ``X86_V3`` included) evaluate

.. math::  (a_r + i a_i)(b_r + i b_i) = \operatorname{fma}(a_r, b_r, -(a_i b_i))
    + i\, \operatorname{fma}(a_r, b_i, a_i b_r),

each ``fma`` rounded once (the products ``a_i b_i`` and ``a_i b_r`` rounded before). A kernel
that multiplies complex numbers as written rounds twice and differs in the last bit about half
of the time, so the kernels that replace NumPy complex products call :func:`complex_multiply`.
``fma`` is LLVM's ``llvm.fma`` intrinsic: a fused instruction on targets that have one (the
``haswell`` target of :mod:`infoseek.envs.compiled`) and the C library's correctly rounded
``fma`` elsewhere, the same number in both cases (it is exactly rounded by definition), so it
keeps results independent of the machine. Fast-math contraction stays off: only these explicit
calls fuse.
"""

from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from infoseek.envs.compiled import kernel

__all__ = ["complex_multiply", "fma"]


@intrinsic
def fma(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """``a * b + c`` rounded once (float32 or float64; the three of one type)."""
    if not (isinstance(a, types.Float) and a == b == c):
        return None
    signature = a(a, a, a)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        kind = args[0].type
        function = builder.module.declare_intrinsic(
            "llvm.fma", [kind], ir.FunctionType(kind, [kind, kind, kind])
        )
        return builder.call(function, args)

    return signature, codegen


@kernel
def complex_multiply(a_real: Any, a_imag: Any, b_real: Any, b_imag: Any) -> tuple[Any, Any]:
    """``(real, imag)`` of ``a * b`` as NumPy's complex multiply rounds it (module docstring)."""
    real: Any = fma(a_real, b_real, -(a_imag * b_imag))  # type: ignore[call-arg]
    imag: Any = fma(a_real, b_imag, a_imag * b_real)  # type: ignore[call-arg]
    return real, imag
