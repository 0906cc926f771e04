"""Shared pytest configuration: headless plotting, seeded generators and fresh interpreters."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from infoseek.experiments.numerics import PINNED  # noqa: E402 (imports nothing heavy)


@pytest.fixture
def rng() -> np.random.Generator:
    """A fixed-seed generator, so a failing test fails the same way every time."""
    return np.random.default_rng(20061213)


@pytest.fixture
def fresh_python() -> Callable[..., subprocess.CompletedProcess[str]]:
    """``fresh_python(code, pinned=False)``: ``python -c code`` in a fresh interpreter, with the
    pinned numerical environment of stored trials if ``pinned`` (it must be set before NumPy
    loads, which this process, NumPy loaded, cannot do); stdout and stderr captured as text."""

    def run(code: str, *, pinned: bool = False) -> subprocess.CompletedProcess[str]:
        env = {k: v for k, v in os.environ.items() if k != "INFOSEEK_NATIVE_NUMERICS"}
        if pinned:
            env.update(PINNED)
        return subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
        )

    return run
