"""Beacon Monte Carlo (``infoseek reproduce beacon``; not in the paper, which shows one episode).

Fig. 1-style paired trials on ``beacon_v0`` (500 per curve by default) of the pairwise-node,
single-node, random and lawnmower policies with ``n_v = 4`` quadrotors and of the pairwise-node
planner with 2 and 3, stored in ``OUT/store`` and drawn as ``OUT/beacon.png`` / ``.svg``;
``infoseek claims OUT/store`` tests whether pairwise beats single (Claim A) and whether larger
fleets localise faster (Claim B). Settings are ``beacon_v0``'s defaults.
"""

from __future__ import annotations

from infoseek.experiments.bench import BenchPlan

__all__ = ["BEACON_ENV", "BEACON_GROUPS", "beacon_plan"]

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


def beacon_plan(
    trials: int = DEFAULT_TRIALS,
    steps: int | None = None,
    particles: int | None = None,
    seed: int = 0,
) -> BenchPlan:
    """The benchmark plan of the beacon Monte Carlo study (module docstring)."""
    return BenchPlan.for_study(BEACON_ENV, BEACON_GROUPS, trials, steps, particles, seed)
