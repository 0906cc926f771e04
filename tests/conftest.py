"""Shared pytest configuration: headless plotting, seeded generators and fresh interpreters."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from infoseek.experiments.numerics import PINNED  # noqa: E402 (imports nothing heavy)


@pytest.fixture
def rng() -> np.random.Generator:
    """A fixed-seed generator, so a failing test fails the same way every time."""
    return np.random.default_rng(20061213)


ROOT = Path(__file__).resolve().parents[1]


def _fresh(argv: list[str], environ: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """``python ARGV`` in a fresh interpreter from the repository's root, output as text."""
    return subprocess.run(
        [sys.executable, *argv],
        env=environ,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.fixture
def fresh_python() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``fresh_python(code, pinned=False, **environ)``: ``python -c code`` in a fresh
    interpreter, with the pinned numerical environment of stored trials if ``pinned`` (it must
    be set before NumPy loads, which this process, NumPy loaded, cannot do) and ``environ``
    added; stdout and stderr captured as text."""

    def run(code: str, *, pinned: bool = False, **environ: str) -> subprocess.CompletedProcess[str]:
        env = {k: v for k, v in os.environ.items() if k != "INFOSEEK_NATIVE_NUMERICS"}
        if pinned:
            env.update(PINNED)
        env.update(environ)
        return _fresh(["-c", code], env)

    return run


@pytest.fixture
def fresh_cli() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``fresh_cli(args, **environ)``: ``infoseek ARGS`` (``python -m infoseek.experiments``) in
    a fresh interpreter, which pins the numerical environment itself for trial commands;
    ``OPENBLAS_CORETYPE`` and ``NUMBA_CPU_NAME`` are left out of the inherited environment
    (the pin, not the caller, sets them) before ``environ`` is added."""

    def run(args: list[str], **environ: str) -> subprocess.CompletedProcess[str]:
        unset = ("OPENBLAS_CORETYPE", "NUMBA_CPU_NAME")
        env = {k: v for k, v in os.environ.items() if k not in unset}
        env.update(environ)
        return _fresh(["-m", "infoseek.experiments", *args], env)

    return run
