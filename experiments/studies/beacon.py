"""Beacon Monte Carlo (``infoseek reproduce beacon`` / ``beacon_v1``; not in the paper, which
shows one episode).

Fig. 1-style paired trials of the pairwise-node, single-node, random and lawnmower policies
with ``n_v = 4`` quadrotors and of the pairwise-node planner with 2 and 3, stored in
``OUT/store`` and drawn as ``OUT/beacon.png`` / ``.svg``; ``infoseek claims OUT/store`` tests
whether pairwise beats single (Claim A) and whether larger fleets localise faster (Claim B).

* ``beacon``: ``beacon_v0`` with its defaults, 500 trials per curve by default.
* ``beacon_v1``: the same on ``beacon_v1``, 1000 trials per curve by default. Its trials run as
  ``beacon_v0`` with :data:`BEACON_V1_SETTINGS`, which is ``beacon_v1`` bit for bit
  (``tests/test_envs.py``); trial seeds depend on the environment id, so this way trial ``k``
  faces the same beacon as trial ``k`` of the ``beacon`` study and the two studies pair trial
  by trial (the effect of ``beacon_v1``'s filter on every curve).
"""

from __future__ import annotations

from typing import Any

from infoseek.experiments.bench import BenchPlan
from infoseek.experiments.environments import changed_settings

__all__ = ["BEACON_ENV", "BEACON_GROUPS", "BEACON_V1_SETTINGS", "beacon_plan", "beacon_v1_plan"]

BEACON_ENV = "beacon_v0"
BEACON_GROUPS: tuple[tuple[str, int], ...] = (
    ("pairwise", 4),
    ("single", 4),
    ("random", 4),
    ("lawnmower", 4),
    ("pairwise", 2),
    ("pairwise", 3),
)
#: Trials per curve.
DEFAULT_TRIALS = 500
#: Trials per curve of the ``beacon_v1`` study.
DEFAULT_V1_TRIALS = 1000
#: ``beacon_v1``'s settings that differ from ``beacon_v0``'s (its registered keywords).
BEACON_V1_SETTINGS: dict[str, Any] = changed_settings("beacon_v1", "beacon_v0")


def beacon_plan(
    trials: int = DEFAULT_TRIALS,
    steps: int | None = None,
    particles: int | None = None,
    seed: int = 0,
) -> BenchPlan:
    """The benchmark plan of the beacon Monte Carlo study (module docstring)."""
    return BenchPlan.for_study(BEACON_ENV, BEACON_GROUPS, trials, steps, particles, seed)


def beacon_v1_plan(
    trials: int = DEFAULT_V1_TRIALS,
    steps: int | None = None,
    particles: int | None = None,
    seed: int = 0,
) -> BenchPlan:
    """The plan of the study on ``beacon_v1``: :func:`beacon_plan` with
    :data:`BEACON_V1_SETTINGS` (module docstring)."""
    return BenchPlan.for_study(
        BEACON_ENV, BEACON_GROUPS, trials, steps, particles, seed, BEACON_V1_SETTINGS
    )
