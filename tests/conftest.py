"""Shared pytest configuration: headless plotting and seeded generators."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def rng() -> np.random.Generator:
    """A fixed-seed generator, so a failing test fails the same way every time."""
    return np.random.default_rng(20061213)
