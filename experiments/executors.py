"""Where trials run: the executor backends of the benchmark harness.

:func:`execute` runs trial specs on a backend and yields ``(spec, record)`` as trials finish;
the caller (:func:`infoseek.experiments.bench.run_bench`, ``infoseek verify``) stores or
compares each record at once. Backends:

* ``"serial"``: in this process, in order;
* ``"process"``: a :class:`concurrent.futures.ProcessPoolExecutor` of ``spawn``-ed workers (a
  clean interpreter in the pinned numerical environment, one BLAS thread each, killed by the
  kernel if this process dies);
* ``"ray"``: ``ray.remote`` tasks, on an existing cluster (``address``) or on a local Ray
  started for the run and shut down afterwards;
* ``"package.module:factory"``: any :class:`concurrent.futures.Executor`, built as
  ``factory(max_workers=workers)`` (``concurrent.futures:ThreadPoolExecutor``,
  ``loky:get_reusable_executor``, a Dask client's executor, submitit behind a small factory).

Trials are drawn lazily from ``specs``, at most :data:`IN_FLIGHT_PER_WORKER` per worker ahead,
so memory does not grow with the number of trials asked for.

Faults. A trial is a pure function of its spec (:mod:`infoseek.experiments.seeds`), so rerunning
it after its worker died gives the same record. A worker that dies (killed, out of memory) makes
a process pool (or any executor) *broken* (:class:`concurrent.futures.BrokenExecutor`): the
trials it had in flight are resubmitted to a fresh pool, each at most :data:`MAX_RETRIES`
times; on Ray the task is retried by Ray itself (``max_retries``). A trial that raises is not
retried (it would raise again): :class:`TrialFailedError` names it with its seeds. Finished
trials are yielded once, so the store ends with every trial exactly once.
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import os
import sys
from collections import deque
from collections.abc import Callable, Generator, Iterable, Iterator
from concurrent.futures import (
    FIRST_COMPLETED,
    BrokenExecutor,
    Executor,
    Future,
    ProcessPoolExecutor,
    wait,
)
from typing import Any

from infoseek.experiments.environments import import_object
from infoseek.experiments.record import TrialRecord
from infoseek.experiments.trial import TrialSpec, run_trial

__all__ = [
    "BACKENDS",
    "IN_FLIGHT_PER_WORKER",
    "MAX_RETRIES",
    "TrialFailedError",
    "check_backend",
    "execute",
    "spawn_pool",
]

#: The named backends (a ``"module:factory"`` executor is the other kind).
BACKENDS: tuple[str, ...] = ("serial", "process", "ray")
#: Trials in flight per worker (the rest are drawn as workers free up).
IN_FLIGHT_PER_WORKER = 2
#: Times a trial is run again after the worker running it died.
MAX_RETRIES = 3

Finished = Iterator[tuple[TrialSpec, TrialRecord]]


class TrialFailedError(RuntimeError):
    """A trial raised (or its worker died too often); carries its key and seeds so it can be
    reproduced alone."""


def check_backend(backend: str) -> None:
    """Raise ``ValueError`` unless ``backend`` is a named backend or a callable factory path."""
    if ":" in backend:
        if not callable(import_object(backend, "--backend")):
            raise ValueError(f"--backend {backend!r} is not callable")
        return
    if backend not in BACKENDS:
        raise ValueError(
            f"unknown backend {backend!r}; expected one of {list(BACKENDS)} or "
            "'package.module:factory' (a concurrent.futures.Executor factory)"
        )


def execute(
    specs: Iterable[TrialSpec],
    backend: str = "serial",
    workers: int = 1,
    address: str | None = None,
) -> Finished:
    """Run ``specs`` on ``backend`` (module docstring); yields ``(spec, record)`` as trials
    finish.

    Raises:
        ValueError: Unknown backend, bad worker count, or ray missing.
        TrialFailedError: A trial raised, or its worker died more than :data:`MAX_RETRIES`
            times (the trials already yielded are unaffected).
    """
    check_backend(backend)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"--workers must be a positive integer, got {workers!r}")
    if address and backend != "ray":
        raise ValueError("--address only applies to --backend ray")
    queue = iter(specs)
    first = next(queue, None)
    if first is None:  # nothing to run: start no pool
        return iter(())
    queue = itertools.chain([first], queue)
    if backend == "serial":
        return _serial(queue)
    if backend == "ray":
        return _ray(queue, workers, address)
    if backend == "process":
        return _process_pool(queue, workers)
    factory = import_object(backend, "--backend")
    return _pooled(queue, workers, lambda: factory(max_workers=workers), _shutdown)


def _serial(specs: Iterable[TrialSpec]) -> Finished:
    for spec in specs:
        try:
            record = run_trial(spec)
        except Exception as error:
            raise TrialFailedError(f"{spec.describe()} failed: {error!r}") from error
        yield spec, record


def _shutdown(executor: Executor, finished: bool) -> None:
    """Shut an executor down without waiting; not-started trials are cancelled."""
    try:
        executor.shutdown(wait=False, cancel_futures=True)
    except TypeError:  # an executor whose shutdown takes no cancel_futures
        executor.shutdown(wait=False)


def _pooled(
    specs: Iterable[TrialSpec],
    workers: int,
    start: Callable[[], Executor],
    stop: Callable[[Executor, bool], None],
) -> Finished:
    """Trials on executors made by ``start``: at most :data:`IN_FLIGHT_PER_WORKER` per worker
    submitted at a time; a broken executor is stopped and replaced, and its unfinished trials
    are submitted again (module docstring). ``stop(executor, finished)`` ends each one
    (``finished``: every trial came back)."""
    queue = iter(specs)
    again: deque[TrialSpec] = deque()
    deaths: dict[str, int] = {}
    pending: dict[Future[TrialRecord], TrialSpec] = {}
    executor = start()
    finished = False

    def fill() -> None:
        while len(pending) < IN_FLIGHT_PER_WORKER * workers:
            spec = again.popleft() if again else next(queue, None)
            if spec is None:
                return
            pending[executor.submit(run_trial, spec)] = spec

    try:
        fill()
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            lost = yield from _collect(done, pending)
            if lost:
                _count_deaths(lost, deaths)
                stop(executor, False)
                executor = start()
                again.extend(lost)
            fill()
        finished = True
    finally:
        stop(executor, finished)


def _collect(
    done: set[Future[TrialRecord]],
    pending: dict[Future[TrialRecord], TrialSpec],
) -> Generator[tuple[TrialSpec, TrialRecord], None, list[TrialSpec]]:
    """Yield the finished trials of ``done`` (removed from ``pending``); returns the specs whose
    worker died. Once one has, every trial still pending on the broken executor is waited for
    and collected too (finished ones yielded, the rest returned)."""
    lost: list[TrialSpec] = []
    futures = list(done)
    while futures:
        for future in futures:
            spec = pending.pop(future)
            try:
                record = future.result()
            except BrokenExecutor:
                lost.append(spec)
                continue
            except Exception as error:
                raise TrialFailedError(f"{spec.describe()} failed: {error!r}") from error
            yield spec, record
        futures = list(wait(pending)[0]) if lost and pending else []
    return lost


def _count_deaths(lost: list[TrialSpec], deaths: dict[str, int]) -> None:
    """Count one more worker death for each of ``lost``; raise once one died too often."""
    for spec in lost:
        deaths[spec.key] = deaths.get(spec.key, 0) + 1
        if deaths[spec.key] > MAX_RETRIES:
            raise TrialFailedError(
                f"{spec.describe()}: its worker died {deaths[spec.key]} times (killed, or out "
                "of memory?); the trials finished before are stored"
            )


# ------------------------------------------------------------------------------- process pool
def _process_pool(specs: Iterable[TrialSpec], workers: int) -> Finished:
    """:func:`_pooled` on ``spawn``-ed process pools; workers of a pool stopped early (Ctrl-C,
    a failed trial, the generator closed) are terminated, since ``shutdown`` only cancels the
    trials not yet started and the running ones would keep this process waiting at exit. The
    pool is then shut down waiting for its manager thread, which reaps the terminated workers
    as well (a pool stopped without that wait could return while the thread still held a
    reaped worker's exit code, the worker still listed as a live child). A pool whose trials
    all came back is shut down the same way, so that no pool thread is left running into the
    interpreter's exit."""
    others = set(multiprocessing.active_children())

    def start() -> Executor:
        return spawn_pool(workers)

    def stop(executor: Executor, finished: bool) -> None:
        if not finished:
            _terminate(set(multiprocessing.active_children()) - others)
        executor.shutdown(wait=True, cancel_futures=True)

    return _pooled(specs, workers, start, stop)


def spawn_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` ``spawn``-ed processes as the process backend starts them: one
    BLAS thread each (:func:`single_threaded_workers`), killed if this process dies, the heap
    tuned as this process chose. The workers are started here, while the thread variables are
    set (a pool starts its processes on the first submit)."""
    with single_threaded_workers():
        executor = ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_worker,
            initargs=(os.getpid(),),
        )
        executor.submit(int).result()
    return executor


#: Thread-count variables of the BLAS/OpenMP libraries NumPy and SciPy may use.
_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_workers() -> Iterator[None]:
    """Worker processes started inside this block use one BLAS thread each (unless the user
    set the variables): with one trial per core, multithreaded matrix products in every worker
    would oversubscribe the cores."""
    saved = {name: os.environ.get(name) for name in _THREAD_VARIABLES}
    for name in _THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _start_worker(parent: int) -> None:
    """Worker initializer: the heap tuned as the parent chose
    (:func:`infoseek.envs.heap.tune_from_environment`), and :func:`_die_with_parent`."""
    from infoseek.envs import heap

    heap.tune_from_environment()
    _die_with_parent(parent)


def _die_with_parent(parent: int) -> None:
    """On Linux, ask the kernel to kill this worker when its parent dies (a killed ``bench``
    then leaves no worker processes behind); a worker whose parent ``parent`` died before this
    ran (a slow start on a loaded machine) exits at once."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        try:
            ctypes.CDLL("libc.so.6").prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # pragma: no cover - exotic libc
            pass
    if os.getppid() != parent:
        os._exit(1)


def _terminate(processes: Iterable[multiprocessing.process.BaseProcess]) -> None:
    """Terminate ``processes`` (SIGTERM, then SIGKILL after 5 s) and reap them."""
    processes = list(processes)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5.0)
        if process.is_alive():
            process.kill()
            process.join()


# ------------------------------------------------------------------------------------------ ray
def _ray(specs: Iterable[TrialSpec], workers: int, address: str | None) -> Finished:
    """Trials as Ray tasks; a task whose worker died is retried by Ray (``max_retries``), one
    that raised is not (``retry_exceptions=False``)."""
    try:
        import ray
    except ImportError:
        raise ValueError(
            "--backend ray needs the 'ray' package (pip install infoseek[distributed])"
        ) from None
    started_here = _start_ray(ray, workers, address)
    pending: dict[Any, TrialSpec] = {}
    queue = iter(specs)
    try:
        remote_trial = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(
            run_trial
        )
        for spec in itertools.islice(queue, IN_FLIGHT_PER_WORKER * workers):
            pending[remote_trial.remote(spec)] = spec
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                spec = pending.pop(ref)
                try:
                    record = ray.get(ref)
                except Exception as error:
                    raise TrialFailedError(f"{spec.describe()} failed: {error!r}") from error
                following = next(queue, None)
                if following is not None:
                    pending[remote_trial.remote(following)] = following
                yield spec, record
    finally:
        for ref in pending:  # interrupted or failed: drop the trials not yet finished
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()


def _start_ray(ray: Any, workers: int, address: str | None) -> bool:
    """Connect to ``address`` or start a local Ray of ``workers`` CPUs, passing the pinned
    numerical environment to its workers; returns whether this call started it."""
    if ray.is_initialized():
        return False
    from infoseek.experiments.numerics import PINNED

    env_vars = {key: os.environ[key] for key in PINNED if key in os.environ}
    runtime_env = {"env_vars": env_vars} if env_vars else None
    if address:
        ray.init(address=address, log_to_driver=False, runtime_env=runtime_env)
    else:
        ray.init(
            num_cpus=workers,
            include_dashboard=False,
            log_to_driver=False,
            runtime_env=runtime_env,
        )
    return True
