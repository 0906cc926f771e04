r"""Compiled kernels: the one place that decides how numba generates code for infoseek.

Every hot path of the filter and of the mutual-information engine is a numba kernel (one pass
over the particles, loops over rows inside the kernel). They must not make results depend on
the machine, because stored trials are re-run by ``infoseek verify`` on other machines and the
planners' decisions depend on the last bits of their utilities (``infoseek.experiments.
numerics``). Three rules make a kernel's floating-point results the same on every x86-64 CPU:

* **One fixed code-generation target.** Before numba is imported, :func:`configure` sets
  ``NUMBA_CPU_NAME`` (``haswell`` on x86-64 CPUs with AVX2 and FMA, the same kernels the
  pinned OpenBLAS uses; ``generic`` elsewhere) and an empty ``NUMBA_CPU_FEATURES`` (that
  target's own instruction set: unset, numba would add the host's, AVX-512 included) instead
  of the host CPU, so the machine code is the same everywhere and the on-disk cache
  (``cache=True``) can be shared.
* **IEEE arithmetic, evaluated as written.** No fast-math (no reassociation, no contraction of
  ``a * b + c`` into a fused multiply-add, no approximate reciprocals), Intel SVML disabled
  (``NUMBA_DISABLE_INTEL_SVML=1``), no ``parallel=True`` (a threaded reduction sums in an order
  that depends on the thread count). Without reassociation the vector width the target allows
  cannot change a result, which is why a second target (``generic``) reproduces the same bits
  (``tests/test_cli.py::test_stored_trials_verify_under_another_blas_kernel``).
* **The C library's transcendentals.** ``math.exp``, ``math.log1p``, ``math.atan2`` ... compile
  to calls of the C library, which are exactly what NumPy's ufuncs call in the pinned
  numerical environment (NumPy's SIMD loops switched off), so a kernel reproduces the NumPy
  expression it replaces bit for bit there. The exception is the float32 ``atan2f``, whose
  values differ between C libraries (:mod:`infoseek.envs.arctangent` computes it in IEEE
  arithmetic instead).

Where a kernel replaces a NumPy reduction it reduces in NumPy's order: :func:`pairwise_sum` is
NumPy's pairwise summation of a contiguous float64 array (blocks of 128, eight accumulators),
sequential sums stay sequential (``cumsum``, ``bincount``, sums over a short leading axis), and
dot products call the same BLAS routine NumPy calls (numba's ``np.dot`` goes to ``ddot`` /
``dgemv``). The kernels therefore give the numbers the NumPy code gave, and the stored results
of earlier versions still verify.

``INFOSEEK_NATIVE_NUMERICS=1`` (as for :mod:`infoseek.experiments.numerics`) leaves numba's
target to numba (the host CPU); an explicit ``NUMBA_CPU_NAME`` in the environment is respected.
Compiled code is cached on disk next to the sources (or in numba's user cache directory when
that is not writable), so only the first run after an install pays the compilation. The cache
key (:class:`KernelCache`) holds a digest of every source file that defines kernels besides
numba's own key, so a kernel is compiled again when a kernel it calls from another file changed.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

__all__ = [
    "KERNEL_OPTIONS",
    "KernelCache",
    "configure",
    "describe",
    "kernel",
    "kernel_sources_digest",
    "pairwise_sum",
    "sources_digest",
]

F = TypeVar("F", bound=Callable[..., Any])

#: Options of every kernel: cached on disk, IEEE arithmetic, NumPy's error model (``x / 0`` is
#: ``inf`` or ``nan`` as in NumPy, not an exception), the GIL released.
KERNEL_OPTIONS: dict[str, Any] = {
    "cache": True,
    "fastmath": False,
    "nogil": True,
    "error_model": "numpy",
    "boundscheck": False,
}


def _fixed_cpu_name() -> str:
    """``haswell`` on x86-64 Linux CPUs with AVX2 and FMA, ``generic`` elsewhere."""
    if sys.platform != "linux" or platform.machine() not in ("x86_64", "AMD64"):
        return "generic"
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    return "haswell" if {"avx2", "fma"} <= flags else "generic"
    except OSError:
        pass
    return "generic"


def configure() -> None:
    """Set numba's code generation as the module docstring describes (idempotent).

    Must run before numba is imported to take effect through the environment; if numba is
    already loaded, its configuration object is updated instead (effective for kernels not yet
    compiled).
    """
    os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")
    if os.environ.get("INFOSEEK_NATIVE_NUMERICS") != "1":
        os.environ.setdefault("NUMBA_CPU_NAME", _fixed_cpu_name())
        # the target's own feature set (an unset NUMBA_CPU_FEATURES means the host's features,
        # e.g. AVX-512 code under the name "haswell")
        os.environ.setdefault("NUMBA_CPU_FEATURES", "")
    if "numba" in sys.modules:
        from numba.core import config

        svml_off = os.environ["NUMBA_DISABLE_INTEL_SVML"] == "1"
        config.DISABLE_INTEL_SVML = svml_off  # type: ignore[attr-defined]
        if "NUMBA_CPU_NAME" in os.environ:
            config.CPU_NAME = os.environ["NUMBA_CPU_NAME"]  # type: ignore[attr-defined]
        if "NUMBA_CPU_FEATURES" in os.environ:
            config.CPU_FEATURES = os.environ["NUMBA_CPU_FEATURES"]  # type: ignore[attr-defined]


configure()

import numba  # noqa: E402  (after configure: numba reads its settings on import)
import numpy as np  # noqa: E402
from numba.core.caching import FunctionCache  # noqa: E402


def kernel(function: F) -> F:
    """Compile ``function`` with :data:`KERNEL_OPTIONS` (lazily, on its first call), cached on
    disk by :class:`KernelCache`."""
    options = {key: value for key, value in KERNEL_OPTIONS.items() if key != "cache"}
    dispatcher = numba.njit(**options)(function)
    if KERNEL_OPTIONS["cache"]:
        dispatcher._cache = KernelCache(function)  # what njit(cache=True) sets, key extended
    return dispatcher  # type: ignore[no-any-return]


class KernelCache(FunctionCache):  # type: ignore[misc]
    """numba's on-disk cache of one kernel, with :func:`kernel_sources_digest` in its index key.

    numba keys a cached kernel by its own bytecode and notices changes to its own file only; a
    kernel compiled together with callees from other files (``pairwise_sum``, the PCG64 draws)
    would keep the old callees after those files changed (numba's documented limitation). With
    the digest of every file that defines kernels in the key, any such change recompiles.
    """

    def _index_key(self, sig: Any, codegen: Any) -> tuple[Any, ...]:
        return (*super()._index_key(sig, codegen), kernel_sources_digest())


def sources_digest(root: Path) -> str:
    """SHA-256 of the ``.py`` files under ``root/envs`` and ``root/planners`` that define kernels
    (containing ``@kernel``): their paths relative to ``root`` and their bytes, in path order."""
    digest = hashlib.sha256()
    for path in sorted(p for folder in ("envs", "planners") for p in (root / folder).rglob("*.py")):
        text = path.read_bytes()
        if b"@kernel" in text:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text)
    return digest.hexdigest()


@functools.cache
def kernel_sources_digest() -> str:
    """:func:`sources_digest` of infoseek's own packages (computed once per process)."""
    return sources_digest(Path(__file__).resolve().parent.parent)


def describe() -> dict[str, Any]:
    """numba's version and code-generation settings in effect (for a store's manifest)."""
    from numba.core import config

    return {
        "numba": numba.__version__,
        "cpu_name": getattr(config, "CPU_NAME", None) or "host",
        "cpu_features": _features(getattr(config, "CPU_FEATURES", None)),
        "svml": not getattr(config, "DISABLE_INTEL_SVML", False),
        "fastmath": KERNEL_OPTIONS["fastmath"],
    }


def _features(features: str | None) -> str:
    """numba's feature string as recorded: ``host`` (unset), ``target`` (empty: the target
    CPU's own features) or the explicit string."""
    if features is None:
        return "host"
    return features or "target"


@kernel
def _block_sum(values: Any, start: int, count: int) -> float:
    """NumPy's sum of ``count <= 128`` values from ``start`` (the leaves of the pairwise tree)."""
    if count < 8:
        total = 0.0
        for i in range(start, start + count):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = start + 8
    stop = start + count - count % 8
    while i < stop:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < start + count:
        total += values[i]
        i += 1
    return total


@kernel
def pairwise_sum(values: Any) -> float:
    """``numpy.sum`` of a contiguous 1-D float64 array, bit for bit (NumPy >= 2.3; earlier
    NumPy sums an array longer than 8192 values, its buffer size, in 8192-value chunks added in
    sequence, so above that length the bits differ from theirs).

    NumPy's pairwise summation: blocks of at most 128 values are summed by :func:`_block_sum`
    (sequentially below 8 values, with eight interleaved accumulators otherwise); a longer
    range splits into halves rounded down to a multiple of 8 and returns ``left + right``. The
    tree is walked here with explicit stacks (numba cannot cache recursive functions).
    """
    count = values.shape[0]
    if count <= 128:
        # an int64 zero, not a literal: one compiled signature
        return _block_sum(values, np.int64(0), count)  # type: ignore[arg-type]
    # pending nodes (start, count; count < 0 marks "add the two partial sums on top")
    node_start = np.empty(128, dtype=np.int64)
    node_count = np.empty(128, dtype=np.int64)
    partial = np.empty(64, dtype=np.float64)
    nodes, sums = 1, 0
    node_start[0], node_count[0] = 0, count
    while nodes:
        nodes -= 1
        start, size = node_start[nodes], node_count[nodes]
        if size < 0:
            sums -= 1
            partial[sums - 1] = partial[sums - 1] + partial[sums]
        elif size <= 128:
            partial[sums] = _block_sum(values, start, size)
            sums += 1
        else:
            half = size // 2
            half -= half % 8
            node_start[nodes], node_count[nodes] = 0, -1
            node_start[nodes + 1], node_count[nodes + 1] = start + half, size - half
            node_start[nodes + 2], node_count[nodes + 2] = start, half
            nodes += 3
    return partial[0]
