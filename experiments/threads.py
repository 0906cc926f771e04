"""One BLAS/OpenMP/torch thread for every ``infoseek`` command, unless asked otherwise.

The work of the commands is many small matrix products (planners' utilities, filters, small
networks), for which a second thread costs more in synchronisation than it gains: on the 2-core
development machine ``infoseek timing --only plan_pairwise_beacon_4`` took 499 ms with
OpenBLAS's default of 2 threads and 113 ms with one. OpenBLAS also sums in another order with
another thread count, so results (the beacon demo's trajectory, from step 27) depend on it. So
every command runs with one thread by default:

* :func:`limit_threads_early` (called by the console entry point before NumPy loads) sets
  ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` (also torch's intra-op threads) and
  ``MKL_NUM_THREADS`` for this process and every process it starts, unless the user set them;
* :func:`limited_threads` (around every command in :func:`infoseek.experiments.cli.main`)
  limits the BLAS and OpenMP pools already loaded, through ``threadpoolctl``, and torch's
  thread count if torch is loaded.

Opt out with ``INFOSEEK_THREADS``: a positive count uses that many threads, ``0`` leaves the
libraries' own defaults. Trials of ``bench``, ``reproduce`` and ``verify`` always run with one
BLAS thread whatever it says (:func:`infoseek.experiments.bench.run_trial`: stored trials must
reproduce).

This module imports nothing heavy, so the entry point can call it before NumPy loads.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator

__all__ = ["THREADS_VARIABLE", "limit_threads_early", "limited_threads", "thread_count"]

#: The environment variable of the opt-out.
THREADS_VARIABLE = "INFOSEEK_THREADS"
#: Thread-count variables of the BLAS/OpenMP libraries NumPy, SciPy and torch may use.
LIBRARY_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def thread_count() -> int | None:
    """The thread count asked for by :data:`THREADS_VARIABLE`: 1 when unset, ``None`` for 0
    (the libraries' defaults).

    Raises:
        ValueError: The variable is not a non-negative integer (the message names it).
    """
    text = os.environ.get(THREADS_VARIABLE, "1").strip()
    try:
        count = int(text)
    except ValueError:
        count = -1
    if count < 0:
        raise ValueError(
            f"{THREADS_VARIABLE}={text!r}: expected a number of threads (0: the libraries' "
            "defaults)"
        )
    return count or None


def limit_threads_early() -> None:
    """Set the libraries' thread variables (those the user has not set) to
    :func:`thread_count`, for this process if NumPy is not loaded yet and for its children.
    An invalid :data:`THREADS_VARIABLE` is left for :func:`limited_threads` to report."""
    try:
        count = thread_count()
    except ValueError:
        return
    if count is None:
        return
    for name in LIBRARY_VARIABLES:
        os.environ.setdefault(name, str(count))


@contextlib.contextmanager
def limited_threads() -> Iterator[int | None]:
    """Run the block with :func:`thread_count` BLAS/OpenMP threads (and torch threads, if torch
    is loaded); yields the count (``None``: the libraries' defaults, nothing changed).

    Raises:
        ValueError: :data:`THREADS_VARIABLE` is invalid.
    """
    count = thread_count()
    if count is None:
        yield None
        return
    from threadpoolctl import threadpool_limits

    torch = sys.modules.get("torch")
    previous = torch.get_num_threads() if torch is not None else None
    if torch is not None:
        torch.set_num_threads(count)
    try:
        with threadpool_limits(limits=count):
            yield count
    finally:
        if torch is not None and previous is not None:
            torch.set_num_threads(previous)
