"""The numerical environment that stored trials run in, the same on every x86-64 machine.

The planners' decisions are sensitive to the last bits of their utilities: the two best
candidate controls of a vehicle are often within ``1e-5`` nats of each other, so a difference
of one unit in the last place of a matrix product can change a decision and, a few steps later,
a whole trajectory. Two things make such bits machine-dependent:

* OpenBLAS picks its matrix kernels at load time from the CPU (``Haswell`` on AVX2 machines,
  ``SkylakeX`` on AVX-512 ones) and sums in a kernel-specific order;
* NumPy dispatches its transcendental and reduction loops at load time to the widest SIMD
  extension present (``X86_V3`` = AVX2, ``X86_V4`` and later = AVX-512).

Trials are therefore run (``infoseek bench``, ``reproduce``, ``verify``, and their worker
processes) in a pinned environment: :data:`PINNED` selects the AVX2 code paths of both, which
every x86-64 CPU with AVX2 runs (NumPy's AVX-512 targets under the names of every NumPy
generation: 2.4 and later group them as ``X86_V4``, earlier versions list ``AVX512F`` ...), and
:func:`pin` sets it before NumPy is imported. Each trial
also runs with one BLAS thread (:func:`infoseek.experiments.bench.run_trial`): the summation
order of a threaded product depends on the thread count. :func:`describe` reports what is in
effect; the bench store records it in its manifest and ``infoseek verify`` prints it.
The compiled kernels (:mod:`infoseek.envs.compiled`) are pinned there: one fixed numba target
(``haswell`` on AVX2 machines, unless ``NUMBA_CPU_NAME`` says otherwise), no fast-math, no SVML
(also set here for worker processes), no threaded reductions; their IEEE arithmetic gives the
same bits whatever the target, which ``tests/test_cli.py`` checks by verifying a stored trial
with ``NUMBA_CPU_NAME=generic``. :func:`describe` records numba's settings too.
Trained policies run in torch, which links Intel's MKL: MKL picks its matrix-product and
vector-function kernels from the CPU and its vendor (an AVX-512 Intel CPU and an AMD one give
other last bits), so the pin selects MKL's ``COMPATIBLE`` branch (conditional numerical
reproducibility: the same results on every Intel and compatible CPU) and ATen's AVX2 kernels.

Setting ``INFOSEEK_NATIVE_NUMERICS=1`` leaves the environment as it is (faster on AVX-512
machines; results then reproduce only on machines with the same kernels).

This module imports nothing heavy, so the command line can pin before NumPy loads.
"""

from __future__ import annotations

import os
import platform
import sys
from typing import Any

__all__ = ["PINNED", "describe", "pin"]

#: Environment variables of the pinned numerical environment.
PINNED: dict[str, str] = {
    "OPENBLAS_CORETYPE": "Haswell",
    # NumPy >= 2.4 names its AVX-512 targets X86_V4, AVX512_ICL, AVX512_SPR; earlier versions
    # AVX512F ... AVX512_SPR. Each version ignores the other's names (an ImportWarning).
    "NPY_DISABLE_CPU_FEATURES": (
        "X86_V4 AVX512_ICL AVX512_SPR AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX "
        "AVX512_CLX AVX512_CNL AVX512FP16"
    ),
    "NUMBA_DISABLE_INTEL_SVML": "1",
    # torch (trained policies): MKL's matrix products and vector functions in the branch
    # that gives the same bits on every Intel and compatible CPU, ATen's AVX2 kernels.
    "MKL_CBWR": "COMPATIBLE",
    "ATEN_CPU_CAPABILITY": "avx2",
}


def pin() -> bool:
    """Put :data:`PINNED` into ``os.environ`` (for this process, if NumPy is not loaded yet,
    and for every process started from it).

    Returns:
        Whether the pin is in effect in this process (``False`` if NumPy was already loaded,
        if ``INFOSEEK_NATIVE_NUMERICS=1``, or off x86-64 Linux).
    """
    if os.environ.get("INFOSEEK_NATIVE_NUMERICS") == "1":
        return False
    if sys.platform != "linux" or os.uname().machine not in ("x86_64", "AMD64"):
        return False
    os.environ.update(PINNED)
    return "numpy" not in sys.modules


def describe() -> dict[str, Any]:
    """NumPy's version and SIMD targets in use, the BLAS libraries with their kernels,
    numba's code generation (:func:`infoseek.envs.compiled.describe`), SciPy's version (its
    ``erf``) and the C library (its transcendentals: ``docs/development.md``)."""
    import importlib

    import numpy as np
    from threadpoolctl import threadpool_info

    from infoseek.envs import compiled

    try:
        umath = importlib.import_module("numpy._core._multiarray_umath")
    except ImportError:  # pragma: no cover - older NumPy
        umath = importlib.import_module("numpy.core._multiarray_umath")
    __cpu_dispatch__, __cpu_features__ = umath.__cpu_dispatch__, umath.__cpu_features__

    return {
        "numpy": np.__version__,
        "numpy_simd": [name for name in __cpu_dispatch__ if __cpu_features__.get(name)],
        "blas": [
            {
                "library": info.get("internal_api"),
                "version": info.get("version"),
                "kernel": info.get("architecture"),
                "prefix": info.get("prefix"),
            }
            for info in threadpool_info()
            if info.get("user_api") == "blas"
        ],
        "numba": compiled.describe(),
        "scipy": importlib.import_module("scipy").__version__,
        "libc": " ".join(platform.libc_ver()).strip() or "unknown",
        "pinned": all(os.environ.get(key) == value for key, value in PINNED.items()),
    }
