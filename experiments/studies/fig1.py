"""The paper's Fig. 1 (``infoseek reproduce fig1``): bearings-only search, Monte Carlo.

The paper fixes the domain (a 40 x 40 square), the uniform prior, the vehicle types (airplanes
with fixed speed and a limited turn rate starting close together), the sensor model (additive
Gaussian bearing noise), one observation per vehicle and step shared by all, 1000 trials per
Fig. 1 curve, the localisation radius 1 and the fleet sizes 2, 3, 4, 10. Everything else is our
choice, the environment's defaults: bearing noise ``sigma = 0.1`` rad, airplane speed 1 unit/s
and turn rate <= 0.5 rad/s, the start grid (spacing 2 around ``(5, 5)``), ``dt = 1``, 2000
particles per vehicle, roughening and progressive correction, and 60-step episodes.

Fig. 1 (section IV.A, ``bearings_v0``): Monte Carlo trials (1000 per curve in the paper) of the
single- and pairwise-node planners with ``n_v = 4`` airplanes (panel a) and of the
pairwise-node planner with 2, 3, 4 and 10 airplanes (panel b), stored in ``OUT/store`` by the
resumable benchmark (:mod:`infoseek.experiments.bench`) and drawn by
:mod:`infoseek.experiments.plot` as ``OUT/fig1.png`` and ``OUT/fig1.svg``. The pairwise
``n_v = 4`` curve is shared by both panels.
"""

from __future__ import annotations

from infoseek.experiments.bench import BenchPlan

__all__ = ["FIG1_ENV", "FIG1_GROUPS", "fig1_plan"]

FIG1_ENV = "bearings_v0"
FIG1_GROUPS: tuple[tuple[str, int], ...] = (
    ("single", 4),
    ("pairwise", 4),
    ("pairwise", 2),
    ("pairwise", 3),
    ("pairwise", 10),
)
#: Trials per curve (the paper's).
DEFAULT_TRIALS = 1000


def fig1_plan(
    trials: int = DEFAULT_TRIALS,
    steps: int | None = None,
    particles: int | None = None,
    seed: int = 0,
) -> BenchPlan:
    """The benchmark plan of Fig. 1 (``steps`` default: the environment's episode length)."""
    return BenchPlan.for_study(FIG1_ENV, FIG1_GROUPS, trials, steps, particles, seed)
