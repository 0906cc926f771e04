"""Pieces shared by the commands that run trials (``bench``, ``reproduce``, ``verify``).

Part of the command line's top layer (:mod:`infoseek.experiments.cli`): the execution options
(``--workers``, ``--backend``, ``--address``, ``--no-progress``) and :func:`run_plan`, which
runs a benchmark plan into a store, reports it on the console and turns an interruption or a
failed trial into the command's exit status.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from infoseek.experiments.bench import BenchPlan, BenchResult, run_bench
from infoseek.experiments.executors import BACKENDS, TrialFailedError, check_backend

__all__ = [
    "EXIT_INTERRUPTED",
    "add_execution_arguments",
    "execution",
    "run_plan",
]

#: Exit code of an interrupted (Ctrl-C) run: the stored trials are kept, a rerun resumes.
EXIT_INTERRUPTED = 130


def _default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def add_execution_arguments(parser: argparse.ArgumentParser) -> None:
    """``--workers``, ``--backend``, ``--address`` and ``--no-progress``."""
    parser.add_argument(
        "--workers", type=int, default=None, help="parallel workers (default: the CPUs available)"
    )
    parser.add_argument(
        "--backend",
        default=None,
        metavar="{" + ",".join(BACKENDS) + "} or MODULE:FACTORY",
        help="where trials run (default: serial for 1 worker, else process); "
        "MODULE:FACTORY builds any concurrent.futures.Executor as FACTORY(max_workers=W)",
    )
    parser.add_argument(
        "--address", default=None, help="address of an existing Ray cluster (--backend ray)"
    )
    parser.add_argument(
        "--no-progress", action="store_true", help="no progress bar (default: on a terminal)"
    )


def execution(args: argparse.Namespace) -> tuple[str, int]:
    """``(backend, workers)`` of the execution options, checked."""
    workers = args.workers if args.workers is not None else _default_workers()
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    backend = args.backend or ("serial" if workers == 1 else "process")
    check_backend(backend)
    if args.address and backend != "ray":
        raise ValueError("--address only applies to --backend ray")
    return backend, workers


def run_plan(
    plan: BenchPlan, out: Path, args: argparse.Namespace
) -> tuple[int, BenchResult | None]:
    """Run ``plan`` into the store ``out`` with the execution options of ``args`` and print
    the summary; returns the exit code and the result (``None`` when the run stopped)."""
    backend, workers = execution(args)
    total = len(plan.groups) * plan.trials
    where = backend if backend == "serial" else f"{backend} ({workers} workers)"
    print(
        f"bench {plan.env}: {len(plan.groups)} group(s) x {plan.trials} trials, {plan.steps} steps,"
        f" seed {plan.seed}, backend {where} -> {out}",
        flush=True,
    )
    try:
        result = run_bench(
            plan,
            out,
            backend=backend,
            workers=workers,
            address=args.address,
            progress=False if args.no_progress else None,
        )
    except KeyboardInterrupt:
        print(
            f"infoseek {args.command}: interrupted; finished trials are stored in {out}, "
            "rerun the same command to resume",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED, None
    except TrialFailedError as error:
        print(
            f"infoseek {args.command}: error: {error}; earlier trials are stored in {out}",
            file=sys.stderr,
        )
        return 1, None
    print(f"{result.ran} trial(s) run, {result.skipped} of {total} already stored")
    print(result.summary(plan.steps))
    return 0, result
