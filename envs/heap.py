"""Keep freed NumPy temporaries in the process heap (glibc ``mallopt``).

NumPy allocates a new array for every intermediate result. With glibc's default settings,
arrays above 128 KiB are served by ``mmap`` and returned to the system when freed, and the top
of the heap is trimmed as soon as it is free, so each batch of temporaries faults its pages in
again. In infoseek's hot loops (MI estimators, particle filters) those page faults cost more
than the arithmetic: ``INFOSEEK_HEAP_TUNING=0 infoseek timing --only mi_single_fast`` against
the default shows the difference on the machine at hand (README, Performance).

:func:`retain_freed_memory` raises the ``mmap`` threshold to 32 MiB and keeps 64 MiB of free
heap at its top (``M_MMAP_THRESHOLD``, ``M_TOP_PAD``), so the pages of freed temporaries are
reused. It costs at most that much resident memory and changes no result (only where memory
comes from); on other C libraries it does nothing.

It is opt-in: importing infoseek changes no process-wide setting. The ``infoseek`` command
turns it on for its process and for the worker processes it starts (unless the environment
variable ``INFOSEEK_HEAP_TUNING`` is ``0``); a program of your own calls
:func:`retain_freed_memory` once, or sets ``INFOSEEK_HEAP_TUNING=1`` so that
:func:`tune_from_environment` (called by infoseek's worker processes as they start) applies it
there as well.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

__all__ = ["ENVIRONMENT_VARIABLE", "retain_freed_memory", "tune_from_environment", "tuned"]

#: ``"1"``: worker processes tune their heap as they start; ``"0"``: the ``infoseek`` command
#: does not tune it either.
ENVIRONMENT_VARIABLE = "INFOSEEK_HEAP_TUNING"

_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3
_state = {"tuned": False}


def retain_freed_memory(mmap_threshold: int = 32 << 20, top_pad: int = 64 << 20) -> bool:
    """Apply the heap settings (module docstring); returns whether glibc accepted them."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    accepted = bool(mallopt(_M_MMAP_THRESHOLD, int(mmap_threshold))) and bool(
        mallopt(_M_TOP_PAD, int(top_pad))
    )
    _state["tuned"] = accepted
    return accepted


def tuned() -> bool:
    """Whether :func:`retain_freed_memory` is in effect in this process."""
    return _state["tuned"]


def tune_from_environment() -> bool:
    """Apply :func:`retain_freed_memory` if ``INFOSEEK_HEAP_TUNING`` is ``1`` (what the
    ``infoseek`` command sets for its worker processes); returns whether the heap is tuned."""
    if os.environ.get(ENVIRONMENT_VARIABLE) == "1" and not tuned():
        retain_freed_memory()
    return tuned()
